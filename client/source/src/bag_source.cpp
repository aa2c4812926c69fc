// bag:FILE.bag - colour, depth and camera_info of a ROS 1 bag (rosbag_storage; no ROS master, no roscpp),
// paired by header stamp (paired_source.hpp).
#include "bag_reader.hpp"
#include "paired_source.hpp"
#include "sources.hpp"

namespace rgbdmap::source_detail {

Result<std::unique_ptr<FrameSource>> openBagSource(const SourceUrl& url, const SourceOptions& options) {
  using R = Result<std::unique_ptr<FrameSource>>;
  const ImageTopics topics = topicsFrom(url, tumBagTopics());
  Result<double> max_dt = maxTimeDiff(url, options);
  if (!max_dt) return R::failure(max_dt.error());
  auto reader = BagReader::open(url.path, topics);
  if (!reader) return R::failure(reader.error());
  return R(makePairedSource(std::move(*reader), *max_dt));
}

}  // namespace rgbdmap::source_detail
