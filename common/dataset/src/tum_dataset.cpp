#include "rgbdmap/dataset/tum_dataset.hpp"

#include "rgbdmap/common/text_lines.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/dataset/association.hpp"
#include "rgbdmap/dataset/dataset_config_table.hpp"

namespace rgbdmap {
namespace fs = std::filesystem;
namespace {

std::string where(const std::string& source, int line) { return source + ":" + std::to_string(line) + ": "; }

std::string typeName(const cv::Mat& m) {
  static const char* kDepths[] = {"8U", "8S", "16U", "16S", "32S", "32F", "64F", "16F"};
  return std::string("CV_") + kDepths[m.depth() & 7] + "C" + std::to_string(m.channels());
}

/// imread on a missing file makes OpenCV print a warning; a library must not, so check first.
bool isFile(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

std::string sizeName(const cv::Mat& m) { return std::to_string(m.cols) + "x" + std::to_string(m.rows); }

/// The image's size against the expected one (0 = any); empty when it fits.
std::string checkSize(const cv::Mat& m, const DatasetOptions& o) {
  if ((o.expected_width > 0 && m.cols != o.expected_width) ||
      (o.expected_height > 0 && m.rows != o.expected_height))
    return "image is " + sizeName(m) + ", expected " + std::to_string(o.expected_width) + "x" +
           std::to_string(o.expected_height);
  return {};
}

Result<cv::Mat> readColor(const std::string& path, const DatasetOptions& options) {
  if (!isFile(path)) return Result<cv::Mat>::failure(path + ": colour image not found");
  cv::Mat color = cv::imread(path, cv::IMREAD_COLOR);  // any depth/channels -> CV_8UC3 BGR, grey expanded
  if (color.empty())
    return Result<cv::Mat>::failure(path + ": cannot read colour image (missing or unsupported)");
  if (color.type() != CV_8UC3)
    return Result<cv::Mat>::failure(path + ": colour image has type " + typeName(color) +
                                    ", expected CV_8UC3");
  const std::string size_error = checkSize(color, options);
  if (!size_error.empty()) return Result<cv::Mat>::failure(path + ": " + size_error);
  return color;
}

Result<cv::Mat> readDepth(const std::string& path, const DatasetOptions& options) {
  if (!isFile(path)) return Result<cv::Mat>::failure(path + ": depth image not found");
  cv::Mat depth = cv::imread(path, cv::IMREAD_UNCHANGED);  // keeps 16-bit PNG / PGM as they are
  if (depth.empty())
    return Result<cv::Mat>::failure(path + ": cannot read depth image (missing or unsupported)");
  if (depth.type() != CV_16UC1)
    return Result<cv::Mat>::failure(path + ": depth image has type " + typeName(depth) +
                                    ", expected 16-bit single channel (CV_16UC1)");
  const std::string size_error = checkSize(depth, options);
  if (!size_error.empty()) return Result<cv::Mat>::failure(path + ": " + size_error);
  return depth;
}

}  // namespace

std::string DatasetOptions::validate() const { return joinProblems(datasetConfigTable().problems(*this)); }

Result<std::vector<ImageListEntry>> parseImageList(const std::string& text, const std::string& source_name) {
  using R = Result<std::vector<ImageListEntry>>;
  std::vector<ImageListEntry> out;
  for (const TextLine& line : dataLines(text)) {
    if (line.fields.size() != 2)
      return R::failure(where(source_name, line.number) + "expected 2 fields (timestamp filename), got " +
                        std::to_string(line.fields.size()));
    const auto t = parseFiniteNumber(line.fields[0], "timestamp");
    if (!t) return R::failure(where(source_name, line.number) + t.error());
    out.push_back({*t, line.fields[1]});
  }
  return out;
}

Result<std::vector<ImageListEntry>> readImageList(const std::string& path) {
  const auto text = readTextFile(path);
  if (!text) return Result<std::vector<ImageListEntry>>::failure(text.error());
  return parseImageList(*text, path);
}

std::vector<FrameEntry> associateImages(const std::vector<ImageListEntry>& rgb,
                                        const std::vector<ImageListEntry>& depth, double max_time_diff) {
  std::vector<double> t_rgb, t_depth;
  for (const auto& e : rgb) t_rgb.push_back(e.timestamp);
  for (const auto& e : depth) t_depth.push_back(e.timestamp);
  std::vector<FrameEntry> frames;
  for (const IndexPair& m : associate(t_rgb, t_depth, max_time_diff))
    frames.push_back({rgb[m.a].timestamp, rgb[m.a].path, depth[m.b].timestamp, depth[m.b].path});
  return frames;
}

Result<TumDataset> TumDataset::open(const std::string& dir, const DatasetOptions& options) {
  using R = Result<TumDataset>;
  const std::string option_errors = options.validate();
  if (!option_errors.empty()) return R::failure("dataset options: " + option_errors);
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    return R::failure(dir + ": dataset folder does not exist or is not a folder");
  auto rgb = readImageList((fs::path(dir) / "rgb.txt").string());
  if (!rgb) return R::failure(rgb.error());
  auto depth = readImageList((fs::path(dir) / "depth.txt").string());
  if (!depth) return R::failure(depth.error());

  TumDataset ds;
  ds.dir_ = dir;
  ds.options_ = options;
  ds.rgb_count_ = rgb->size();
  ds.depth_count_ = depth->size();
  ds.frames_ = associateImages(*rgb, *depth, options.max_time_diff);
  if (ds.frames_.empty())
    return R::failure(dir + ": no colour frame has a depth image within " +
                      formatShort(options.max_time_diff) + " s (" + std::to_string(ds.rgb_count_) +
                      " colour, " + std::to_string(ds.depth_count_) + " depth entries)");
  const fs::path gt_path = fs::path(dir) / "groundtruth.txt";
  if (fs::exists(gt_path, ec)) {
    auto gt = readTumTrajectory(gt_path.string());
    if (!gt) return R::failure(gt.error());
    ds.ground_truth_ = std::move(gt).value();
  }
  log::info("dataset ", dir, ": ", ds.frames_.size(), " frames (", ds.rgb_count_, " colour, ",
            ds.depth_count_, " depth, ", ds.droppedRgbCount(),
            " colour without depth dropped), ground truth: ",
            ds.ground_truth_ ? std::to_string(ds.ground_truth_->size()) + " poses" : std::string("none"));
  return ds;
}

Result<RgbdFrame> TumDataset::load(size_t i) const {
  using R = Result<RgbdFrame>;
  if (i >= frames_.size())
    return R::failure(dir_ + ": frame " + std::to_string(i) + " out of range (" + std::to_string(size()) +
                      ")");
  const FrameEntry& e = frames_[i];
  auto color = readColor((fs::path(dir_) / e.rgb_path).string(), options_);
  if (!color) return R::failure(color.error());
  auto depth = readDepth((fs::path(dir_) / e.depth_path).string(), options_);
  if (!depth) return R::failure(depth.error());
  if (color->size() != depth->size())
    return R::failure(dir_ + ": colour " + e.rgb_path + " is " + sizeName(*color) + " but depth " +
                      e.depth_path + " is " + sizeName(*depth));
  RgbdFrame frame;
  frame.timestamp = e.rgb_timestamp;
  frame.color = std::move(color).value();
  frame.depth = std::move(depth).value();
  frame.depth_scale = options_.depth_scale;
  return frame;
}

}  // namespace rgbdmap
