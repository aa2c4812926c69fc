#pragma once
// The viewer's side of the map streams: per robot, the server's MapUpdate, PoseCorrections, OccupancySlice,
// LoopEdges and ServerStatus on that robot's channels and the robot's own RobotPose, authenticated with that
// robot's key (or open mode), checked to come from the server (the pose: from that robot), decoded and
// applied to a MapView. Runs on the transport's receive thread and
// never waits on a WebSocket client.
#include <atomic>
#include <map>
#include <mutex>
#include <string>

#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/transport/transport.hpp"
#include "rgbdmap/viewer/map_view.hpp"

namespace rgbdmap::viewer {

class MapSubscriber {
 public:
  explicit MapSubscriber(MapView& view) : view_(view) {}
  /// One KeyStore per robot (the server's key for it, or open mode); fails for a robot without a key.
  Status setKeys(const msg::KeyStore& server_keys, bool open);
  Status subscribe(transport::Transport& transport);
  void disable() { enabled_ = false; }
  uint64_t rejected() const { return rejects_.total(); }
  uint64_t mapUpdates() const { return map_updates_; }
  uint64_t mapErrors() const { return map_errors_; }

 private:
  void onMessage(const std::string& robot, msg::MessageType type, const uint8_t* data, size_t size);

  MapView& view_;
  struct RobotKeys {
    msg::KeyStore keys;
    msg::ReplayGuard guard;
  };
  std::map<std::string, RobotKeys> robots_;
  std::mutex mutex_;  ///< a transport may deliver from more than one thread
  msg::RejectCounters rejects_;
  std::atomic<bool> enabled_{true};
  std::atomic<uint64_t> map_updates_{0}, map_errors_{0};
};

}  // namespace rgbdmap::viewer
