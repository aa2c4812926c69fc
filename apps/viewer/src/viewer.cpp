// Viewer: set-up (channels, keys, the HTTP port) and lifecycle.
#include "rgbdmap/viewer/viewer.hpp"

#include <filesystem>

#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/data_files.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/viewer/foxglove_json.hpp"
#include "viewer_impl.hpp"

namespace rgbdmap::viewer {

int64_t nowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

Result<std::string> findWebDir(const std::string& web_dir) {
  if (web_dir.empty()) {
    const Result<std::string> index = findDataFile("viewer/index.html", RGBDMAP_INSTALLED_DATA_DIR);
    if (!index) return Result<std::string>::failure("the web page: " + index.error());
    return findWebDir(folderOf(*index));
  }
  for (const char* file : {"index.html", "viewer.js"}) {
    const std::string path = web_dir + "/" + file;
    if (!std::filesystem::is_regular_file(path))
      return Result<std::string>::failure("the web page: " + path + " not found");
  }
  return web_dir;
}

std::vector<ChannelInfo> Viewer::Impl::makeChannels() {
  std::vector<ChannelInfo> list;
  uint32_t next = 1;
  auto add = [&](const std::string& topic, const std::string& schema, bool incremental = false) {
    list.push_back({next, topic, schema, schemaFor(schema), incremental});
    return next++;
  };
  for (const std::string& robot : view.robots()) {
    RobotChannels c;
    c.voxels = add("/" + robot + "/voxels", "foxglove.PointCloud");
    c.voxel_delta = add("/" + robot + "/voxel_delta", "rgbdmap.VoxelDelta", true);
    c.trajectory = add("/" + robot + "/trajectory", "foxglove.PosesInFrame");
    c.pose = add("/" + robot + "/pose", "foxglove.PoseInFrame");
    c.slice = add("/" + robot + "/slice", "foxglove.Grid");
    c.status = add("/" + robot + "/status", "rgbdmap.RobotStatus");
    c.loops = add("/" + robot + "/loops", "foxglove.SceneUpdate");
    c.map_grid = add("/" + robot + "/map_grid", "foxglove.Grid");
    channels.push_back(c);
    published.push_back(std::make_unique<RobotPublished>());
  }
  tf_channel = add("/tf", "foxglove.FrameTransforms");
  return list;
}

Status Viewer::Impl::openRecording(const std::vector<ChannelInfo>& list) {
  if (options.record_path.empty()) return Status::success();
  mcap::WriterOptions o;
  o.profile = "";  // no ROS: Foxglove JSON messages
  o.library = "rgbdmap-viewer";
  auto writer = mcap::Writer::create(options.record_path, o);
  if (!writer) return Status::failure(writer.error());
  recording = std::move(*writer);
  std::map<std::string, uint16_t> schemas;
  for (const ChannelInfo& c : list) {
    if (c.incremental) continue;  // deltas need their snapshot: /R/voxels carries the same voxels whole
    auto [it, fresh] = schemas.try_emplace(c.schema_name, 0);
    if (fresh)
      it->second = recording->addSchema(c.schema_name, "jsonschema", {c.schema.begin(), c.schema.end()});
    recorded_channels[c.id] = recording->addChannel(it->second, c.topic, "json");
  }
  return Status::success();
}

Status Viewer::Impl::closeRecording() {
  if (!recording) return Status::success();
  const Status s = recording->close();
  recording.reset();
  if (s) {
    log::info("viewer: recorded ", recorded_messages.load(), " messages into ", options.record_path);
  } else {
    recording_failed = true;
    log::error("viewer: the recording: ", s.error());
  }
  return s;
}

void Viewer::Impl::requestSnapshot(uint32_t channel) {
  for (size_t i = 0; i < channels.size(); ++i)
    if (channels[i].voxel_delta == channel) published[i]->snapshot_wanted = true;
  view.notifyAll();
}

Result<std::unique_ptr<Viewer>> Viewer::create(ViewerOptions options, const msg::KeyStore& server_keys) {
  using R = Result<std::unique_ptr<Viewer>>;
  if (options.robots.empty()) return R::failure("viewer: no robots");
  const Result<std::string> web_dir = findWebDir(options.web_dir);
  if (!web_dir) return R::failure("viewer: " + web_dir.error());
  options.web_dir = *web_dir;
  if (!std::filesystem::is_regular_file(options.three_dir + "/three.min.js"))
    return R::failure("viewer: three.js not found in " + options.three_dir + " (Debian package libjs-three)");
  const std::vector<std::string> robots = options.robots;
  auto impl = std::make_unique<Impl>(std::move(options), robots);
  if (const Status s = impl->subscriber.setKeys(server_keys, impl->options.open); !s)
    return R::failure(s.error());
  WsServerOptions ws;
  ws.bind = impl->options.bind;
  ws.port = impl->options.port;
  ws.web_dir = impl->options.web_dir;
  ws.three_dir = impl->options.three_dir;
  ws.max_clients = impl->options.max_clients;
  ws.limits.max_queue_bytes = impl->options.max_queue_bytes;
  Impl* raw = impl.get();
  const std::vector<ChannelInfo> list = impl->makeChannels();
  if (const Status s = impl->openRecording(list); !s) return R::failure("viewer: " + s.error());
  impl->server = std::make_unique<WsServer>(ws, list, [raw](uint32_t c) { raw->requestSnapshot(c); });
  return std::unique_ptr<Viewer>(new Viewer(std::move(impl)));
}

Viewer::Viewer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Viewer::~Viewer() { stop(); }

Status Viewer::subscribe(transport::Transport& transport) { return impl_->subscriber.subscribe(transport); }

Status Viewer::start() {
  Impl& m = *impl_;
  if (m.started) return Status::failure("viewer already started");
  if (const Status s = m.server->start(); !s) return s;
  m.started = true;
  m.thread = std::thread([&m] { m.run(); });
  return Status::success();
}

void Viewer::stop() {
  Impl& m = *impl_;
  m.subscriber.disable();
  m.stopping = true;
  m.view.notifyAll();
  if (m.thread.joinable()) m.thread.join();
  m.server->stop();
  m.closeRecording();
}

int Viewer::port() const { return impl_->server->port(); }

ViewerStats Viewer::stats() const {
  const WsServerStats w = impl_->server->stats();
  ViewerStats s;
  s.clients = w.clients;
  s.connections = w.connections;
  s.messages_sent = w.messages_sent;
  s.bytes_sent = w.bytes_sent;
  s.dropped_messages = w.dropped_messages;
  s.malformed = w.malformed;
  s.unknown_ops = w.unknown_ops;
  s.refused_subscriptions = w.refused_subscriptions;
  s.refused_connections = w.refused_connections;
  s.map_updates = impl_->subscriber.mapUpdates();
  s.map_errors = impl_->subscriber.mapErrors();
  s.rejected_stream_messages = impl_->subscriber.rejected();
  s.voxels = impl_->voxels_total;
  s.recorded_messages = impl_->recorded_messages;
  s.recording_failed = impl_->recording_failed;
  return s;
}

}  // namespace rgbdmap::viewer
