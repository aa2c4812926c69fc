// --source URL parsing and the dispatch to the concrete sources.
#include <set>

#include "rgbdmap/ros2/dds.hpp"
#include "rgbdmap/source/live_source.hpp"
#include "sources.hpp"

namespace rgbdmap {
namespace {

/// The query keys each scheme accepts.
const std::map<std::string, std::set<std::string>>& allowedKeys() {
  static const std::map<std::string, std::set<std::string>> keys = {
      {"tum", {"live"}},
      {"bag", {"rgb", "depth", "info", "max_dt"}},
      {"mcap", {"rgb", "depth", "info", "max_dt"}},
      {"ros2", {"rgb", "depth", "info", "max_dt", "domain", "wait"}},
      {"openni2", {}},
      {"7scenes", {}},
  };
  return keys;
}

Status parseQuery(const std::string& text, std::map<std::string, std::string>* query) {
  size_t start = 0;
  while (start <= text.size()) {
    const size_t amp = std::min(text.find('&', start), text.size());
    const std::string item = text.substr(start, amp - start);
    if (!item.empty()) {
      const size_t eq = item.find('=');
      const std::string key = item.substr(0, eq);
      if (key.empty()) return Status::failure("empty key in '" + item + "'");
      (*query)[key] = eq == std::string::npos ? "" : item.substr(eq + 1);
    }
    start = amp + 1;
  }
  return Status::success();
}

}  // namespace

Result<SourceUrl> SourceUrl::parse(const std::string& url) {
  using R = Result<SourceUrl>;
  SourceUrl u;
  const size_t colon = url.find(':');
  if (colon == std::string::npos)
    return R::failure(
        "source '" + url +
        "': expected tum:DIR, 7scenes:DIR, bag:FILE.bag[?...], mcap:FILE.mcap[?...], ros2:[?...] or "
        "openni2:[URI]");
  u.scheme = url.substr(0, colon);
  const auto allowed = allowedKeys().find(u.scheme);
  if (allowed == allowedKeys().end())
    return R::failure("source '" + url + "': unknown kind '" + u.scheme +
                      "' (tum, 7scenes, bag, mcap, ros2, openni2)");
  std::string rest = url.substr(colon + 1);
  if (rest.rfind("//", 0) == 0) rest = rest.substr(2);  // tum://DIR and bag://FILE read the same
  const size_t question = rest.find('?');
  u.path = rest.substr(0, question);
  if (question != std::string::npos) {
    if (Status s = parseQuery(rest.substr(question + 1), &u.query); !s)
      return R::failure("source '" + url + "': " + s.error());
  }
  for (const auto& [key, value] : u.query)
    if (!allowed->second.count(key))
      return R::failure("source '" + url + "': unknown option '" + key + "' for " + u.scheme);
  if (u.path.empty() && u.scheme != "openni2" && u.scheme != "ros2")
    return R::failure("source '" + url +
                      "': " + (u.scheme == "tum" || u.scheme == "7scenes" ? "folder" : "file") + " missing");
  if (u.scheme == "ros2")  // a configuration error, like a dds:// link without it
    if (const Status s = ros2::checkDdsConfiguration(); !s) return R::failure("source '" + url + "': " + s.error());
  return u;
}

Result<std::unique_ptr<FrameSource>> openFrameSource(const SourceUrl& url, const SourceOptions& options) {
  Result<std::unique_ptr<FrameSource>> opened = Result<std::unique_ptr<FrameSource>>::failure("");
  if (url.scheme == "tum")
    opened = source_detail::openTumSource(url, options);
  else if (url.scheme == "bag")
    opened = source_detail::openBagSource(url, options);
  else if (url.scheme == "mcap")
    opened = source_detail::openMcapSource(url, options);
  else if (url.scheme == "ros2")
    opened = source_detail::openRos2Source(url, options);
  else if (url.scheme == "7scenes")
    opened = source_detail::openSevenScenesSource(url, options);
  else
    opened = source_detail::openOpenni2Source(url, options);
  if (!opened) return opened;
  std::unique_ptr<FrameSource> source = std::move(*opened);
  if (url.scheme == "tum" && url.query.count("live")) source = makePacedSource(std::move(source));
  if (source->live()) source = makeLatestFrameSource(std::move(source));
  if (url.scheme != "tum" && url.scheme != "7scenes" &&
      (options.first_frame > 0 || options.end_frame >= 0))  // tum: its own range
    source = makeRangeSource(std::move(source), options.first_frame, options.end_frame);
  return source;
}

const char* sourceUrlHelp() {
  return "  --source URL            where frames come from (instead of --dataset):\n"
         "                          tum:DIR                  a TUM-layout folder (= --dataset DIR)\n"
         "                          tum:DIR?live             the folder replayed as a live camera at its\n"
         "                                                   frame rate (frames the odometry misses drop)\n"
         "                          7scenes:DIR              a Microsoft 7-Scenes sequence folder\n"
         "                                                   (frame-NNNNNN.color|depth|pose files); its\n"
         "                                                   depth registered to its colour camera\n"
         "                          bag:FILE.bag[?rgb=TOPIC&depth=TOPIC&info=TOPIC&max_dt=S]  a ROS 1 bag\n"
         "                                                   (default topics: the TUM benchmark's\n"
         "                                                   /camera/rgb/image_color, /camera/depth/image,\n"
         "                                                   /camera/rgb/camera_info; colour rgb8, bgr8 or\n"
         "                                                   mono8, depth 32FC1 metres or 16UC1 mm)\n"
         "                          mcap:FILE.mcap[?rgb=TOPIC&depth=TOPIC&info=TOPIC&max_dt=S]  a ROS 2\n"
         "                                                   bag (rosbag2 MCAP, CDR; chunks zstd, lz4 or\n"
         "                                                   none; a cut-off file reads up to the cut);\n"
         "                                                   default topics: realsense2_camera's\n"
         "                                                   /camera/camera/color/image_raw,\n"
         "                                                   /camera/camera/aligned_depth_to_color/\n"
         "                                                   image_raw, /camera/camera/color/camera_info\n"
         "                          ros2:[?rgb=T&depth=T&info=T&domain=N&wait=S]  live ROS 2 topics over\n"
         "                                                   Cyclone DDS (CYCLONEDDS_URI), e.g. "
         "realsense2_camera\n"
         "                                                   (its topics are the defaults, as for mcap:)\n"
         "                          openni2:[URI]            a live OpenNI2 camera (Kinect v1, Xtion,\n"
         "                                                   Astra), 640x480 at 30 Hz, depth registered\n"
         "                                                   to colour; no URI: the first device\n";
}

}  // namespace rgbdmap
