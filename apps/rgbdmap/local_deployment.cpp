#include "local_deployment.hpp"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>

#include "rgbdmap/common/data_files.hpp"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::cmd {
namespace {

Result<std::unique_ptr<transport::Transport>> makeTransport(const std::string& url) {
  auto t = transport::makeTransport(url);
  if (!t)
    return Result<std::unique_ptr<transport::Transport>>::failure("transport " + url + ": " + t.error());
  return std::move(*t);
}

}  // namespace

Status ensureDdsConfig() {
  if (std::getenv("CYCLONEDDS_URI")) return Status::success();
  const Result<std::string> xml = findDataFile("dds/cyclonedds-loopback.xml", RGBDMAP_INSTALLED_DATA_DIR);
  if (!xml) return Status::failure("CYCLONEDDS_URI is not set and the loopback configuration " + xml.error());
  setenv("CYCLONEDDS_URI", ("file://" + *xml).c_str(), 1);
  log::info("CYCLONEDDS_URI=file://", *xml, " (loopback only)");
  return Status::success();
}

Result<std::unique_ptr<LocalDeployment>> LocalDeployment::start(const std::string& url,
                                                                MapServerConfig config,
                                                                const std::vector<LocalRobotSpec>& robots) {
  using R = Result<std::unique_ptr<LocalDeployment>>;
  if (url.rfind("dds://", 0) == 0)
    if (const Status s = ensureDdsConfig(); !s) return R::failure(s.error());
  std::unique_ptr<LocalDeployment> d(new LocalDeployment());
  auto server_transport = makeTransport(url);
  if (!server_transport) return R::failure(server_transport.error());
  d->server_transport_ = std::move(*server_transport);
  config.robots.clear();
  msg::KeyStore keys;
  for (const LocalRobotSpec& r : robots) {
    config.robots.push_back(r.id);
    (void)keys.add(r.id, r.key);
  }
  d->server_ = std::make_unique<MapServer>(std::move(config), *d->server_transport_, std::move(keys));
  if (const Status s = d->server_->start(); !s) return R::failure(s.error());
  if (const Status s = d->addRobots(url, robots); !s) return R::failure(s.error());
  if (const Status s = d->startTransportsAndLinks(); !s) return R::failure(s.error());
  return R(std::move(d));
}

Status LocalDeployment::addRobots(const std::string& url, const std::vector<LocalRobotSpec>& robots) {
  const bool shared_bus = url.rfind("memq://", 0) == 0;
  for (const LocalRobotSpec& r : robots) {
    Party party;
    transport::Transport* t = server_transport_.get();
    if (!shared_bus) {
      auto own = makeTransport(url);
      if (!own) return Status::failure(own.error());
      party.own_transport = std::move(*own);
      t = party.own_transport.get();
    }
    RobotLinkOptions lo;
    lo.robot_id = r.id;
    lo.key = r.key;
    lo.camera = r.camera;
    lo.T_base_camera = r.T_base_camera;
    lo.chunk_bytes = resolveChunkBytes(lo.chunk_bytes, url);
    party.link = std::make_unique<RobotLink>(*t, lo);
    robots_.push_back(std::move(party));
    robot_ids_.push_back(r.id);
  }
  return Status::success();
}

Status LocalDeployment::startTransportsAndLinks() {
  if (const Status s = server_transport_->start(); !s)
    return Status::failure("transport start: " + s.error());
  for (size_t i = 0; i < robots_.size(); ++i) {
    if (robots_[i].own_transport)
      if (const Status s = robots_[i].own_transport->start(); !s)
        return Status::failure("transport start: " + s.error());
    if (const Status s = robots_[i].link->start(); !s)
      return Status::failure(robot_ids_[i] + ": " + s.error());
  }
  return Status::success();
}

void LocalDeployment::settle(double idle_timeout_s, double robot_timeout_s) {
  server_->waitIdle(idle_timeout_s);
  server_->flushMapStreams(idle_timeout_s);  // the final map to every subscriber (robots, a viewer)
  const MapServerStats stats = server_->stats();
  const auto keyframes = server_->keyframes();
  for (size_t i = 0; i < robots_.size(); ++i) {
    // A localising robot stored nothing (the map's keyframes of its id are an earlier session's); its run
    // already waited for the correction of its last keyframe.
    const auto row = std::find_if(stats.robots.begin(), stats.robots.end(),
                                  [&](const ServerRobotStats& r) { return r.robot_id == robot_ids_[i]; });
    if (row != stats.robots.end() && row->mode == "localize") continue;
    int last = -1;
    for (const ServerKeyframe& k : keyframes)
      if (k.robot_id == robot_ids_[i]) last = k.keyframe_id;
    if (last < 0) continue;
    const auto start = std::chrono::steady_clock::now();
    RobotLink& link = *robots_[i].link;
    if (!link.waitForCorrection(last, robot_timeout_s)) continue;
    // The server's last optimisation may still be on its way to this robot.
    const double spent_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (stats.optimizations > 0)
      link.waitForGraphRevision(stats.graph_revision, std::max(0.0, robot_timeout_s - spent_s));
  }
}

void LocalDeployment::stop() {
  if (stopped_) return;
  stopped_ = true;
  for (Party& p : robots_) {
    p.link->stop();
    if (p.own_transport) p.own_transport->stop();
  }
  if (server_transport_) server_transport_->stop();
  if (server_) server_->stop();
}

LocalDeployment::~LocalDeployment() { stop(); }

}  // namespace rgbdmap::cmd
