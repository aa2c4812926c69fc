// OccupancySlice <-> ROS map_server PGM + YAML.
#include "rgbdmap/export/slice_export.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "atomic_file.hpp"

namespace rgbdmap {
namespace {

constexpr double kOccupiedThresh = 0.65;
constexpr double kFreeThresh = 0.196;
constexpr uint8_t kPgmFree = 254, kPgmOccupied = 0, kPgmUnknown = 205;

using SliceResult = Result<msg::OccupancySlice>;

Status checkSlice(const msg::OccupancySlice& s) {
  if (s.width < 1 || s.height < 1 || s.width > msg::kMaxGridSide || s.height > msg::kMaxGridSide)
    return Status::failure("grid size out of range");
  if (s.cells.size() != static_cast<size_t>(s.width) * static_cast<size_t>(s.height))
    return Status::failure("cell count != width * height");
  if (!(std::isfinite(s.resolution_m) && s.resolution_m > 0.0f))
    return Status::failure("resolution must be > 0");
  if (!se3::isValid(s.T_map_grid)) return Status::failure("T_map_grid is not a rigid transform");
  for (int8_t c : s.cells)
    if (c < -1 || c > 100) return Status::failure("cell value out of range (-1..100)");
  return Status::success();
}

uint8_t pgmValue(int8_t cell) {
  if (cell < 0) return kPgmUnknown;
  const double p = cell / 100.0;
  if (p >= kOccupiedThresh) return kPgmOccupied;
  if (p < kFreeThresh) return kPgmFree;
  return kPgmUnknown;
}

std::string imageReference(const std::string& pgm_path, const std::string& yaml_path) {
  namespace fs = std::filesystem;
  const fs::path pgm(pgm_path), yaml(yaml_path);
  if (fs::absolute(pgm).parent_path() == fs::absolute(yaml).parent_path()) return pgm.filename().string();
  return fs::absolute(pgm).string();
}

/// A float field as written: the fewest digits that read back as the same float (0.05, not the double
/// 0.0500000007).
std::string floatText(float v) {
  std::string text;
  for (int digits = 6; digits <= 9; ++digits) {
    std::ostringstream o;
    o << std::setprecision(digits) << v;
    text = o.str();
    if (std::strtof(text.c_str(), nullptr) == v) break;
  }
  return text;
}

std::string sliceYaml(const msg::OccupancySlice& s, const std::string& image) {
  const SE3& T = s.T_map_grid;
  const Vec3& t = T.translation();
  const double yaw = std::atan2(T.linear()(1, 0), T.linear()(0, 0)) + 0.0;  // + 0.0: never "-0"
  const Eigen::Quaterniond q = se3::quat(T);
  std::ostringstream y;
  y << std::setprecision(9);
  y << "image: " << image << "\nmode: trinary\nresolution: " << floatText(s.resolution_m) << "\norigin: ["
    << t.x() << ", " << t.y() << ", " << yaw << "]\nnegate: 0\noccupied_thresh: " << kOccupiedThresh
    << "\nfree_thresh: " << kFreeThresh << "\n# rgbdmap (ignored by map_server): the exact 3-D grid pose\n";
  if (!s.robot_id.empty()) y << "robot_id: \"" << s.robot_id << "\"\n";
  y << "utime: " << s.header.utime << "\nz_min_m: " << floatText(s.z_min_m)
    << "\nz_max_m: " << floatText(s.z_max_m) << "\nT_map_grid: [" << T.translation().x() << ", "
    << T.translation().y() << ", " << T.translation().z() << ", " << q.x() << ", " << q.y() << ", " << q.z()
    << ", " << q.w() << "]\n";
  return y.str();
}

/// Skips whitespace and '#' comments between PGM header fields.
size_t skipPgmSpace(const std::string& b, size_t i) {
  while (i < b.size()) {
    if (b[i] == '#') {
      while (i < b.size() && b[i] != '\n') ++i;
    } else if (std::isspace(static_cast<unsigned char>(b[i]))) {
      ++i;
    } else {
      break;
    }
  }
  return i;
}

bool readPgmInt(const std::string& b, size_t* i, int* value) {
  *i = skipPgmSpace(b, *i);
  long v = 0;
  size_t digits = 0;
  while (*i < b.size() && std::isdigit(static_cast<unsigned char>(b[*i])) && digits < 9) {
    v = v * 10 + (b[*i] - '0');
    ++*i;
    ++digits;
  }
  *value = static_cast<int>(v);
  return digits > 0 && digits < 9;
}

struct Pgm {
  int width = 0, height = 0;
  std::string pixels;  ///< row-major, top row first
};

Result<Pgm> readPgm(const std::string& path) {
  auto file = export_detail::readWholeFile(path, 64 + size_t{msg::kMaxGridSide} * msg::kMaxGridSide + 4096);
  if (!file) return Result<Pgm>::failure(file.error());
  const std::string& b = *file;
  if (b.size() < 2 || b[0] != 'P' || b[1] != '5')
    return Result<Pgm>::failure(path + ": not a binary PGM (P5)");
  size_t i = 2;
  Pgm pgm;
  int maxval = 0;
  if (!readPgmInt(b, &i, &pgm.width) || !readPgmInt(b, &i, &pgm.height) || !readPgmInt(b, &i, &maxval))
    return Result<Pgm>::failure(path + ": malformed PGM header");
  if (pgm.width < 1 || pgm.height < 1 || pgm.width > msg::kMaxGridSide || pgm.height > msg::kMaxGridSide)
    return Result<Pgm>::failure(path + ": PGM size out of range");
  if (maxval != 255) return Result<Pgm>::failure(path + ": PGM max value must be 255");
  if (i >= b.size() || !std::isspace(static_cast<unsigned char>(b[i])))
    return Result<Pgm>::failure(path + ": malformed PGM header");
  ++i;
  const size_t n = static_cast<size_t>(pgm.width) * static_cast<size_t>(pgm.height);
  if (b.size() - i != n)
    return Result<Pgm>::failure(path + ": PGM has " + std::to_string(b.size() - i) +
                                " pixel bytes, expected " + std::to_string(n));
  pgm.pixels = b.substr(i);
  return pgm;
}

/// The pose fields of the YAML: rgbdmap's exact T_map_grid, or map_server's origin in the plane frame.
Result<SE3> gridPose(const YAML::Node& y) {
  SE3 T = SE3::Identity();
  if (y["T_map_grid"]) {
    const auto v = y["T_map_grid"].as<std::vector<double>>();
    if (v.size() != 7) return Result<SE3>::failure("T_map_grid needs 7 numbers");
    T = se3::fromTum(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
  } else {
    const auto o = y["origin"].as<std::vector<double>>();
    if (o.size() != 3) return Result<SE3>::failure("origin needs 3 numbers");
    T.linear() = Eigen::AngleAxisd(o[2], Vec3::UnitZ()).toRotationMatrix();
    T.translation() = Vec3(o[0], o[1], 0.0);
  }
  if (!se3::isValid(T)) return Result<SE3>::failure("grid pose is not finite");
  return T;
}

int8_t cellFromPixel(uint8_t pixel, bool negate, double occupied_thresh, double free_thresh) {
  const double p = negate ? pixel / 255.0 : (255.0 - pixel) / 255.0;
  if (p > occupied_thresh) return msg::OccupancySlice::kOccupied;
  if (p < free_thresh) return msg::OccupancySlice::kFree;
  return msg::OccupancySlice::kUnknown;
}

SliceResult parseSliceYaml(const std::string& yaml_path, const YAML::Node& y) {
  msg::OccupancySlice s;
  for (const char* key : {"image", "resolution", "origin"})
    if (!y[key]) return SliceResult::failure(yaml_path + ": missing '" + key + "'");
  const double resolution = y["resolution"].as<double>();
  if (!(std::isfinite(resolution) && resolution > 0.0 && resolution <= 10.0))
    return SliceResult::failure(yaml_path + ": resolution out of range");
  s.resolution_m = static_cast<float>(resolution);
  auto T = gridPose(y);
  if (!T) return SliceResult::failure(yaml_path + ": " + T.error());
  s.T_map_grid = *T;
  if (y["robot_id"]) s.robot_id = y["robot_id"].as<std::string>();
  if (y["utime"]) s.header.utime = y["utime"].as<int64_t>();
  if (y["z_min_m"]) s.z_min_m = y["z_min_m"].as<float>();
  if (y["z_max_m"]) s.z_max_m = y["z_max_m"].as<float>();
  return s;
}

}  // namespace

Status writeSlice(const msg::OccupancySlice& slice, const std::string& pgm_path,
                  const std::string& yaml_path) {
  if (Status s = checkSlice(slice); !s) return Status::failure("slice: " + s.error());
  const std::string title =
      slice.robot_id.empty() ? "global occupancy map" : "occupancy slice of " + slice.robot_id;
  std::string pgm = "P5\n# rgbdmap " + title + "\n" + std::to_string(slice.width) + " " +
                    std::to_string(slice.height) + "\n255\n";
  const size_t header = pgm.size();
  pgm.resize(header + slice.cells.size());
  for (int row = 0; row < slice.height; ++row) {
    const int image_row = slice.height - 1 - row;  // map_saver: the image's top row is the grid's last row
    for (int col = 0; col < slice.width; ++col)
      pgm[header + static_cast<size_t>(image_row) * slice.width + col] =
          static_cast<char>(pgmValue(slice.cells[static_cast<size_t>(row) * slice.width + col]));
  }
  if (Status s = export_detail::writeFileAtomically(pgm_path, pgm); !s)
    return Status::failure("slice: " + s.error());
  Status s =
      export_detail::writeFileAtomically(yaml_path, sliceYaml(slice, imageReference(pgm_path, yaml_path)));
  return s ? s : Status::failure("slice: " + s.error());
}

Result<msg::OccupancySlice> readSlice(const std::string& yaml_path) {
  YAML::Node y;
  try {
    y = YAML::LoadFile(yaml_path);
  } catch (const std::exception& e) {
    return SliceResult::failure(yaml_path + ": " + e.what());
  }
  SliceResult parsed = SliceResult::failure("");
  double occupied_thresh = kOccupiedThresh, free_thresh = kFreeThresh;
  bool negate = false;
  std::string image;
  try {
    if (!y.IsMap()) return SliceResult::failure(yaml_path + ": not a YAML map");
    parsed = parseSliceYaml(yaml_path, y);
    if (y["occupied_thresh"]) occupied_thresh = y["occupied_thresh"].as<double>();
    if (y["free_thresh"]) free_thresh = y["free_thresh"].as<double>();
    if (y["negate"]) negate = y["negate"].as<int>() != 0;
    if (y["image"]) image = y["image"].as<std::string>();
  } catch (const std::exception& e) {
    return SliceResult::failure(yaml_path + ": malformed value (" + e.what() + ")");
  }
  if (!parsed) return parsed;
  if (!(free_thresh >= 0.0 && free_thresh < occupied_thresh && occupied_thresh <= 1.0))
    return SliceResult::failure(yaml_path + ": thresholds out of range");
  std::filesystem::path pgm_path(image);
  if (pgm_path.is_relative()) pgm_path = std::filesystem::path(yaml_path).parent_path() / pgm_path;
  auto pgm = readPgm(pgm_path.string());
  if (!pgm) return SliceResult::failure(pgm.error());
  msg::OccupancySlice s = std::move(*parsed);
  s.width = pgm->width;
  s.height = pgm->height;
  s.cells.resize(pgm->pixels.size());
  for (int row = 0; row < s.height; ++row)
    for (int col = 0; col < s.width; ++col)
      s.cells[static_cast<size_t>(row) * s.width + col] = cellFromPixel(
          static_cast<uint8_t>(pgm->pixels[static_cast<size_t>(s.height - 1 - row) * s.width + col]), negate,
          occupied_thresh, free_thresh);
  return s;
}

}  // namespace rgbdmap
