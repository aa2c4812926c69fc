#pragma once
// Reassembly of chunked keyframe transfers (msg::KeyframeChunk, udpm:// robots), on the inbox's receive
// thread. Chunks arrive authenticated and validated (consistent count/size/index); this class bounds what a
// robot can make the server hold: at most `max_transfers_per_robot` transfers in progress and
// `max_bytes_per_robot` declared bytes (the oldest transfer is evicted to make room; a new transfer is
// refused while all robots together hold `max_total_bytes`), and a transfer with no new chunk for `timeout_s`
// is dropped. Completed transfers are remembered (a few per robot) so late duplicates are answered "all
// received" rather than starting a new transfer. Not thread-safe.
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

struct ChunkReassemblyOptions {
  size_t max_transfers_per_robot = 64;  ///< a robot catching up after loss has many keyframes in flight
  size_t max_bytes_per_robot = 32u << 20;
  size_t max_total_bytes = 256u << 20;  ///< all robots (open mode lets anyone claim a robot id)
  double timeout_s = 10.0;
  size_t completed_remembered = 32;  ///< per robot
};

struct ChunkReassemblyStats {
  uint64_t chunks = 0, duplicates = 0, completed = 0, evicted = 0, timed_out = 0, refused = 0;
};

class ChunkReassembly {
 public:
  using Clock = std::chrono::steady_clock;
  enum class Outcome { kStored, kDuplicate, kComplete, kRefused };

  explicit ChunkReassembly(ChunkReassemblyOptions options = {}) : options_(options) {}

  /// Adds one validated chunk of `robot`. kComplete moves the envelope bytes into *complete. kRefused: the
  /// chunk contradicts its transfer (other count, size or keyframe) or the transfer exceeds the bounds.
  /// Transfer ids are per sender session (chunk.header.session): a newer session (a restarted robot) drops
  /// what the robot's previous session left; the envelope's ReplayGuard already refused older sessions.
  Outcome add(const std::string& robot, const msg::KeyframeChunk& chunk, Clock::time_point now,
              std::vector<uint8_t>* complete);
  /// Received-chunk bitmap of a transfer (bit i of byte i / 8, LSB first), all ones once completed;
  /// nullopt for a transfer not held (evicted, timed out or never seen).
  std::optional<msg::Bytes> receivedBitmap(const std::string& robot, int64_t transfer_id) const;
  /// Drops transfers idle for timeout_s.
  void evictStale(Clock::time_point now);

  size_t transfersInProgress() const;
  size_t bytesInProgress() const;
  const ChunkReassemblyStats& stats() const { return stats_; }

 private:
  struct Transfer {
    int keyframe_id = 0, chunk_count = 0, chunk_bytes = 0, total_bytes = 0, received_count = 0;
    std::vector<uint8_t> data;
    std::vector<bool> received;
    Clock::time_point last_chunk;
  };
  struct Completed {
    int64_t transfer_id = 0;
    int keyframe_id = 0, chunk_count = 0, total_bytes = 0;
  };
  struct RobotState {
    int64_t session = 0;
    std::map<int64_t, Transfer> transfers;  ///< transfer id -> in progress
    std::deque<Completed> completed;
    size_t bytes = 0;
  };
  void clear(RobotState& state);
  bool makeRoom(RobotState& state, size_t bytes);
  void erase(RobotState& state, std::map<int64_t, Transfer>::iterator it);

  ChunkReassemblyOptions options_;
  std::map<std::string, RobotState> robots_;
  size_t total_bytes_ = 0;
  ChunkReassemblyStats stats_;
};

}  // namespace rgbdmap
