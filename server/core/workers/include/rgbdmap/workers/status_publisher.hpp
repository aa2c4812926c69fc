#pragma once
// The status thread: every status_period_s a ServerStatus (uptime, graph revision, per-robot counters) to
// every robot that said Hello. A periodic SerialWorker ("rgbdmap-status"); off when the period is 0.
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "rgbdmap/common/serial_worker.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/workers/robot_publisher.hpp"

namespace rgbdmap {

class StatusPublisher {
 public:
  /// graph_revision: the revision of the last applied optimisation.
  StatusPublisher(double period_s, RobotRegistry& registry, RobotPublisher& publisher,
                  std::function<int64_t()> graph_revision);

  /// Where ServerStatus::rejects come from (call before start()). The status also goes to every robot
  /// named there that has not said Hello (e.g. one whose signatures fail), so it can learn why.
  void setRejectCounts(std::function<std::vector<msg::RejectCount>()> reject_counts);

  /// The `state` text of the status ("running" when not set); set before start().
  void setStateSource(std::function<std::string()> state);
  /// Per robot: its pose is in the map (RobotStatus::placed; a robot not named there: true). Before start().
  void setPlacementSource(std::function<std::map<std::string, bool>()> placed);
  void start();  ///< no effect when the period is 0
  void stop();   ///< idempotent

  /// The status as it would be published now (its robots are the ones it goes to).
  msg::ServerStatus status() const;

 private:
  void publish();

  const double period_s_;
  RobotRegistry& registry_;
  RobotPublisher& publisher_;
  const std::function<int64_t()> graph_revision_;
  std::function<std::vector<msg::RejectCount>()> reject_counts_;
  std::function<std::string()> state_;
  std::function<std::map<std::string, bool>()> placed_;
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  SerialWorker worker_;  ///< last member
};

}  // namespace rgbdmap
