// camera.yaml of a dataset folder: read (readDatasetCamera in tum_dataset.hpp) and written
// (datasetCameraYaml).
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"

namespace rgbdmap {
namespace {

/// Collects every problem of one file so that the caller sees them all at once.
class YamlErrors {
 public:
  explicit YamlErrors(std::string path) : path_(std::move(path)) {}
  void add(const YAML::Node& node, const std::string& message) {
    const int line = node.Mark().line;
    errors_.push_back(path_ + (line >= 0 ? ":" + std::to_string(line + 1) : std::string()) + ": " + message);
  }
  bool empty() const { return errors_.empty(); }
  std::string joined() const {
    std::string out;
    for (const auto& e : errors_) out += (out.empty() ? "" : "; ") + e;
    return out;
  }

 private:
  std::string path_;
  std::vector<std::string> errors_;
};

template <typename T>
void readScalar(const YAML::Node& cam, const char* key, bool required, T* out, YamlErrors* errors) {
  const YAML::Node node = cam[key];
  if (!node) {
    if (required) errors->add(cam, std::string("camera.") + key + " is missing");
    return;
  }
  try {
    *out = node.as<T>();
  } catch (const YAML::Exception&) {
    errors->add(node, std::string("camera.") + key + ": '" +
                          (node.IsScalar() ? node.Scalar() : "<not a scalar>") + "' is not " +
                          (std::is_integral<T>::value ? "an integer" : "a number"));
  }
}

void readDistortion(const YAML::Node& cam, CameraIntrinsics* k, YamlErrors* errors) {
  const YAML::Node node = cam["distortion"];
  k->distortion = {0, 0, 0, 0, 0};  // absent: ideal pinhole
  if (!node) return;
  if (!node.IsSequence() || node.size() != 5) {
    errors->add(node, "camera.distortion must be a list of 5 numbers [k1, k2, p1, p2, k3]");
    return;
  }
  for (size_t i = 0; i < 5; ++i) {
    try {
      k->distortion[i] = node[i].as<double>();
    } catch (const YAML::Exception&) {
      errors->add(node[i], "camera.distortion[" + std::to_string(i) + "] is not a number");
    }
  }
}

void checkKeys(const YAML::Node& cam, YamlErrors* errors) {
  static const std::set<std::string> kKnown = {"fx",     "fy",         "cx",          "cy",       "width",
                                               "height", "distortion", "depth_scale", "readout_s"};
  for (const auto& kv : cam) {
    const std::string key = kv.first.Scalar();
    if (!kKnown.count(key)) errors->add(kv.first, "unknown key camera." + key);
  }
}

Result<CameraIntrinsics> parseCamera(const YAML::Node& root, const std::string& path) {
  YamlErrors errors(path);
  const YAML::Node cam = root.IsMap() ? root["camera"] : YAML::Node();
  if (!cam || !cam.IsMap()) return Result<CameraIntrinsics>::failure(path + ": expected a 'camera:' map");
  CameraIntrinsics k;
  checkKeys(cam, &errors);
  readScalar(cam, "fx", true, &k.fx, &errors);
  readScalar(cam, "fy", true, &k.fy, &errors);
  readScalar(cam, "cx", true, &k.cx, &errors);
  readScalar(cam, "cy", true, &k.cy, &errors);
  readScalar(cam, "width", true, &k.width, &errors);
  readScalar(cam, "height", true, &k.height, &errors);
  readScalar(cam, "depth_scale", false, &k.depth_scale, &errors);
  readScalar(cam, "readout_s", false, &k.readout_s, &errors);
  readDistortion(cam, &k, &errors);
  if (!errors.empty()) return Result<CameraIntrinsics>::failure(errors.joined());
  const std::string invalid = k.validate();
  if (!invalid.empty()) return Result<CameraIntrinsics>::failure(path + ": " + invalid);
  return k;
}

}  // namespace

Result<std::optional<CameraIntrinsics>> readDatasetCamera(const std::string& dir) {
  using R = Result<std::optional<CameraIntrinsics>>;
  const std::string path = (std::filesystem::path(dir) / "camera.yaml").string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::optional<CameraIntrinsics>();
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    const std::string line = e.mark.line >= 0 ? ":" + std::to_string(e.mark.line + 1) : std::string();
    return R::failure(path + line + ": " + e.msg);
  }
  auto k = parseCamera(root, path);
  if (!k) return R::failure(k.error());
  return std::optional<CameraIntrinsics>(k.value());
}

std::string datasetCameraYaml(const CameraIntrinsics& k, const std::string& comment) {
  std::ostringstream os;
  os << "# " << comment << "\ncamera:\n"
     << "  fx: " << formatExact(k.fx) << "\n  fy: " << formatExact(k.fy) << "\n  cx: " << formatExact(k.cx)
     << "\n  cy: " << formatExact(k.cy) << "\n  width: " << k.width << "\n  height: " << k.height
     << "\n  distortion: [";
  for (size_t i = 0; i < k.distortion.size(); ++i) os << (i ? ", " : "") << formatExact(k.distortion[i]);
  os << "]\n  depth_scale: " << formatExact(k.depth_scale) << "\n  readout_s: " << formatExact(k.readout_s)
     << "\n";
  return os.str();
}

}  // namespace rgbdmap
