#pragma once
// Viewer::Impl: the MapView the subscription fills, the WsServer, and the publisher thread that turns
// changes of the view into the topics' messages (viewer_publish.cpp).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <thread>
#include <unordered_set>
#include <vector>

#include "rgbdmap/viewer/map_subscriber.hpp"
#include "rgbdmap/mcap/mcap_writer.hpp"
#include "rgbdmap/viewer/map_view.hpp"
#include "rgbdmap/viewer/viewer.hpp"
#include "ws_server.hpp"

namespace rgbdmap::viewer {

/// The channel ids of one robot's topics.
struct RobotChannels {
  uint32_t voxels = 0, voxel_delta = 0, trajectory = 0, pose = 0, slice = 0, status = 0, loops = 0;
  uint32_t map_grid = 0;
};

/// What the publisher last sent for one robot.
struct RobotPublished {
  RobotSnapshot seen;  ///< change counters of the last publication
  std::unordered_set<uint64_t> voxel_keys;
  std::vector<Voxel> voxels;
  int64_t revision = 0;  ///< of /R/voxel_delta, bumped per delta
  bool cloud_pending = false, grid_pending = false;
  bool live_used = false;  ///< /R/pose was the robot's live pose (else its newest keyframe)
  std::chrono::steady_clock::time_point last_cloud{}, last_snapshot{}, last_grid{};
  uint64_t bytes_down_at_last_status = 0;
  std::chrono::steady_clock::time_point last_status{};
  std::atomic<bool> snapshot_wanted{false};
};

struct Viewer::Impl {
  Impl(ViewerOptions o, const std::vector<std::string>& robots)
      : options(std::move(o)), view(robots), subscriber(view) {}

  std::vector<ChannelInfo> makeChannels();
  void requestSnapshot(uint32_t channel);
  void run();
  void publishRobot(size_t index, bool periodic_snapshot);
  void publishVoxels(size_t index, const RobotSnapshot& s, bool periodic_snapshot);
  void publishPoses(size_t index, const RobotSnapshot& s, bool trajectory);
  void publishMapGrid(size_t index, const RobotSnapshot& s);
  void publishStatus(size_t index, const RobotSnapshot& s);
  void publishTransforms();
  void send(uint32_t channel, const nlohmann::json& message, int64_t utime);
  /// Opens options.record_path with a channel per non-incremental channel of `list`.
  Status openRecording(const std::vector<ChannelInfo>& list);
  Status closeRecording();

  ViewerOptions options;
  MapView view;
  MapSubscriber subscriber;
  std::unique_ptr<WsServer> server;
  std::vector<RobotChannels> channels;
  std::vector<std::unique_ptr<RobotPublished>> published;
  uint32_t tf_channel = 0;
  std::unique_ptr<mcap::Writer> recording;         ///< written by the publisher thread, closed after it ended
  std::map<uint32_t, uint16_t> recorded_channels;  ///< viewer channel -> MCAP channel
  std::atomic<uint64_t> recorded_messages{0};
  uint64_t recorded_ns = 0;  ///< log time of the last recorded message
  std::atomic<bool> recording_failed{false};
  std::thread thread;
  std::atomic<bool> stopping{false};
  std::atomic<uint64_t> voxels_total{0};
  bool started = false;
};

int64_t nowUtime();

}  // namespace rgbdmap::viewer
