#pragma once
// Per-robot keyframe queues served round-robin ("fair share"): one robot sending faster than the
// server ingests fills only its own queue; every other robot's keyframes are taken in turn with it. Each
// queue is bounded in keyframes and in bytes (a keyframe that does not fit is refused: the caller leaves it
// unacknowledged and the robot resends it later), and all robots together by a total count.
// A robot that went over its share (its queue was full, or it was throttled) is demoted for a while: it is
// served only when no robot within its share has a keyframe queued, so a well-behaved robot waits at most
// for the one keyframe in progress, however expensive the flood's keyframes are.
// A retransmission of a keyframe that is still queued (same session, segment and id) takes no second slot:
// push() reports it as a duplicate and the queued copy is answered when served. Without that, a robot whose
// acknowledgements are late (the server behind for a while) filled its queue with copies of the same few
// keyframes, went "over its share", was demoted and fell further behind with every round of resends: the
// 16-robot fleet run lost two robots that way. Not thread-safe: IngestQueue
// guards it with its own mutex.
#include <chrono>
#include <cstddef>
#include <deque>
#include <map>
#include <optional>
#include <string>

#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

struct RobotQueueLimits {
  size_t keyframes_per_robot = 64;     ///< server.robot_queue_capacity
  size_t bytes_per_robot = 64u << 20;  ///< server.robot_queue_bytes (one keyframe always fits an empty queue)
  size_t keyframes_total = 1024;       ///< server.ingest_queue_capacity (all robots together)
};

class RobotQueues {
 public:
  explicit RobotQueues(RobotQueueLimits limits) : limits_(limits) {}

  /// Whether a keyframe of `bytes` (its encoded size) from `robot` would be queued now.
  bool hasRoom(const std::string& robot, size_t bytes) const;
  enum class Pushed { kQueued, kFull, kDuplicate };
  /// Queues it at the back of its robot's queue: kFull (nothing queued) when there is no room, kDuplicate
  /// (nothing queued, room or not) when the same keyframe (session, segment, id) is queued already.
  Pushed push(const std::string& robot, msg::Keyframe keyframe, size_t bytes);
  /// Whether that keyframe of `robot` is queued now.
  bool contains(const std::string& robot, const msg::Keyframe& keyframe) const;
  using Clock = std::chrono::steady_clock;
  /// The front keyframe of the next robot in turn (robots with queued keyframes, round-robin), skipping
  /// robots demoted at `now` while another robot has keyframes queued.
  std::optional<msg::Keyframe> pop(Clock::time_point now = Clock::now());
  /// `robot` is served after the robots within their share until `until`.
  void demote(const std::string& robot, Clock::time_point until);
  void clear();

  size_t size() const { return total_; }
  size_t size(const std::string& robot) const;
  size_t bytes(const std::string& robot) const;
  /// The most keyframes one robot's queue has held at once (since construction).
  size_t highWater(const std::string& robot) const;

 private:
  struct Entry {
    msg::Keyframe keyframe;
    size_t bytes = 0;
  };
  struct Queue {
    std::deque<Entry> entries;
    size_t bytes = 0;
    size_t high_water = 0;
    Clock::time_point demoted_until;
  };

  const RobotQueueLimits limits_;
  std::map<std::string, Queue> queues_;  ///< one per robot seen (a robot id is bounded by the key store)
  std::deque<std::string> turn_;         ///< robots with queued keyframes, the next to serve first
  size_t total_ = 0;
};

}  // namespace rgbdmap
