// The bridge's publisher thread: waits for the MapView to change (or the next /tf period) and writes what
// changed as ROS 2 samples. Samples point into strings and vectors that live until dds_write returns.
#include "rgbdmap/ros2_bridge/bridge.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <deque>
#include <thread>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/ros2/dds.hpp"
#include "rgbdmap/viewer/map_subscriber.hpp"
#include "rgbdmap/viewer/map_view.hpp"

namespace rgbdmap::ros2 {
namespace {

using Clock = std::chrono::steady_clock;

int64_t nowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

builtin_interfaces_msg_dds__Time_ rosTime(int64_t utime) {
  builtin_interfaces_msg_dds__Time_ t{};
  utime = std::max<int64_t>(0, utime);
  t.sec = static_cast<int32_t>(utime / 1000000);
  t.nanosec = static_cast<uint32_t>(utime % 1000000) * 1000u;
  return t;
}

/// Strings the samples point to; stable while the holder lives (a deque does not move its elements).
struct Strings {
  std::deque<std::string> held;
  char* operator()(std::string s) {
    held.push_back(std::move(s));
    return held.back().data();
  }
};

std_msgs_msg_dds__Header_ header(int64_t utime, const std::string& frame, Strings& strings) {
  std_msgs_msg_dds__Header_ h{};
  h.stamp = rosTime(utime);
  h.frame_id = strings(frame);
  return h;
}

geometry_msgs_msg_dds__Pose_ rosPose(const SE3& T) {
  geometry_msgs_msg_dds__Pose_ p{};
  const Vec3 t = T.translation();
  const Eigen::Quaterniond q = se3::quat(T);
  p.position = {t.x(), t.y(), t.z()};
  p.orientation = {q.x(), q.y(), q.z(), q.w()};
  return p;
}

geometry_msgs_msg_dds__TransformStamped_ rosTransform(const SE3& T, const std::string& parent,
                                                      const std::string& child, int64_t utime,
                                                      Strings& strings) {
  geometry_msgs_msg_dds__TransformStamped_ m{};
  m.header = header(utime, parent, strings);
  m.child_frame_id = strings(child);
  const geometry_msgs_msg_dds__Pose_ p = rosPose(T);
  m.transform.translation = {p.position.x, p.position.y, p.position.z};
  m.transform.rotation = p.orientation;
  return m;
}

template <typename Seq, typename T>
void borrow(Seq* seq, const std::vector<T>& v) {
  seq->_length = seq->_maximum = static_cast<uint32_t>(v.size());
  seq->_buffer = const_cast<T*>(v.data());
  seq->_release = false;
}

}  // namespace

struct Bridge::Impl {
  Impl(BridgeOptions o) : options(std::move(o)), view(options.robots), subscriber(view) {}

  struct RobotOut {
    std::string token;  ///< the robot id as a ROS name token
    SE3 mount = defaultT_base_camera();
    dds_entity_t pose = 0, path = 0, local_map = 0;
    viewer::RobotSnapshot seen;
    std::string frame_seen;  ///< the map frame it was last published in
    bool live_used = false;
  };

  Status createWriters();
  void run();
  void publishRobot(RobotOut& r, const viewer::RobotSnapshot& s, const std::string& frame);
  void publishMainMap(const std::string& robot, const viewer::RobotSnapshot& s);
  void publishTransforms(const std::vector<viewer::RobotSnapshot>& snapshots,
                         const std::vector<std::string>& frames);
  void publishStatic();
  Status writeGrid(dds_entity_t writer, const msg::OccupancySlice& grid, const std::string& frame);
  void count(dds_return_t rc, const char* topic);

  BridgeOptions options;
  viewer::MapView view;
  viewer::MapSubscriber subscriber;
  std::vector<RobotOut> robots;
  dds_entity_t participant = 0, map = 0, octomap = 0, cloud = 0, tf = 0, tf_static = 0;
  std::string main_robot;  ///< whose map /map, /octomap_binary and /map_cloud were last cut from
  uint64_t main_map_changes = 0;
  bool main_pending = false;
  Clock::time_point last_main{}, last_tf{};
  std::thread thread;
  std::atomic<bool> stopping{false};
  std::atomic<uint64_t> published{0}, publish_errors{0}, voxels{0};
  bool started = false;
};

void Bridge::Impl::count(dds_return_t rc, const char* topic) {
  if (rc >= 0) {
    ++published;
    return;
  }
  if (publish_errors++ == 0) log::warn("ros2: ", ddsError(topic, rc));
}

Status Bridge::Impl::createWriters() {
  participant = dds_create_participant(static_cast<dds_domainid_t>(options.domain), nullptr, nullptr);
  if (participant < 0) return Status::failure(ddsError("dds_create_participant", participant));
  auto make = [&](const dds_topic_descriptor_t* type, const std::string& name, const Qos& qos,
                  dds_entity_t* out) -> Status {
    auto w = createWriter(participant, type, name, qos);
    if (!w) return Status::failure(w.error());
    *out = *w;
    return Status::success();
  };
  for (const Status& s :
       {make(&nav_msgs_msg_dds__OccupancyGrid__desc, "/map", latchedQos(), &map),
        make(&octomap_msgs_msg_dds__Octomap__desc, "/octomap_binary", latchedQos(), &octomap),
        make(&sensor_msgs_msg_dds__PointCloud2__desc, "/map_cloud", latchedQos(), &cloud),
        make(&tf2_msgs_msg_dds__TFMessage__desc, "/tf", defaultQos(100), &tf),
        make(&tf2_msgs_msg_dds__TFMessage__desc, "/tf_static", latchedQos(), &tf_static)})
    if (!s) return s;
  for (RobotOut& r : robots) {
    const std::string ns = "/" + r.token;
    for (const Status& s :
         {make(&geometry_msgs_msg_dds__PoseStamped__desc, ns + "/pose", latchedQos(), &r.pose),
          make(&nav_msgs_msg_dds__Path__desc, ns + "/path", latchedQos(), &r.path),
          make(&nav_msgs_msg_dds__OccupancyGrid__desc, ns + "/local_map", latchedQos(), &r.local_map)})
      if (!s) return s;
  }
  return Status::success();
}

Status Bridge::Impl::writeGrid(dds_entity_t writer, const msg::OccupancySlice& grid,
                               const std::string& frame) {
  Strings strings;
  nav_msgs_msg_dds__OccupancyGrid_ m{};
  m.header = header(grid.header.utime, frame, strings);
  m.info.map_load_time = rosTime(grid.header.utime);
  m.info.resolution = grid.resolution_m;
  m.info.width = static_cast<uint32_t>(grid.width);
  m.info.height = static_cast<uint32_t>(grid.height);
  m.info.origin = rosPose(grid.T_map_grid);
  borrow(&m.data, grid.cells);
  const dds_return_t rc = dds_write(writer, &m);
  return rc < 0 ? Status::failure(ddsError("dds_write", rc)) : Status::success();
}

void Bridge::Impl::publishStatic() {
  Strings strings;
  std::vector<geometry_msgs_msg_dds__TransformStamped_> transforms;
  const int64_t utime = nowUtime();
  for (const RobotOut& r : robots)
    transforms.push_back(
        rosTransform(r.mount, r.token + "/base_link", r.token + "/camera_optical_frame", utime, strings));
  tf2_msgs_msg_dds__TFMessage_ m{};
  borrow(&m.transforms, transforms);
  count(dds_write(tf_static, &m), "/tf_static");
}

void Bridge::Impl::run() {
  uint64_t seen = 0, copied = 0;
  std::vector<viewer::RobotSnapshot> snapshots;
  std::vector<std::string> frames(robots.size());
  size_t main_index = 0;
  publishStatic();
  while (!stopping) {
    seen = view.waitForChange(seen, options.tf_period_s);
    if (stopping) break;
    if (snapshots.empty() || seen != copied) {  // a /tf tick with nothing new reuses the last copies
      copied = seen;
      snapshots.clear();
      std::vector<std::vector<msg::MapLoopEdge>> loops;
      for (const std::string& id : options.robots) {
        snapshots.push_back(view.snapshot(id));
        loops.push_back(snapshots.back().loops);
      }
      const auto groups = mapGroups(options.robots, loops);
      for (size_t g = 0; g < groups.size(); ++g)
        for (const std::string& id : groups[g]) {
          const size_t i = static_cast<size_t>(std::find(options.robots.begin(), options.robots.end(), id) -
                                               options.robots.begin());
          frames[i] = g == 0 ? "map" : rosNameToken(groups[g].front()) + "/map";
        }
      main_index = static_cast<size_t>(
          std::find(options.robots.begin(), options.robots.end(), groups.front().front()) -
          options.robots.begin());
    }
    for (size_t i = 0; i < robots.size(); ++i) publishRobot(robots[i], snapshots[i], frames[i]);
    publishMainMap(options.robots[main_index], snapshots[main_index]);
    if (secondsSince(last_tf) >= options.tf_period_s) {
      last_tf = Clock::now();
      publishTransforms(snapshots, frames);
    }
  }
}

void Bridge::Impl::publishRobot(RobotOut& r, const viewer::RobotSnapshot& s, const std::string& frame) {
  const bool moved = frame != r.frame_seen;
  const int64_t utime = nowUtime();
  Strings strings;
  const bool trajectory = moved || s.pose_changes != r.seen.pose_changes;
  if (trajectory && !s.keyframes.empty()) {
    std::vector<geometry_msgs_msg_dds__PoseStamped_> poses;
    for (const msg::CorrectedPose& k : s.keyframes) {
      geometry_msgs_msg_dds__PoseStamped_ p{};
      p.header = header(utime, frame, strings);
      p.pose = rosPose(baseOf(k.T_map_cam, r.mount));
      poses.push_back(p);
    }
    nav_msgs_msg_dds__Path_ m{};
    m.header = header(utime, frame, strings);
    borrow(&m.poses, poses);
    count(dds_write(r.path, &m), "path");
  }
  bool live = false;
  const std::optional<SE3> pose = viewer::currentPose(s, utime, &live);
  if (pose && (trajectory || s.live_changes != r.seen.live_changes || live != r.live_used)) {
    r.live_used = live;
    geometry_msgs_msg_dds__PoseStamped_ m{};
    m.header = header(live ? s.live_pose->header.utime : utime, frame, strings);
    m.pose = rosPose(baseOf(*pose, r.mount));
    count(dds_write(r.pose, &m), "pose");
  }
  if ((moved || s.slice_changes != r.seen.slice_changes) && s.slice) {
    const Status st = writeGrid(r.local_map, *s.slice, frame);
    count(st ? 0 : DDS_RETCODE_ERROR, "local_map");
  }
  r.seen = s;
  r.frame_seen = frame;
}

void Bridge::Impl::publishMainMap(const std::string& robot, const viewer::RobotSnapshot& s) {
  if (robot != main_robot || s.map_changes != main_map_changes) main_pending = s.map_revision >= 0;
  main_robot = robot;
  main_map_changes = s.map_changes;
  if (!main_pending || secondsSince(last_main) < options.map_period_s) return;
  main_pending = false;
  last_main = Clock::now();
  const int64_t utime = nowUtime();
  Strings strings;
  SliceConfig config;  // the band and cell size of the robot's slices, when one came
  if (s.slice) {
    config.resolution_m = s.slice->resolution_m;
    config.z_min_m = s.slice->z_min_m;
    config.z_max_m = s.slice->z_max_m;
  }
  if (Result<msg::OccupancySlice> grid = view.mapGrid(robot, viewer::mapCutHeight(s), config)) {
    grid->header.utime = utime;
    const Status st = writeGrid(map, *grid, "map");
    count(st ? 0 : DDS_RETCODE_ERROR, "/map");
  }
  double resolution = 0.05;
  int64_t revision = 0;
  if (Result<std::string> tree = view.octomapBinary(robot, &resolution, &revision)) {
    octomap_msgs_msg_dds__Octomap_ m{};
    m.header = header(utime, "map", strings);
    m.binary = true;
    m.id = strings("OcTree");
    m.resolution = resolution;
    m.data._length = m.data._maximum = static_cast<uint32_t>(tree->size());
    m.data._buffer = reinterpret_cast<int8_t*>(tree->data());
    m.data._release = false;
    count(dds_write(octomap, &m), "/octomap_binary");
  }
  int64_t cloud_revision = 0;
  const std::vector<viewer::Voxel> occupied = view.occupiedVoxels(robot, &cloud_revision);
  const std::vector<uint8_t> data = pointCloudData(occupied);
  std::vector<sensor_msgs_msg_dds__PointField_> fields;
  for (const auto& [name, offset] :
       {std::pair<const char*, uint32_t>{"x", 0}, {"y", 4}, {"z", 8}, {"rgb", 12}}) {
    sensor_msgs_msg_dds__PointField_ f{};
    f.name = strings(name);
    f.offset = offset;
    f.datatype = 7;  // FLOAT32
    f.count = 1;
    fields.push_back(f);
  }
  sensor_msgs_msg_dds__PointCloud2_ m{};
  m.header = header(utime, "map", strings);
  m.height = 1;
  m.width = static_cast<uint32_t>(occupied.size());
  borrow(&m.fields, fields);
  m.is_bigendian = false;
  m.point_step = 16;
  m.row_step = static_cast<uint32_t>(data.size());
  borrow(&m.data, data);
  m.is_dense = true;
  count(dds_write(cloud, &m), "/map_cloud");
  voxels = occupied.size();
}

void Bridge::Impl::publishTransforms(const std::vector<viewer::RobotSnapshot>& snapshots,
                                     const std::vector<std::string>& frames) {
  Strings strings;
  std::vector<geometry_msgs_msg_dds__TransformStamped_> transforms;
  const int64_t utime = nowUtime();
  for (size_t i = 0; i < robots.size(); ++i) {
    const viewer::RobotSnapshot& s = snapshots[i];
    if (s.graph_revision < 0) continue;  // no corrections yet: T_map_odom unknown
    bool live = false;
    const std::optional<SE3> pose = viewer::currentPose(s, utime, &live);
    if (!pose) continue;
    const RobotOut& r = robots[i];
    const OdomTransforms t = odomTransforms(s.T_map_odom, *pose, r.mount);
    transforms.push_back(rosTransform(t.T_map_odom, frames[i], r.token + "/odom", utime, strings));
    transforms.push_back(
        rosTransform(t.T_odom_base, r.token + "/odom", r.token + "/base_link", utime, strings));
  }
  if (transforms.empty()) return;
  tf2_msgs_msg_dds__TFMessage_ m{};
  borrow(&m.transforms, transforms);
  count(dds_write(tf, &m), "/tf");
}

Bridge::Bridge(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Bridge::~Bridge() { stop(); }

Result<std::unique_ptr<Bridge>> Bridge::create(BridgeOptions options, const msg::KeyStore& server_keys) {
  using R = Result<std::unique_ptr<Bridge>>;
  if (options.robots.empty()) return R::failure("no robots");
  if (!(options.map_period_s >= 0.0) || !(options.tf_period_s > 0.0))
    return R::failure("map_period_s must be >= 0 and tf_period_s > 0");
  auto impl = std::make_unique<Impl>(std::move(options));
  if (const Status s = impl->subscriber.setKeys(server_keys, impl->options.open); !s)
    return R::failure(s.error());
  std::vector<std::string> tokens;
  for (const std::string& id : impl->options.robots) {
    Impl::RobotOut r;
    r.token = rosNameToken(id);
    if (std::find(tokens.begin(), tokens.end(), r.token) != tokens.end())
      return R::failure("robots '" + id + "' and another have the same ROS name '" + r.token + "'");
    tokens.push_back(r.token);
    if (const auto it = impl->options.mounts.find(id); it != impl->options.mounts.end()) r.mount = it->second;
    impl->robots.push_back(std::move(r));
  }
  return R(std::unique_ptr<Bridge>(new Bridge(std::move(impl))));
}

Status Bridge::subscribe(transport::Transport& transport) { return impl_->subscriber.subscribe(transport); }

Status Bridge::start() {
  if (impl_->started) return Status::failure("already started");
  if (const Status s = checkDdsConfiguration(); !s) return s;
  if (const Status s = impl_->createWriters(); !s) {
    if (impl_->participant > 0) dds_delete(impl_->participant);
    impl_->participant = 0;
    return s;
  }
  impl_->started = true;
  impl_->thread = std::thread([this] { impl_->run(); });
  return Status::success();
}

void Bridge::stop() {
  impl_->subscriber.disable();
  impl_->stopping = true;
  impl_->view.notifyAll();
  if (impl_->thread.joinable()) impl_->thread.join();
  if (impl_->participant > 0) dds_delete(impl_->participant);
  impl_->participant = 0;
}

BridgeStats Bridge::stats() const {
  BridgeStats s;
  s.published = impl_->published;
  s.publish_errors = impl_->publish_errors;
  s.map_updates = impl_->subscriber.mapUpdates();
  s.map_errors = impl_->subscriber.mapErrors();
  s.rejected_stream_messages = impl_->subscriber.rejected();
  s.voxels = impl_->voxels;
  return s;
}

}  // namespace rgbdmap::ros2
