// tum:DIR - a TUM-layout folder through TumDataset (frames [first, end) of it).
#include <algorithm>

#include "rgbdmap/dataset/tum_dataset.hpp"
#include "sources.hpp"

namespace rgbdmap::source_detail {

class TumSource : public FrameSource {
 public:
  TumSource(TumDataset dataset, std::optional<CameraIntrinsics> camera, size_t first, long long end)
      : dataset_(std::move(dataset)), camera_(std::move(camera)) {
    const size_t n = dataset_.size();
    next_ = std::min(first, n);
    end_ = end < 0 ? n : std::clamp<size_t>(static_cast<size_t>(end), next_, n);
  }

  FrameRead next() override {
    if (next_ >= end_) return FrameRead::end();
    const size_t i = next_++;
    Result<RgbdFrame> frame = dataset_.load(i);
    if (!frame) return FrameRead::unreadable(i, frame.error());
    return FrameRead::ok(i, std::move(*frame));
  }
  bool live() const override { return false; }
  std::optional<CameraIntrinsics> camera() const override { return camera_; }
  std::string describe() const override { return "tum:" + dataset_.dir(); }
  size_t sizeHint() const override { return end_ > next_ ? end_ - next_ : 0; }
  std::optional<Trajectory> groundTruth() const override { return dataset_.groundTruth(); }

 private:
  TumDataset dataset_;
  std::optional<CameraIntrinsics> camera_;
  size_t next_ = 0, end_ = 0;
};

Result<std::unique_ptr<FrameSource>> openTumSource(const SourceUrl& url, const SourceOptions& options) {
  using R = Result<std::unique_ptr<FrameSource>>;
  DatasetOptions d;
  d.max_time_diff = options.max_time_diff;
  d.depth_scale = options.depth_scale;
  d.expected_width = options.expected_width;
  d.expected_height = options.expected_height;
  auto dataset = TumDataset::open(url.path, d);
  if (!dataset) return R::failure(dataset.error());
  auto camera = readDatasetCamera(url.path);
  if (!camera) return R::failure(camera.error());
  return R(std::make_unique<TumSource>(std::move(*dataset), *camera, options.first_frame, options.end_frame));
}

}  // namespace rgbdmap::source_detail

namespace rgbdmap {

std::unique_ptr<FrameSource> makeTumSource(TumDataset dataset, size_t first, long long end) {
  return std::make_unique<source_detail::TumSource>(std::move(dataset), std::nullopt, first, end);
}

}  // namespace rgbdmap
