#pragma once
// rgbdmap-monitor's state and table (private to the program): per robot, the server's latest status and
// map stream (signed by the server with the robot's key) and the robot's own LinkStatus (signed by the
// robot), and the bytes seen on its channels.
#include <unistd.h>

#include <octomap/OcTree.h>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/map/map_io.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap {

using Clock = std::chrono::steady_clock;

struct RobotView {
  msg::KeyStore keys;  ///< "server" and the robot -> this robot's key
  msg::ReplayGuard guard;
  uint64_t bytes_up = 0, bytes_down = 0;            ///< since start
  uint64_t bytes_up_last = 0, bytes_down_last = 0;  ///< at the previous print
  bool has_status = false;
  msg::ServerStatus status;
  std::unique_ptr<octomap::OcTree> map;
  int64_t map_revision = -1, map_saved_revision = -1;
  uint64_t map_updates = 0, map_errors = 0;
  uint64_t status_bad_signatures =
      0;  ///< server messages on this robot's channels the monitor could not verify
  std::optional<msg::LinkStatus> link;  ///< the robot's latest (its spool, send window, diagnosis)
};

/// "12 (34 s)": keyframes in the robot's spool and the oldest unanswered one's age; "-" without a spool or
/// before its first LinkStatus.
inline std::string spoolText(const std::optional<msg::LinkStatus>& link) {
  if (!link || link->spool_depth < 0) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%d (%.0f s)%s", link->spool_depth, link->oldest_unanswered_s,
                link->live_only ? " LIVE ONLY" : "");
  return buf;
}

/// The robot's map mode and placement from the server's status: "map"; "map, not merged" (its keyframes
/// are in a map of their own so far); "localize"; "localize, unplaced" (not placed in the stored map yet:
/// its pose and slices come from its own keyframes). "-" before a status names the robot.
inline std::string placementText(const msg::RobotStatus* r) {
  if (!r) return "-";
  if (r->localize) return r->placed ? "localize" : "localize, unplaced";
  return r->placed || r->keyframes == 0 ? "map" : "map, not merged";
}

struct MonitorOptions {
  std::string transport_url, keys_file, save_dir;
  std::vector<std::string> robots;
  bool open = false, once = false;
  double period_s = 2.0, timeout_s = 0.0;
};

/// The options as flags (for range checks and the start-up log).
inline const ConfigTable<MonitorOptions>& monitorOptionsTable() {
  using O = MonitorOptions;
  static const ConfigTable<O> table = ConfigTable<O>()
                                          .add("transport", &O::transport_url, "")
                                          .add("robots", &O::robots, "")
                                          .add("keys-file", &O::keys_file, "")
                                          .add("open", &O::open, "")
                                          .add("period", &O::period_s, ConfigRange::closed(0.05, 3600.0), "")
                                          .add("save-map", &O::save_dir, "")
                                          .add("once", &O::once, "")
                                          .add("timeout", &O::timeout_s, ConfigRange::closed(0.0, 1e6), "");
  return table;
}

class Monitor {
 public:
  explicit Monitor(const MonitorOptions& options) : options_(options), start_(Clock::now()) {}

  Status setup(const msg::KeyStore& server_keys, transport::Transport& transport) {
    for (const std::string& robot : options_.robots) {
      RobotView& view = robots_[robot];
      view.keys = options_.open ? msg::KeyStore::openMode() : msg::KeyStore();
      if (const msg::Bytes* key = server_keys.find(robot)) {
        if (Status s = view.keys.add(msg::kServerId, *key); !s) return s;
        if (Status s = view.keys.add(robot, *key); !s) return s;  // its LinkStatus
      } else if (!options_.open) {
        return Status::failure("no key for robot '" + robot + "' in " + options_.keys_file);
      }
      for (int t = 1; t <= msg::kNumMessageTypes; ++t) {
        const auto type = static_cast<msg::MessageType>(t);
        const auto channel = msg::channelFor(type, robot);
        if (!channel) return Status::failure(channel.error());
        if (channel->rfind("rgbdmap/" + robot + "/", 0) != 0) continue;  // server-wide channels
        auto handler = [this, robot, type](const std::string&, const uint8_t* data, size_t size) {
          onMessage(robot, type, data, size);
        };
        if (Status s = transport.subscribe(*channel, handler); !s) return s;
      }
    }
    return Status();
  }

  /// Prints every period until stopped (with --once: the first period that ends with a status). Returns
  /// the exit code.
  int run() {
    std::unique_lock<std::mutex> lock(mutex_);
    auto last = Clock::now();
    for (;;) {
      const auto deadline = options_.timeout_s > 0
                                ? start_ + std::chrono::duration_cast<Clock::duration>(
                                               std::chrono::duration<double>(options_.timeout_s))
                                : Clock::time_point::max();
      const auto next = last + std::chrono::duration_cast<Clock::duration>(
                                   std::chrono::duration<double>(options_.period_s));
      cv_.wait_until(lock, std::min(next, deadline), [&] { return stop_; });
      // --once answers after a whole period, so that its bandwidth columns cover one.
      if (options_.once && anyStatus() && (Clock::now() >= next || Clock::now() >= deadline)) {
        print(Clock::now() - last);
        return 0;
      }
      if (stop_) break;
      if (Clock::now() >= deadline) {
        if (options_.once) {
          std::fprintf(stderr, "rgbdmap-monitor: no status within %.1f s%s\n", options_.timeout_s,
                       unverifiable().c_str());
          return 1;
        }
        break;
      }
      if (Clock::now() >= next) {
        print(Clock::now() - last);
        saveMaps();
        last = Clock::now();
      }
    }
    print(Clock::now() - last);
    saveMaps();
    return 0;
  }

  void requestStop() {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    cv_.notify_all();
  }

  uint64_t rejected() const { return rejects_.total(); }

 private:
  bool anyStatus() const {
    for (const auto& [robot, view] : robots_)
      if (view.has_status) return true;
    return false;
  }

  void onMessage(const std::string& robot, msg::MessageType type, const uint8_t* data, size_t size) {
    std::lock_guard<std::mutex> lock(mutex_);
    RobotView& view = robots_[robot];
    (msg::directionOf(type) == msg::Direction::kRobotToServer ? view.bytes_up : view.bytes_down) += size;
    if (type != msg::MessageType::kServerStatus && type != msg::MessageType::kMapUpdate &&
        type != msg::MessageType::kLinkStatus)
      return;
    msg::RejectNote note;
    auto opened = msg::openEnvelope(data, size, view.keys, &view.guard, &rejects_, &note);
    if (!opened) {  // counted and logged (rate-limited) by openEnvelope
      if (note.reason == msg::RejectReason::kBadSignature) ++view.status_bad_signatures;
      return;
    }
    if (type == msg::MessageType::kLinkStatus) {  // the robot's own, signed by it
      auto link = opened->header.sender == robot ? msg::decodeMessage<msg::LinkStatus>(*opened, &rejects_)
                                                 : Result<msg::LinkStatus>::failure("");
      if (link && link->robot_id == robot) view.link = std::move(*link);
      return;
    }
    if (opened->header.sender != msg::kServerId) {
      rejects_.add(msg::RejectReason::kUnknownSender, "monitor: " + opened->header.sender + " on " + robot);
      return;
    }
    if (type == msg::MessageType::kServerStatus) {
      auto status = msg::decodeMessage<msg::ServerStatus>(*opened, &rejects_);
      if (!status) return;
      view.status = std::move(*status);
      view.has_status = true;
      cv_.notify_all();
    } else if (!options_.save_dir.empty()) {
      auto update = msg::decodeMessage<msg::MapUpdate>(*opened, &rejects_);
      if (!update) return;
      if (const Status s = applyMapUpdate(*update, &view.map); !s) {
        ++view.map_errors;
        log::warn("monitor: map update for ", robot, ": ", s.error());
        return;
      }
      view.map_revision = update->map_revision;
      ++view.map_updates;
    }
  }

  void saveMaps() {
    if (options_.save_dir.empty()) return;
    for (auto& [robot, view] : robots_) {
      if (!view.map || view.map_revision == view.map_saved_revision) continue;
      const std::string path = options_.save_dir + "/map_" + robot + ".bt";
      if (const Status s = writeMapFiles(*view.map, path, ""); !s)
        log::error("monitor: ", s.error());
      else
        view.map_saved_revision = view.map_revision;
    }
  }

  /// "" or why there is no status: "; cannot verify the server's status for a: N bad signatures (...)".
  std::string unverifiable() const {
    std::string out;
    for (const auto& [robot, view] : robots_)
      if (!view.has_status && view.status_bad_signatures > 0)
        out += "; cannot verify the server's status for " + robot + ": " +
               std::to_string(view.status_bad_signatures) + " bad signatures (wrong key in --keys-file?)";
    return out;
  }

  /// What the server's status says about `robot`, or why there is none for it: "bad signature (12)" when the
  /// server rejected messages from it with a bad signature; "cannot verify status (N bad signatures: wrong
  /// key?)" when the monitor itself cannot verify the server's copies for it; "no status"; else "ok".
  static std::string robotVerdict(const std::string& robot, const RobotView& view,
                                  const msg::ServerStatus* status) {
    int64_t bad = 0;
    if (status)
      for (const msg::RejectCount& r : status->rejects)
        if (r.robot_id == robot && r.reason == "bad_signature") bad = r.count;
    if (bad > 0) return "bad signature (" + std::to_string(bad) + ")";
    if (!view.has_status && view.status_bad_signatures > 0)
      return "cannot verify status (" + std::to_string(view.status_bad_signatures) +
             " bad signatures: wrong key?)";
    return status ? "ok" : "no status";
  }

  /// The newest status any robot's copy carried (all copies describe the same server).
  const msg::ServerStatus* newestStatus() const {
    const msg::ServerStatus* best = nullptr;
    for (const auto& [robot, view] : robots_)
      if (view.has_status && (!best || view.status.header.utime > best->header.utime)) best = &view.status;
    return best;
  }

  void print(Clock::duration since_last) {
    const double dt = std::max(1e-3, std::chrono::duration<double>(since_last).count());
    const double t = std::chrono::duration<double>(Clock::now() - start_).count();
    const msg::ServerStatus* status = newestStatus();
    const bool table = isatty(STDOUT_FILENO) && !options_.once;
    if (table) std::printf("\033[H\033[2J");
    if (table)
      std::printf(
          "rgbdmap-monitor  %.0f s   server %s, up %.0f s, graph revision %lld, rejected %llu\n\n"
          "%-12s %-18s %9s %6s %10s %12s %12s %9s %16s  %s\n",
          t, status ? status->state.c_str() : "(no status yet)", status ? status->uptime_s : 0.0,
          static_cast<long long>(status ? status->graph_revision : 0),
          static_cast<unsigned long long>(rejects_.total()), "robot", "map mode", "keyframes", "loops",
          "refused", "up Mbit/s", "down Mbit/s", "map rev", "spool (oldest)", "server says");
    else
      std::printf("monitor t=%.1fs state=%s graph_revision=%lld", t, status ? status->state.c_str() : "none",
                  static_cast<long long>(status ? status->graph_revision : 0));
    for (auto& [robot, view] : robots_) {
      const msg::RobotStatus* r = nullptr;
      if (status)
        for (const msg::RobotStatus& s : status->robots)
          if (s.robot_id == robot) r = &s;
      const double up = 8e-6 * static_cast<double>(view.bytes_up - view.bytes_up_last) / dt;
      const double down = 8e-6 * static_cast<double>(view.bytes_down - view.bytes_down_last) / dt;
      view.bytes_up_last = view.bytes_up;
      view.bytes_down_last = view.bytes_down;
      const std::string verdict = robotVerdict(robot, view, status);
      if (table)
        std::printf("%-12s %-18s %9d %6d %10lld %12.2f %12.2f %9lld %16s  %s\n", robot.c_str(),
                    placementText(r).c_str(), r ? r->keyframes : 0, r ? r->loop_closures : 0,
                    static_cast<long long>(r ? r->rejected_messages : 0), up, down,
                    static_cast<long long>(view.map_revision), spoolText(view.link).c_str(), verdict.c_str());
      else
        std::printf(
            " | %s keyframes=%d loops=%d up_mbps=%.2f down_mbps=%.2f bytes_up=%llu map_rev=%lld spool=%d "
            "oldest_unanswered_s=%.1f mode=%s placed=%d status=%s",
            robot.c_str(), r ? r->keyframes : 0, r ? r->loop_closures : 0, up, down,
            static_cast<unsigned long long>(view.bytes_up), static_cast<long long>(view.map_revision),
            view.link ? view.link->spool_depth : -1, view.link ? view.link->oldest_unanswered_s : 0.0,
            r ? (r->localize ? "localize" : "map") : "-", r ? int(r->placed) : -1, verdict.c_str());
    }
    std::printf("\n");
    std::fflush(stdout);
  }

  MonitorOptions options_;
  Clock::time_point start_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::map<std::string, RobotView> robots_;
  msg::RejectCounters rejects_;
};

}  // namespace rgbdmap
