#pragma once
// The server's answers to keyframes (KeyframeAck: accepted, or refused with the reason), remembered so that
// the receive side can answer again when a robot shows it has no answer: a duplicate chunk of a keyframe
// that was answered (a robot whose KeyframeAck was lost probes with the last chunk of its transfer). The
// ingest worker fills it as it answers (a stored, refused or duplicate keyframe); the inbox reads it on the
// transport's receive thread. Only an answered keyframe is found: one still queued has no answer here.
// Bounded: the newest `per_robot` answers of each robot and `total` in all (beyond, the robot holding the
// most forgets its oldest). Each answer goes out at most once per `repeat_interval_s`, its first sending
// included, so duplicates, however many, cannot make the server send more than that. Thread-safe (one short
// lock, never held while sending).
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

struct KeyframeAnswersOptions {
  size_t per_robot = 64;  ///< above ChunkReassemblyOptions::completed_remembered (32)
  size_t total = 4096;
  double repeat_interval_s = 0.1;
};

class KeyframeAnswers {
 public:
  using Clock = std::chrono::steady_clock;

  explicit KeyframeAnswers(KeyframeAnswersOptions options = {}) : options_(options) {}

  /// Keyframe `keyframe_id` of `robot`'s process `session` was answered at `now`. A keyframe answered before
  /// keeps its first answer; `now` restarts its repeat interval.
  void remember(const std::string& robot, int64_t session, int keyframe_id, bool accepted,
                const std::string& reason, Clock::time_point now);
  /// The answer to send again now (and noted as sent), or nullopt: none remembered, or it went out less than
  /// repeat_interval_s ago.
  std::optional<msg::KeyframeAck> repeat(const std::string& robot, int64_t session, int keyframe_id,
                                         Clock::time_point now);

  uint64_t repeated() const;  ///< answers repeat() gave
  size_t size() const;        ///< answers remembered

 private:
  struct Answer {
    int64_t session = 0;
    msg::KeyframeAck ack;
    Clock::time_point last_sent;
  };
  using Answers = std::deque<Answer>;  ///< oldest first
  Answer* findLocked(Answers& answers, int64_t session, int keyframe_id);
  void forgetOldestLocked();  ///< of the robot holding the most

  const KeyframeAnswersOptions options_;
  mutable std::mutex mutex_;
  std::map<std::string, Answers> robots_;
  size_t total_ = 0;
  uint64_t repeated_ = 0;
};

}  // namespace rgbdmap
