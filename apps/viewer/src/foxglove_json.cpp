// The Foxglove schemas as JSON Schema (the subset of fields this viewer fills, with the public schemas'
// names and types) and the message builders.
#include "rgbdmap/viewer/foxglove_json.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>

namespace rgbdmap::viewer {
namespace {

using nlohmann::json;

json object(const std::string& title, json properties) {
  json o = {{"type", "object"}, {"properties", std::move(properties)}};
  if (!title.empty()) o["title"] = title;
  return o;
}
json number() { return {{"type", "number"}}; }
json integer() { return {{"type", "integer"}}; }
json string() { return {{"type", "string"}}; }
json boolean() { return {{"type", "boolean"}}; }
json bytes() { return {{"type", "string"}, {"contentEncoding", "base64"}}; }
json array(json items) { return {{"type", "array"}, {"items", std::move(items)}}; }

json timeSchema() { return object("time", {{"sec", integer()}, {"nsec", integer()}}); }
json vector3Schema() {
  return object("foxglove.Vector3", {{"x", number()}, {"y", number()}, {"z", number()}});
}
json quaternionSchema() {
  return object("foxglove.Quaternion", {{"x", number()}, {"y", number()}, {"z", number()}, {"w", number()}});
}
json poseSchema() {
  return object("foxglove.Pose", {{"position", vector3Schema()}, {"orientation", quaternionSchema()}});
}
json numericTypeSchema() {
  json one_of = json::array();
  const char* names[] = {"UNKNOWN", "UINT8", "INT8",    "UINT16", "INT16",
                         "UINT32",  "INT32", "FLOAT32", "FLOAT64"};
  for (int i = 0; i < 9; ++i) one_of.push_back({{"const", i}, {"title", names[i]}});
  return {{"title", "foxglove.NumericType"}, {"oneOf", one_of}};
}
json fieldsSchema() {
  return array(object("foxglove.PackedElementField",
                      {{"name", string()}, {"offset", integer()}, {"type", numericTypeSchema()}}));
}

std::map<std::string, json> buildSchemas() {
  std::map<std::string, json> s;
  s["foxglove.PointCloud"] = object("foxglove.PointCloud", {{"timestamp", timeSchema()},
                                                            {"frame_id", string()},
                                                            {"pose", poseSchema()},
                                                            {"point_stride", integer()},
                                                            {"fields", fieldsSchema()},
                                                            {"data", bytes()}});
  s["foxglove.PosesInFrame"] =
      object("foxglove.PosesInFrame",
             {{"timestamp", timeSchema()}, {"frame_id", string()}, {"poses", array(poseSchema())}});
  s["foxglove.PoseInFrame"] = object(
      "foxglove.PoseInFrame", {{"timestamp", timeSchema()}, {"frame_id", string()}, {"pose", poseSchema()}});
  s["foxglove.FrameTransforms"] =
      object("foxglove.FrameTransforms",
             {{"transforms", array(object("foxglove.FrameTransform", {{"timestamp", timeSchema()},
                                                                      {"parent_frame_id", string()},
                                                                      {"child_frame_id", string()},
                                                                      {"translation", vector3Schema()},
                                                                      {"rotation", quaternionSchema()}}))}});
  s["foxglove.Grid"] =
      object("foxglove.Grid", {{"timestamp", timeSchema()},
                               {"frame_id", string()},
                               {"pose", poseSchema()},
                               {"column_count", integer()},
                               {"cell_size", object("foxglove.Vector2", {{"x", number()}, {"y", number()}})},
                               {"row_stride", integer()},
                               {"cell_stride", integer()},
                               {"fields", fieldsSchema()},
                               {"data", bytes()}});
  const json colour =
      object("foxglove.Color", {{"r", number()}, {"g", number()}, {"b", number()}, {"a", number()}});
  const json line = object(
      "foxglove.LinePrimitive",
      {{"type",
        {{"title", "foxglove.LineType"},
         {"oneOf", json::array({{{"const", 0}, {"title", "LINE_STRIP"}},
                                {{"const", 1}, {"title", "LINE_LOOP"}},
                                {{"const", 2}, {"title", "LINE_LIST"}}})}}},
       {"pose", poseSchema()},
       {"thickness", number()},
       {"scale_invariant", {{"type", "boolean"}}},
       {"points", array(object("foxglove.Point3", {{"x", number()}, {"y", number()}, {"z", number()}}))},
       {"color", colour},
       {"colors", array(colour)},
       {"indices", array(integer())}});
  json entity_properties = {
      {"timestamp", timeSchema()},
      {"frame_id", string()},
      {"id", string()},
      {"lifetime", object("duration", {{"sec", integer()}, {"nsec", integer()}})},
      {"frame_locked", {{"type", "boolean"}}},
      {"metadata", array(object("foxglove.KeyValuePair", {{"key", string()}, {"value", string()}}))},
      {"lines", array(line)}};
  for (const char* kind : {"arrows", "cubes", "spheres", "cylinders", "triangles", "texts", "models"})
    entity_properties[kind] = array(object("", json::object()));  // never filled: always empty
  s["foxglove.SceneUpdate"] = object(
      "foxglove.SceneUpdate",
      {{"deletions", array(object("foxglove.SceneEntityDeletion",
                                  {{"timestamp", timeSchema()}, {"type", integer()}, {"id", string()}}))},
       {"entities", array(object("foxglove.SceneEntity", entity_properties))}});
  // rgbdmap's own: incremental voxels for the web page (coordinates flat x0,y0,z0,x1,...), robot status.
  s["rgbdmap.VoxelDelta"] = object("rgbdmap.VoxelDelta", {{"revision", integer()},
                                                          {"full", {{"type", "boolean"}}},
                                                          {"resolution", number()},
                                                          {"frame_id", string()},
                                                          {"add", array(number())},
                                                          {"remove", array(number())},
                                                          {"voxels", integer()},
                                                          {"map_utime", integer()},
                                                          {"robot_keyframe", integer()}});
  s["rgbdmap.RobotStatus"] = object("rgbdmap.RobotStatus", {{"robot", string()},
                                                            {"keyframes", integer()},
                                                            {"loops", integer()},
                                                            {"map_revision", integer()},
                                                            {"voxels", integer()},
                                                            {"bytes_down", integer()},
                                                            {"down_kbps", number()},
                                                            {"last_seen_s", number()},
                                                            {"live_poses", integer()},
                                                            {"spool_depth", integer()},
                                                            {"oldest_unanswered_s", number()},
                                                            {"live_only", boolean()},
                                                            {"link", string()},
                                                            {"state", string()},
                                                            {"map_mode", string()},
                                                            {"placed", boolean()}});
  return s;
}

}  // namespace

std::string schemaFor(const std::string& schema_name) {
  static const std::map<std::string, json> schemas = buildSchemas();
  const auto it = schemas.find(schema_name);
  return it == schemas.end() ? std::string() : it->second.dump();
}

std::string base64(const uint8_t* data, size_t size) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (size_t i = 0; i < size; i += 3) {
    const uint32_t b0 = data[i], b1 = i + 1 < size ? data[i + 1] : 0, b2 = i + 2 < size ? data[i + 2] : 0;
    const uint32_t v = (b0 << 16) | (b1 << 8) | b2;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < size ? kAlphabet[(v >> 6) & 63] : '=';
    out += i + 2 < size ? kAlphabet[v & 63] : '=';
  }
  return out;
}

json timeJson(int64_t utime) {
  const int64_t sec = utime / 1000000;
  return {{"sec", sec}, {"nsec", (utime - sec * 1000000) * 1000}};
}

json poseJson(const SE3& T) {
  const Eigen::Quaterniond q(T.rotation());
  const Vec3 t = T.translation();
  return {{"position", {{"x", t.x()}, {"y", t.y()}, {"z", t.z()}}},
          {"orientation", {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}}}};
}

void heightColour(float height, float low, float high, uint8_t rgb[3]) {
  const float t = high > low ? std::clamp((height - low) / (high - low), 0.0f, 1.0f) : 0.5f;
  // Blue -> cyan -> green -> yellow -> red.
  const float r = std::clamp(std::min(4 * t - 1.5f, -4 * t + 4.5f), 0.0f, 1.0f);
  const float g = std::clamp(std::min(4 * t - 0.5f, -4 * t + 3.5f), 0.0f, 1.0f);
  const float b = std::clamp(std::min(4 * t + 0.5f, -4 * t + 2.5f), 0.0f, 1.0f);
  rgb[0] = static_cast<uint8_t>(255 * r);
  rgb[1] = static_cast<uint8_t>(255 * g);
  rgb[2] = static_cast<uint8_t>(255 * b);
}

json pointCloudJson(const std::vector<Voxel>& voxels, int64_t utime, const std::string& frame) {
  constexpr size_t kStride = 16;
  float low = 0, high = 0;
  for (size_t i = 0; i < voxels.size(); ++i) {
    const float h = heightOf(voxels[i]);
    low = i == 0 ? h : std::min(low, h);
    high = i == 0 ? h : std::max(high, h);
  }
  std::vector<uint8_t> data(voxels.size() * kStride);
  for (size_t i = 0; i < voxels.size(); ++i) {
    uint8_t* p = data.data() + i * kStride;
    std::memcpy(p, &voxels[i].x, 4);
    std::memcpy(p + 4, &voxels[i].y, 4);
    std::memcpy(p + 8, &voxels[i].z, 4);
    heightColour(heightOf(voxels[i]), low, high, p + 12);
    p[15] = 255;
  }
  json fields = json::array();
  const std::pair<const char*, int> layout[] = {{"x", 0},      {"y", 4},     {"z", 8},     {"red", 12},
                                                {"green", 13}, {"blue", 14}, {"alpha", 15}};
  for (const auto& [name, offset] : layout)
    fields.push_back({{"name", name}, {"offset", offset}, {"type", offset < 12 ? 7 : 1}});
  return {{"timestamp", timeJson(utime)},      {"frame_id", frame},
          {"pose", poseJson(SE3::Identity())}, {"point_stride", kStride},
          {"fields", std::move(fields)},       {"data", base64(data.data(), data.size())}};
}

json posesInFrameJson(const std::vector<SE3>& poses, int64_t utime, const std::string& frame) {
  json list = json::array();
  for (const SE3& T : poses) list.push_back(poseJson(T));
  return {{"timestamp", timeJson(utime)}, {"frame_id", frame}, {"poses", std::move(list)}};
}

json poseInFrameJson(const SE3& pose, int64_t utime, const std::string& frame) {
  return {{"timestamp", timeJson(utime)}, {"frame_id", frame}, {"pose", poseJson(pose)}};
}

json frameTransformsJson(const std::vector<FrameTransform>& transforms, int64_t utime) {
  json list = json::array();
  for (const FrameTransform& f : transforms) {
    const json pose = poseJson(f.T_parent_child);
    list.push_back({{"timestamp", timeJson(utime)},
                    {"parent_frame_id", f.parent},
                    {"child_frame_id", f.child},
                    {"translation", pose["position"]},
                    {"rotation", pose["orientation"]}});
  }
  return {{"transforms", std::move(list)}};
}

json loopEdgesJson(const std::vector<msg::MapLoopEdge>& loops, int64_t utime, const std::string& frame,
                   const std::string& id) {
  json points = json::array(), colours = json::array();
  for (const msg::MapLoopEdge& e : loops)
    for (const Vec3& p : {e.p_from, e.p_to}) {
      points.push_back({{"x", p.x()}, {"y", p.y()}, {"z", p.z()}});
      colours.push_back(e.inter_robot ? json{{"r", 0.9}, {"g", 0.1}, {"b", 0.9}, {"a", 1.0}}
                                      : json{{"r", 1.0}, {"g", 0.55}, {"b", 0.0}, {"a", 1.0}});
    }
  json line = {{"type", 2},         {"pose", poseJson(SE3::Identity())},
               {"thickness", 2.0},  {"scale_invariant", true},
               {"points", points},  {"color", {{"r", 1.0}, {"g", 0.55}, {"b", 0.0}, {"a", 1.0}}},
               {"colors", colours}, {"indices", json::array()}};
  json entity = {
      {"timestamp", timeJson(utime)},          {"frame_id", frame},     {"id", id},
      {"lifetime", {{"sec", 0}, {"nsec", 0}}}, {"frame_locked", false}, {"metadata", json::array()},
      {"lines", json::array({line})}};
  for (const char* kind : {"arrows", "cubes", "spheres", "cylinders", "triangles", "texts", "models"})
    entity[kind] = json::array();
  return {{"deletions", json::array()}, {"entities", json::array({entity})}};
}

json gridJson(const msg::OccupancySlice& slice, const std::string& frame) {
  const float res = slice.resolution_m;
  return {{"timestamp", timeJson(slice.header.utime)},
          {"frame_id", frame},
          {"pose", poseJson(slice.T_map_grid)},
          {"column_count", slice.width},
          {"cell_size", {{"x", res}, {"y", res}}},
          {"row_stride", slice.width},
          {"cell_stride", 1},
          {"fields", json::array({{{"name", "occupancy"}, {"offset", 0}, {"type", 2}}})},
          {"data", base64(reinterpret_cast<const uint8_t*>(slice.cells.data()), slice.cells.size())}};
}

}  // namespace rgbdmap::viewer
