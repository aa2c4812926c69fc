// Slice extraction: the tree's leaves in the slab's bounding box are rasterised once into a dense key grid
// (large free leaves fill many cells at once), then every cell samples its column from that grid.
#include "rgbdmap/map/occupancy_slice.hpp"

#include <cmath>
#include <sstream>

#include <octomap/OcTree.h>

#include "rgbdmap/map/map_config_tables.hpp"

namespace rgbdmap {
namespace {

enum : uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

/// Frame of the grid: x forward (horizontal), y left, z up; origin at cell (0,0)'s corner at camera height.
SE3 gridPose(const SE3& T_map_cam, const Vec3& up, double size_m) {
  const Mat3& R = T_map_cam.linear();
  Vec3 x = R.col(2) - R.col(2).dot(up) * up;                      // camera forward on the horizontal plane
  if (x.norm() < 1e-6) x = -R.col(1) - (-R.col(1)).dot(up) * up;  // looking straight up/down: image up
  x.normalize();
  const Vec3 y = up.cross(x);
  SE3 T = SE3::Identity();
  T.linear() << x, y, up;
  T.translation() = T_map_cam.translation() - 0.5 * size_m * (x + y);
  return T;
}

/// Dense copy of the tree's leaf states over a key box.
struct KeyBox {
  int lo[3], n[3];
  std::vector<uint8_t> state;
  size_t index(int x, int y, int z) const {
    return (static_cast<size_t>(x - lo[0]) * n[1] + (y - lo[1])) * n[2] + (z - lo[2]);
  }
  bool inside(int x, int y, int z) const {
    return x >= lo[0] && y >= lo[1] && z >= lo[2] && x < lo[0] + n[0] && y < lo[1] + n[1] && z < lo[2] + n[2];
  }
};

void fillFromTree(const octomap::OcTree& tree, float occupied_log_odds, KeyBox* box) {
  const octomap::OcTreeKey kmin(box->lo[0], box->lo[1], box->lo[2]);
  const octomap::OcTreeKey kmax(box->lo[0] + box->n[0] - 1, box->lo[1] + box->n[1] - 1,
                                box->lo[2] + box->n[2] - 1);
  const int depth = static_cast<int>(tree.getTreeDepth());
  for (auto it = tree.begin_leafs_bbx(kmin, kmax), end = tree.end_leafs_bbx(); it != end; ++it) {
    const octomap::OcTreeKey k = it.getIndexKey();
    const int span = 1 << (depth - static_cast<int>(it.getDepth()));
    const uint8_t value = it->getLogOdds() > occupied_log_odds ? kOccupied : kFree;
    int a0[3], a1[3];
    for (int a = 0; a < 3; ++a) {
      a0[a] = std::max<int>(k[a], box->lo[a]);
      a1[a] = std::min<int>(k[a] + span, box->lo[a] + box->n[a]);
    }
    for (int x = a0[0]; x < a1[0]; ++x)
      for (int y = a0[1]; y < a1[1]; ++y) {
        uint8_t* row = &box->state[box->index(x, y, a0[2])];
        std::fill(row, row + (a1[2] - a0[2]), value);
      }
  }
}

/// Up along key axis `axis`: the most occupied state over the band's keys [box lo, hi] along it, per
/// (u, v) column of the box, straight from the leaves (no 3-D copy).
std::vector<uint8_t> fillColumns(const octomap::OcTree& tree, float occupied_log_odds, const KeyBox& box,
                                 int axis) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  std::vector<uint8_t> column(static_cast<size_t>(box.n[u]) * box.n[v], kUnknown);
  const octomap::OcTreeKey kmin(box.lo[0], box.lo[1], box.lo[2]);
  const octomap::OcTreeKey kmax(box.lo[0] + box.n[0] - 1, box.lo[1] + box.n[1] - 1, box.lo[2] + box.n[2] - 1);
  const int depth = static_cast<int>(tree.getTreeDepth());
  for (auto it = tree.begin_leafs_bbx(kmin, kmax), end = tree.end_leafs_bbx(); it != end; ++it) {
    const octomap::OcTreeKey k = it.getIndexKey();
    const int span = 1 << (depth - static_cast<int>(it.getDepth()));
    const uint8_t value = it->getLogOdds() > occupied_log_odds ? kOccupied : kFree;
    const int i0 = std::max<int>(k[u], box.lo[u]), i1 = std::min<int>(k[u] + span, box.lo[u] + box.n[u]);
    const int j0 = std::max<int>(k[v], box.lo[v]), j1 = std::min<int>(k[v] + span, box.lo[v] + box.n[v]);
    for (int i = i0; i < i1; ++i) {
      uint8_t* row = &column[static_cast<size_t>(i - box.lo[u]) * box.n[v]];
      for (int j = j0; j < j1; ++j) row[j - box.lo[v]] = std::max(row[j - box.lo[v]], value);
    }
  }
  return column;
}

}  // namespace

std::string SliceConfig::validate() const {
  std::vector<std::string> problems = sliceConfigTable().problems(*this);
  if (!(size_m >= resolution_m && size_m / resolution_m <= msg::kMaxGridSide))
    problems.push_back("size_m must be >= resolution_m and at most kMaxGridSide cells");
  if (!(z_min_m < z_max_m)) problems.push_back("z_min_m must be < z_max_m");
  if (!(up_in_map.allFinite() && up_in_map.norm() > 1e-9))
    problems.push_back("up_in_map must be a finite non-zero vector");
  return joinProblems(problems);
}

Result<msg::OccupancySlice> extractSlice(const octomap::OcTree& tree, const SE3& T_map_cam,
                                         const SliceConfig& config) {
  using R = Result<msg::OccupancySlice>;
  if (const std::string why = config.validate(); !why.empty()) return R::failure("slice config: " + why);
  if (!se3::isValid(T_map_cam, 1e-4)) return R::failure("slice: camera pose is not finite or not a rotation");
  const Vec3 up = config.up_in_map.normalized();
  const int cells = static_cast<int>(std::lround(config.size_m / config.resolution_m));
  const double size = cells * config.resolution_m;
  msg::OccupancySlice slice;
  slice.T_map_grid = gridPose(T_map_cam, up, size);
  slice.resolution_m = static_cast<float>(config.resolution_m);
  slice.width = slice.height = cells;
  slice.z_min_m = static_cast<float>(config.z_min_m);
  slice.z_max_m = static_cast<float>(config.z_max_m);
  slice.cells.assign(static_cast<size_t>(cells) * cells, msg::OccupancySlice::kUnknown);

  const double res = tree.getResolution();
  const int levels = std::max(1, static_cast<int>(std::ceil((config.z_max_m - config.z_min_m) / res - 1e-9)));
  const double dz = (config.z_max_m - config.z_min_m) / levels;
  // Key box of every sample point (the slab's corners bound them), clipped to the tree's key range.
  const double key_offset = 1 << (tree.getTreeDepth() - 1), inv_res = 1.0 / res;
  KeyBox box{};
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 g((corner & 1) ? size : 0.0, (corner & 2) ? size : 0.0,
                 (corner & 4) ? config.z_max_m : config.z_min_m);
    const Vec3 p = slice.T_map_grid * g;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], std::floor(p[a] * inv_res) + key_offset);
      hi[a] = std::max(hi[a], std::floor(p[a] * inv_res) + key_offset);
    }
  }
  const double key_max = 2.0 * key_offset - 1.0;
  for (int a = 0; a < 3; ++a) {
    if (hi[a] < 0 || lo[a] > key_max) return slice;  // entirely outside the tree's range: all unknown
    box.lo[a] = static_cast<int>(std::max(0.0, lo[a]));
    box.n[a] = static_cast<int>(std::min(key_max, hi[a])) - box.lo[a] + 1;
  }
  const Vec3 dx = slice.T_map_grid.linear().col(0) * config.resolution_m;
  const Vec3 dy = slice.T_map_grid.linear().col(1) * config.resolution_m;
  const Vec3 origin = slice.T_map_grid * Vec3(0.5 * config.resolution_m, 0.5 * config.resolution_m, 0.0);
  const auto keyOf = [&](double v) { return static_cast<int>(std::floor(v * inv_res + key_offset)); };
  const auto encode = [](uint8_t best) {
    return best == kOccupied ? msg::OccupancySlice::kOccupied
           : best == kFree   ? msg::OccupancySlice::kFree
                             : msg::OccupancySlice::kUnknown;
  };
  const float occupied_log_odds = octomap::logodds(config.occupied_threshold);
  int axis = -1;  // up along a key axis (the usual case): every column shares the same level keys
  for (int a = 0; a < 3; ++a)
    if (std::abs(up[a]) > 1.0 - 1e-9) axis = a;
  if (axis >= 0) {
    // The band's keys along the axis: those of the sample heights (contiguous, as dz <= resolution).
    int k0 = keyOf(origin[axis] + (config.z_min_m + 0.5 * dz) * up[axis]);
    int k1 = keyOf(origin[axis] + (config.z_min_m + (levels - 0.5) * dz) * up[axis]);
    if (k0 > k1) std::swap(k0, k1);
    k0 = std::max(k0, box.lo[axis]);
    k1 = std::min(k1, box.lo[axis] + box.n[axis] - 1);
    if (k0 > k1) return slice;
    box.lo[axis] = k0;
    box.n[axis] = k1 - k0 + 1;
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const std::vector<uint8_t> column = fillColumns(tree, occupied_log_odds, box, axis);
    for (int row = 0; row < cells; ++row)
      for (int col = 0; col < cells; ++col) {
        const Vec3 c = origin + col * dx + row * dy;
        const int i = keyOf(c[u]) - box.lo[u], j = keyOf(c[v]) - box.lo[v];
        const bool in = i >= 0 && j >= 0 && i < box.n[u] && j < box.n[v];
        slice.cells[static_cast<size_t>(row) * cells + col] =
            encode(in ? column[static_cast<size_t>(i) * box.n[v] + j] : uint8_t{kUnknown});
      }
    return slice;
  }
  if (static_cast<double>(box.n[0]) * box.n[1] * box.n[2] > 256e6)
    return R::failure("slice: band too large for the tree's resolution");
  box.state.assign(static_cast<size_t>(box.n[0]) * box.n[1] * box.n[2], kUnknown);
  fillFromTree(tree, occupied_log_odds, &box);
  for (int row = 0; row < cells; ++row)
    for (int col = 0; col < cells; ++col) {
      const Vec3 c = origin + col * dx + row * dy;
      uint8_t best = kUnknown;
      for (int l = 0; l < levels && best != kOccupied; ++l) {
        const Vec3 p = c + (config.z_min_m + (l + 0.5) * dz) * up;
        const int x = keyOf(p.x()), y = keyOf(p.y()), z = keyOf(p.z());
        if (box.inside(x, y, z)) best = std::max(best, box.state[box.index(x, y, z)]);
      }
      slice.cells[static_cast<size_t>(row) * cells + col] = encode(best);
    }
  return slice;
}

}  // namespace rgbdmap
