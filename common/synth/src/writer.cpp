// Writes a synthetic sequence in TUM layout. Frames are rendered and encoded in parallel (one frame per
// task); every byte depends only on the config, so the same seed gives identical files.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string_view>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;

std::string describe(const SynthConfig& c) {
  return "rgbdmap synth: scene " + c.scene + ", seed " + std::to_string(c.seed) + ", " +
         std::to_string(c.frames) + " frames";
}

std::string fileList(const SynthConfig& c, bool depth) {
  std::string out = depth ? "# depth maps\n" : "# color images\n";
  out += "# " + describe(c) + "\n# timestamp filename\n";
  for (int i = 0; i < c.frames; ++i) {
    const std::string ts = formatTimestamp(depth ? c.depthTimestamp(i) : c.colorTimestamp(i));
    out += ts + (depth ? " depth/" : " rgb/") + ts + ".png\n";
  }
  return out;
}

Status writeText(const fs::path& path, const std::string& text) {
  return writeFileAtomic(path.string(), text);
}

/// The image as PNG, written atomically; the reason on failure ("" on success).
std::string writePng(const fs::path& path, const cv::Mat& image, const std::vector<int>& params) {
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png, params)) return path.string() + ": cannot encode PNG";
  const Status s =
      writeFileAtomic(path.string(), std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  return s ? std::string() : s.error();
}

Status prepareDirectories(const fs::path& out) {
  for (const char* sub : {"rgb", "depth"}) {
    std::error_code ec;
    fs::create_directories(out / sub, ec);
    if (ec) return Status::failure((out / sub).string() + ": cannot create directory: " + ec.message());
    const auto existing = std::distance(fs::directory_iterator(out / sub, ec), fs::directory_iterator());
    if (existing > 0)
      log::warn("synth: ", (out / sub).string(), " already holds ", existing,
                " files; same-named ones are overwritten, others are stale (not listed in the index files)");
  }
  return Status::success();
}

/// Renders and writes one frame; returns the reason on failure.
std::string writeFrame(const SyntheticScene& scene, int i, const fs::path& out) {
  const SynthConfig& c = scene.config();
  // Fastest PNG path: with no IMWRITE_PNG_COMPRESSION given, OpenCV uses zlib level 1 (Z_BEST_SPEED, the
  // same level as IMWRITE_PNG_COMPRESSION 1) with the SUB row filter; passing the level explicitly makes
  // libpng try every filter per row (2-3x slower here). Huffman-only coding skips the LZ77 search, which
  // finds little in noisy images anyway.
  const std::vector<int> png = {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY};
  try {
    const RgbdFrame frame = scene.renderFrame(i);
    const fs::path rgb = out / "rgb" / (formatTimestamp(c.colorTimestamp(i)) + ".png");
    const fs::path depth = out / "depth" / (formatTimestamp(c.depthTimestamp(i)) + ".png");
    if (std::string e = writePng(rgb, frame.color, png); !e.empty()) return e;
    if (std::string e = writePng(depth, frame.depth, png); !e.empty()) return e;
  } catch (const cv::Exception& e) {
    return "frame " + std::to_string(i) + ": " + e.what();
  }
  return "";
}

Status writeFrames(const SyntheticScene& scene, const fs::path& out) {
  const int n = scene.config().frames;
  std::vector<std::string> errors(static_cast<size_t>(n));
  cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) errors[static_cast<size_t>(i)] = writeFrame(scene, i, out);
  });
  int failed = 0;
  std::string first;
  for (const auto& e : errors)
    if (!e.empty() && failed++ == 0) first = e;
  if (failed) return Status::failure(std::to_string(failed) + " frames not written; first: " + first);
  return Status::success();
}

}  // namespace

Status writeSyntheticSequence(const SynthConfig& config, const std::string& out_dir) {
  const std::string invalid = config.validate();  // cheap checks first, then the folders, then the work
  if (!invalid.empty()) return Status::failure("invalid synthetic config: " + invalid);
  const fs::path out(out_dir);
  if (Status s = prepareDirectories(out); !s) return s;
  auto scene = SyntheticScene::build(config);
  if (!scene) return Status::failure(scene.error());
  if (Status s =
          writeText(out / "camera.yaml",
                    datasetCameraYaml(config.camera,
                                      describe(config) +
                                          ". Ideal pinhole, global shutter; depth is registered to colour."));
      !s)
    return s;
  if (Status s = writeText(out / "rgb.txt", fileList(config, false)); !s) return s;
  if (Status s = writeText(out / "depth.txt", fileList(config, true)); !s) return s;
  const std::string gt_path = (out / "groundtruth.txt").string();
  if (Status s = writeTumTrajectory(gt_path, scene->trajectory(), describe(config) + ", exact poses"); !s)
    return s;
  return writeFrames(*scene, out);
}

}  // namespace rgbdmap
