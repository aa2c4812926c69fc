// TumRecorder and RecordingSource.
#include "rgbdmap/source/frame_recorder.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/text_lines.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;

Status writePng(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> png;
  const std::vector<int> params = {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY};
  try {
    if (!cv::imencode(".png", image, png, params)) return Status::failure(path + ": cannot encode PNG");
  } catch (const cv::Exception& e) {
    return Status::failure(path + ": " + e.what());
  }
  AtomicWriteOptions o;
  o.sync = false;  // the folders are synced as a whole by finish()
  return writeFileAtomic(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()), o);
}

}  // namespace

Result<TumRecorder> TumRecorder::create(const std::string& dir, const CameraIntrinsics& camera) {
  for (const char* sub : {"rgb", "depth"}) {
    std::error_code ec;
    fs::create_directories(fs::path(dir) / sub, ec);
    if (ec) return Result<TumRecorder>::failure(dir + "/" + sub + ": cannot create: " + ec.message());
  }
  TumRecorder r;
  r.dir_ = dir;
  r.camera_ = camera;
  r.rgb_list_ = "# color images\n# timestamp filename\n";
  r.depth_list_ = "# depth maps\n# timestamp filename\n";
  return r;
}

Status TumRecorder::add(const RgbdFrame& frame) {
  const std::string ts = formatTimestamp(frame.timestamp);
  if (Status s = writePng(dir_ + "/rgb/" + ts + ".png", frame.color); !s) return s;
  if (Status s = writePng(dir_ + "/depth/" + ts + ".png", frame.depth); !s) return s;
  if (frame.depth_scale != camera_.depth_scale)
    return Status::failure("frame " + ts + ": depth scale " + formatExact(frame.depth_scale) +
                           " differs from the " + "recording's " + formatExact(camera_.depth_scale));
  rgb_list_ += ts + " rgb/" + ts + ".png\n";
  depth_list_ += ts + " depth/" + ts + ".png\n";
  if (++lines_ % kListEvery == 0) return writeLists();
  return Status::success();
}

Status TumRecorder::writeLists() const {
  if (Status s = writeFileAtomic(
          dir_ + "/camera.yaml",
          datasetCameraYaml(
              camera_,
              "recorded by rgbdmap; depth is registered to colour, depth_scale raw units per metre"));
      !s)
    return s;
  if (Status s = writeFileAtomic(dir_ + "/rgb.txt", rgb_list_); !s) return s;
  return writeFileAtomic(dir_ + "/depth.txt", depth_list_);
}

Status TumRecorder::finish(const std::optional<Trajectory>& ground_truth) {
  for (const char* sub : {"/rgb", "/depth"})
    if (Status s = syncFolder(dir_ + sub); !s) return s;
  if (ground_truth && !ground_truth->empty())
    if (Status s = writeTumTrajectory(dir_ + "/groundtruth.txt", *ground_truth, "ground truth of the source");
        !s)
      return s;
  return writeLists();
}

RecordingSource::RecordingSource(std::unique_ptr<FrameSource> inner, TumRecorder recorder)
    : inner_(std::move(inner)), recorder_(std::move(recorder)) {}

FrameRead RecordingSource::next() {
  FrameRead read = inner_->next();
  if (read.kind != FrameRead::Kind::kFrame) return read;
  if (Status s = recorder_.add(read.frame); !s) return FrameRead::failed("recording: " + s.error());
  return read;
}

}  // namespace rgbdmap
