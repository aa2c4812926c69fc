// VoxelCloud accumulation and the binary PLY writer/reader.
#include "rgbdmap/export/point_cloud_export.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

#include "atomic_file.hpp"

namespace rgbdmap {
namespace {

constexpr int64_t kIndexBits = 21;  ///< per axis: voxel indices in [-2^20, 2^20)
constexpr int64_t kIndexHalf = int64_t{1} << (kIndexBits - 1);
constexpr size_t kPlyVertexBytes = 15;
constexpr size_t kMaxPlyHeaderBytes = 4096;
constexpr uint64_t kMaxPlyVertices = uint64_t{1} << 31;

bool voxelKey(const Eigen::Vector3d& p, double voxel_m, uint64_t* key) {
  uint64_t k = 0;
  for (int a = 0; a < 3; ++a) {
    const double i = std::floor(p[a] / voxel_m);
    if (!(i >= -static_cast<double>(kIndexHalf) && i < static_cast<double>(kIndexHalf))) return false;
    k = (k << kIndexBits) | static_cast<uint64_t>(static_cast<int64_t>(i) + kIndexHalf);
  }
  *key = k;
  return true;
}

void putFloat(std::string* out, float f) {
  uint32_t u = 0;
  std::memcpy(&u, &f, 4);
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((u >> (8 * i)) & 0xff));
}

float getFloat(const unsigned char* b) {
  const uint32_t u = uint32_t{b[0]} | (uint32_t{b[1]} << 8) | (uint32_t{b[2]} << 16) | (uint32_t{b[3]} << 24);
  float f = 0;
  std::memcpy(&f, &u, 4);
  return f;
}

using PlyResult = Result<std::vector<ColoredPoint>>;

/// Parses the header lines; returns the vertex count or the reason the header is not ours.
Result<uint64_t> parsePlyHeader(const std::string& header) {
  std::istringstream lines(header);
  std::string line;
  std::vector<std::string> props;
  uint64_t count = 0;
  bool have_format = false, have_vertex = false;
  int line_no = 0;
  while (std::getline(lines, line)) {
    ++line_no;
    std::istringstream words(line);
    std::string w0, w1, w2, w3;
    words >> w0 >> w1 >> w2 >> w3;
    if (line_no == 1) {
      if (line != "ply") return Result<uint64_t>::failure("not a PLY file (no 'ply' magic)");
    } else if (w0 == "format") {
      if (w1 != "binary_little_endian" || w2 != "1.0")
        return Result<uint64_t>::failure("unsupported format '" + line + "'");
      have_format = true;
    } else if (w0 == "comment" || w0 == "obj_info") {
    } else if (w0 == "element") {
      if (w1 != "vertex" || have_vertex)
        return Result<uint64_t>::failure("unexpected element '" + line + "'");
      if (w2.empty() || w2.find_first_not_of("0123456789") != std::string::npos || w2.size() > 12)
        return Result<uint64_t>::failure("bad vertex count '" + w2 + "'");
      count = std::stoull(w2);
      if (count > kMaxPlyVertices) return Result<uint64_t>::failure("vertex count too large");
      have_vertex = true;
    } else if (w0 == "property") {
      if (!have_vertex) return Result<uint64_t>::failure("property before element");
      props.push_back(w1 + " " + w2);
    } else if (!line.empty()) {
      return Result<uint64_t>::failure("unexpected header line '" + line + "'");
    }
  }
  if (!have_format) return Result<uint64_t>::failure("no format line");
  if (!have_vertex) return Result<uint64_t>::failure("no vertex element");
  const std::vector<std::string> expected{"float x",   "float y",     "float z",
                                          "uchar red", "uchar green", "uchar blue"};
  if (props != expected)
    return Result<uint64_t>::failure("vertex properties are not x y z float, red green blue uchar");
  return count;
}

}  // namespace

VoxelCloud::VoxelCloud(double voxel_m) : voxel_m_(voxel_m) {}

Status VoxelCloud::add(const std::vector<Eigen::Vector3f>& points_cam,
                       const std::vector<std::array<uint8_t, 3>>& rgb, const SE3& T_map_cam) {
  if (!(std::isfinite(voxel_m_) && voxel_m_ > 0.0))
    return Status::failure("voxel size must be finite and > 0");
  if (points_cam.size() != rgb.size()) return Status::failure("points and colours differ in count");
  if (!se3::isValid(T_map_cam)) return Status::failure("T_map_cam is not a rigid transform");
  for (size_t i = 0; i < points_cam.size(); ++i) {
    const Eigen::Vector3f& pc = points_cam[i];
    uint64_t key = 0;
    if (!pc.allFinite()) {
      ++skipped_;
      continue;
    }
    const Eigen::Vector3d p = T_map_cam * pc.cast<double>();
    if (!voxelKey(p, voxel_m_, &key)) {
      ++skipped_;
      continue;
    }
    Sum& s = voxels_[key];
    s.x += p.x();
    s.y += p.y();
    s.z += p.z();
    s.r += rgb[i][0];
    s.g += rgb[i][1];
    s.b += rgb[i][2];
    ++s.n;
  }
  return Status::success();
}

std::vector<ColoredPoint> VoxelCloud::points() const {
  std::vector<std::pair<uint64_t, const Sum*>> sorted;
  sorted.reserve(voxels_.size());
  for (const auto& [key, sum] : voxels_) sorted.emplace_back(key, &sum);
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<ColoredPoint> out;
  out.reserve(sorted.size());
  for (const auto& [key, s] : sorted) {
    const double n = s->n;
    ColoredPoint c;
    c.p = Eigen::Vector3f(static_cast<float>(s->x / n), static_cast<float>(s->y / n),
                          static_cast<float>(s->z / n));
    auto mean = [n](uint32_t v) { return static_cast<uint8_t>(std::lround(v / n)); };
    c.rgb = {mean(s->r), mean(s->g), mean(s->b)};
    out.push_back(c);
  }
  return out;
}

Status writePly(const std::string& path, const std::vector<ColoredPoint>& points) {
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\ncomment rgbdmap map point cloud (map frame, metres)\nelement "
      "vertex " +
      std::to_string(points.size()) +
      "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nend_header\n";
  bytes.reserve(bytes.size() + points.size() * kPlyVertexBytes);
  for (size_t i = 0; i < points.size(); ++i) {
    const ColoredPoint& c = points[i];
    if (!c.p.allFinite()) return Status::failure("point " + std::to_string(i) + " is not finite");
    for (int a = 0; a < 3; ++a) putFloat(&bytes, c.p[a]);
    for (uint8_t v : c.rgb) bytes.push_back(static_cast<char>(v));
  }
  Status s = export_detail::writeFileAtomically(path, bytes);
  return s ? s : Status::failure("PLY: " + s.error());
}

PlyResult readPly(const std::string& path) {
  auto file = export_detail::readWholeFile(path, kMaxPlyHeaderBytes + kMaxPlyVertices * kPlyVertexBytes);
  if (!file) return PlyResult::failure(file.error());
  const std::string& bytes = *file;
  const std::string end_marker = "end_header\n";
  const size_t end = bytes.find(end_marker);
  if (end == std::string::npos || end > kMaxPlyHeaderBytes)
    return PlyResult::failure(path + ": PLY header without end_header");
  auto count = parsePlyHeader(bytes.substr(0, end));
  if (!count) return PlyResult::failure(path + ": " + count.error());
  const size_t body = end + end_marker.size();
  const size_t expected = *count * kPlyVertexBytes;
  if (bytes.size() - body != expected)
    return PlyResult::failure(path + ": body has " + std::to_string(bytes.size() - body) +
                              " bytes, header says " + std::to_string(expected) +
                              (bytes.size() - body < expected ? " (truncated)" : ""));
  std::vector<ColoredPoint> points(*count);
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data()) + body;
  for (ColoredPoint& c : points) {
    c.p = Eigen::Vector3f(getFloat(b), getFloat(b + 4), getFloat(b + 8));
    c.rgb = {b[12], b[13], b[14]};
    b += kPlyVertexBytes;
  }
  return points;
}

}  // namespace rgbdmap
