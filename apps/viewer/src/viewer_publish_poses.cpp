// The viewer's publisher, robots' poses and 2-D maps: /R/trajectory, /R/pose (the robot's live RobotPose,
// else its newest optimised keyframe), /tf, and /R/map_grid (the global 2-D map of R's map, cut from the
// viewer's copy of the tree like the server's map_<id>.pgm).
#include "viewer_impl.hpp"

namespace rgbdmap::viewer {

void Viewer::Impl::publishPoses(size_t index, const RobotSnapshot& s, bool trajectory) {
  const int64_t utime = nowUtime();
  if (trajectory) {
    std::vector<SE3> poses;
    for (const msg::CorrectedPose& k : s.keyframes) poses.push_back(k.T_map_cam);
    send(channels[index].trajectory, posesInFrameJson(poses, utime, "map"), utime);
  }
  bool live = false;
  if (const std::optional<SE3> pose = currentPose(s, utime, &live))
    send(channels[index].pose, poseInFrameJson(*pose, utime, "map"), utime);
}

void Viewer::Impl::publishTransforms() {
  std::vector<FrameTransform> transforms;
  const int64_t utime = nowUtime();
  for (const std::string& robot : view.robots()) {
    const RobotSnapshot s = view.snapshot(robot);
    bool live = false;
    const std::optional<SE3> pose = currentPose(s, utime, &live);
    if (!pose) continue;
    transforms.push_back({"map", robot, *pose});
    transforms.push_back({"map", robot + "_odom", s.T_map_odom});
  }
  send(tf_channel, frameTransformsJson(transforms, utime), utime);
}

void Viewer::Impl::publishMapGrid(size_t index, const RobotSnapshot& s) {
  RobotPublished& p = *published[index];
  if (!p.grid_pending ||
      std::chrono::duration<double>(std::chrono::steady_clock::now() - p.last_grid).count() <
          options.cloud_period_s)
    return;
  p.grid_pending = false;
  p.last_grid = std::chrono::steady_clock::now();
  SliceConfig config;  // the band and cell size of the robot's slices, when one came
  if (s.slice) {
    config.resolution_m = s.slice->resolution_m;
    config.z_min_m = s.slice->z_min_m;
    config.z_max_m = s.slice->z_max_m;
  }
  Result<msg::OccupancySlice> grid = view.mapGrid(view.robots()[index], mapCutHeight(s), config);
  if (!grid) return;
  grid->header.utime = nowUtime();
  send(channels[index].map_grid, gridJson(*grid, "map"), grid->header.utime);
}

}  // namespace rgbdmap::viewer
