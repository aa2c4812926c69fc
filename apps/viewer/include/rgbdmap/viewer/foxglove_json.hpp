#pragma once
// Messages of the Foxglove WebSocket protocol's JSON encoding with the public Foxglove schemas
// (https://docs.foxglove.dev/docs/visualization/message-schemas): the JSON Schema text each channel
// advertises, and builders for the messages the viewer sends. Bytes fields (PointCloud.data, Grid.data) are
// base64 strings, as the schemas declare with "contentEncoding": "base64".
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::viewer {

/// A voxel centre in the map frame (metres).
struct Voxel {
  float x = 0, y = 0, z = 0;
};

/// JSON Schema text for a schema name this viewer sends: "foxglove.PointCloud", "foxglove.PosesInFrame",
/// "foxglove.PoseInFrame", "foxglove.FrameTransforms", "foxglove.Grid", "foxglove.SceneUpdate",
/// "rgbdmap.VoxelDelta", "rgbdmap.RobotStatus". Empty for any other name.
std::string schemaFor(const std::string& schema_name);

std::string base64(const uint8_t* data, size_t size);

nlohmann::json timeJson(int64_t utime);
nlohmann::json poseJson(const SE3& T);

/// foxglove.PointCloud of voxel centres in `frame`: x, y, z (float32) and red, green, blue, alpha (uint8)
/// coloured by height (z in the z-up map frame, see heightOf()).
nlohmann::json pointCloudJson(const std::vector<Voxel>& voxels, int64_t utime, const std::string& frame);
/// The colour of a voxel at a height (turbo-like ramp over [low, high]): r, g, b in 0..255.
void heightColour(float height, float low, float high, uint8_t rgb[3]);
/// Height in the map frame: the map frame is z-up (REP-103, the base frame of the first robot's first
/// keyframe).
inline float heightOf(const Voxel& v) { return v.z; }

/// foxglove.PosesInFrame / foxglove.PoseInFrame in `frame`.
nlohmann::json posesInFrameJson(const std::vector<SE3>& poses, int64_t utime, const std::string& frame);
nlohmann::json poseInFrameJson(const SE3& pose, int64_t utime, const std::string& frame);

struct FrameTransform {
  std::string parent, child;
  SE3 T_parent_child = SE3::Identity();
};
nlohmann::json frameTransformsJson(const std::vector<FrameTransform>& transforms, int64_t utime);

/// foxglove.SceneUpdate with one entity `id`: a line list, one segment per loop edge (same-chain loops
/// orange, inter-robot loops magenta).
nlohmann::json loopEdgesJson(const std::vector<msg::MapLoopEdge>& loops, int64_t utime,
                             const std::string& frame, const std::string& id);

/// foxglove.Grid of an occupancy slice: one int8 field "occupancy" (-1 unknown, 0 free .. 100 occupied),
/// row-major from the cell (0, 0) corner at T_map_grid.
nlohmann::json gridJson(const msg::OccupancySlice& slice, const std::string& frame);

}  // namespace rgbdmap::viewer
