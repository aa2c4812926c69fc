// RobotLink with a keyframe spool: keyframes wait on disk, in id order, for room in the send window; the
// feeder thread moves them in (read back from the spool when no longer in memory), a keyframe given up by
// the ReliableSender goes back to the queue, and an answered one leaves the spool. While keyframes in
// flight get no answer at all (an outage, a server down), the window shrinks to a few keyframes, so the
// link probes rather than floods; the first answer opens it again.
#include "rgbdmap/common/logging.hpp"
#include "robot_link_impl.hpp"

namespace rgbdmap {
namespace {

/// Keyframes in flight while none gets an answer: a probe, not a flood, through an outage.
constexpr size_t kOutageWindow = 4;
/// No KeyframeAck or ChunkAck for this long while keyframes are in flight: an outage.
constexpr std::chrono::seconds kOutageAfter{5};
/// The feeder re-checks the window this often when nothing wakes it (the outage limit changes with time).
constexpr std::chrono::milliseconds kFeederTick{200};

}  // namespace

void RobotLink::Impl::startSpool() {
  const std::vector<int> left = spool_->pending();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const int id : left) {
      SentKeyframe& entry = sent_[id];
      entry.spooled = entry.recovered = true;
      queue_.insert(id);
    }
    last_answer_ = Clock::now();
  }
  if (!left.empty())
    log::info("robot ", options_.robot_id, ": ", left.size(), " keyframes left in the spool ",
              spool_->directory(), " by an earlier run (ids ", left.front(), "..", left.back(), ", session ",
              session_, ") are sent first");
  feeder_ = std::thread([this] { runFeeder(); });
}

Status RobotLink::Impl::enqueueSpooled(msg::Keyframe message, const KeyframeBytes& bytes) {
  const int id = message.keyframe_id;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return Status::success();  // spooled: the next start sends it
    SentKeyframe& entry = sent_[id];
    entry.spooled = true;
    entry.segment = message.segment_id;
    entry.T_odom_cam = message.T_odom_cam;
    // Kept in memory only when the feeder can take it at once; else it is read back from the spool.
    if (queue_.empty() && reliable_.pending() < windowLimit(Clock::now()))
      entry.message = std::make_unique<msg::Keyframe>(std::move(message));
    queue_.insert(id);
    ++counts_.keyframes_spooled;
    countKeyframeBytes(bytes);
  }
  changed_.notify_all();
  return Status::success();
}

void RobotLink::Impl::noteSpooled(const Status& spooled) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (spooled) {
    if (live_only_) log::info("robot ", options_.robot_id, ": keyframes are spooled again");
    live_only_ = false;
    return;
  }
  ++counts_.keyframes_live_only;
  if (!live_only_)
    log::warn("robot ", options_.robot_id, ": ", spooled.error(),
              ": keyframes are sent live only (lost if this process ends before they are acknowledged)");
  live_only_ = true;
}

size_t RobotLink::Impl::windowLimit(Clock::time_point now) const {
  const size_t full = options_.reliable.max_pending;
  return now - last_answer_ > kOutageAfter ? std::min(full, kOutageWindow) : full;
}

void RobotLink::Impl::runFeeder() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    const auto now = Clock::now();
    if (reliable_.pending() == 0) last_answer_ = now;  // nothing in flight, nothing unanswered
    if (queue_.empty() || reliable_.pending() >= windowLimit(now)) {
      changed_.wait_for(lock, kFeederTick);
      continue;
    }
    const int id = *queue_.begin();
    queue_.erase(queue_.begin());
    // Out of the queue and not in the sender yet (read back, submitted without the lock): waitAllAcked must
    // not take the link for idle meanwhile. Every path below ends this iteration with the lock held.
    feeding_ = true;
    struct Fed {
      bool& feeding;
      ~Fed() { feeding = false; }
    } fed{feeding_};
    auto it = sent_.find(id);
    if (it == sent_.end() || it->second.answer != Answer::kPending) continue;
    if (!it->second.message) {
      lock.unlock();
      Result<msg::Keyframe> read = spool_->read(id);
      lock.lock();
      it = sent_.find(id);
      if (!read) {
        log::warn("robot ", options_.robot_id, ": keyframe ", id,
                  " cannot be read back from the spool: ", read.error());
        continue;
      }
      if (stopping_ || it == sent_.end() || it->second.answer != Answer::kPending) continue;
      it->second.message = std::make_unique<msg::Keyframe>(std::move(*read));
    }
    SentKeyframe& entry = it->second;
    if (!entry.fed) entry.first_sent = Clock::now();
    lock.unlock();
    const Status s = reliable_.submit(static_cast<uint64_t>(id));  // transmits on this thread
    lock.lock();
    it = sent_.find(id);
    if (it == sent_.end()) continue;
    if (!s) {
      it->second.message.reset();
      if (it->second.answer == Answer::kPending) queue_.insert(id);
      log::debug("robot ", options_.robot_id, ": keyframe ", id, " back in the queue: ", s.error());
      changed_.wait_for(lock, kFeederTick);
    } else if (!it->second.fed) {
      it->second.fed = true;
      ++counts_.keyframes_sent;
    }
  }
}

void RobotLink::Impl::onGivenUp(uint64_t id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = sent_.find(static_cast<int>(id));
    if (it == sent_.end() || !it->second.spooled || it->second.answer != Answer::kPending || stopping_)
      return;
    SentKeyframe& entry = it->second;
    entry.message.reset();
    entry.transfer = ChunkTransfer{};
    entry.transmissions = 0;
    entry.reseals = 0;
    queue_.insert(static_cast<int>(id));
    ++counts_.keyframes_requeued;
  }
  changed_.notify_all();
}

void RobotLink::Impl::noteAnswered(int keyframe_id) {
  if (spool_) spool_->remove(keyframe_id);
}

void RobotLink::Impl::addSpoolStats(RobotLinkStats* s) const {
  const KeyframeSpoolStats spool = spool_->stats();
  s->spool_depth = spool.depth;
  s->spool_bytes = spool.bytes;
  s->spool_recovered = spool.recovered;
  s->spool_damaged = spool.damaged;
  s->spool_oldest_utime = spool.oldest_utime;
  s->keyframes_queued = queue_.size();
}

}  // namespace rgbdmap
