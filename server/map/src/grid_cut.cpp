// The horizontal cut: the tree's leaves in the slab's bounding box are rasterised once into a dense key grid
// (large free leaves fill many cells at once), then every cell samples its column from that grid.
#include "grid_cut.hpp"

#include <algorithm>
#include <cmath>

#include <octomap/OcTree.h>

namespace rgbdmap::map_detail {
namespace {

enum : uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

int8_t encode(uint8_t best) { return best == kOccupied ? 100 : best == kFree ? 0 : -1; }

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
  octomap::OcTreeKey min() const { return octomap::OcTreeKey(lo[0], lo[1], lo[2]); }
  octomap::OcTreeKey max() const {
    return octomap::OcTreeKey(lo[0] + n[0] - 1, lo[1] + n[1] - 1, lo[2] + n[2] - 1);
  }
};

/// Every leaf in the box: its key range clipped to the box along each axis and its state.
template <typename F>
void forEachLeaf(const octomap::OcTree& tree, float occupied_log_odds, const KeyBox& box, F&& f) {
  const int depth = static_cast<int>(tree.getTreeDepth());
  for (auto it = tree.begin_leafs_bbx(box.min(), box.max()), end = tree.end_leafs_bbx(); it != end; ++it) {
    const octomap::OcTreeKey k = it.getIndexKey();
    const int span = 1 << (depth - static_cast<int>(it.getDepth()));
    int a0[3], a1[3];
    for (int a = 0; a < 3; ++a) {
      a0[a] = std::max<int>(k[a], box.lo[a]);
      a1[a] = std::min<int>(k[a] + span, box.lo[a] + box.n[a]);
    }
    f(a0, a1, it->getLogOdds() > occupied_log_odds ? kOccupied : kFree);
  }
}

void fillFromTree(const octomap::OcTree& tree, float occupied_log_odds, KeyBox* box) {
  forEachLeaf(tree, occupied_log_odds, *box, [box](const int* a0, const int* a1, uint8_t value) {
    for (int x = a0[0]; x < a1[0]; ++x)
      for (int y = a0[1]; y < a1[1]; ++y) {
        uint8_t* row = &box->state[box->index(x, y, a0[2])];
        std::fill(row, row + (a1[2] - a0[2]), value);
      }
  });
}

/// Up along key axis `axis`: the most occupied state over the band's keys along it, per (u, v) column of
/// the box, straight from the leaves (no 3-D copy).
std::vector<uint8_t> fillColumns(const octomap::OcTree& tree, float occupied_log_odds, const KeyBox& box,
                                 int axis) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  std::vector<uint8_t> column(static_cast<size_t>(box.n[u]) * box.n[v], kUnknown);
  forEachLeaf(tree, occupied_log_odds, box, [&](const int* a0, const int* a1, uint8_t value) {
    for (int i = a0[u]; i < a1[u]; ++i) {
      uint8_t* row = &column[static_cast<size_t>(i - box.lo[u]) * box.n[v]];
      for (int j = a0[v]; j < a1[v]; ++j) row[j - box.lo[v]] = std::max(row[j - box.lo[v]], value);
    }
  });
  return column;
}

/// What the cells need of the tree's key space.
struct Sampler {
  double key_offset = 0, inv_res = 0;
  int levels = 1;
  double dz = 0;
  Vec3 origin, dx, dy, up;  ///< cell (0,0)'s centre at the grid's height; steps per column and row
  int key(double v) const { return static_cast<int>(std::floor(v * inv_res + key_offset)); }
};

/// Key box of every sample point (the slab's corners bound them), clipped to the tree's key range; false
/// when the slab is entirely outside it.
bool sampleBox(const GridCut& cut, const Sampler& s, KeyBox* box) {
  const double w = cut.width * cut.resolution_m, h = cut.height * cut.resolution_m;
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 g((corner & 1) ? w : 0.0, (corner & 2) ? h : 0.0, (corner & 4) ? cut.z_max_m : cut.z_min_m);
    const Vec3 p = cut.T_map_grid * g;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], std::floor(p[a] * s.inv_res) + s.key_offset);
      hi[a] = std::max(hi[a], std::floor(p[a] * s.inv_res) + s.key_offset);
    }
  }
  const double key_max = 2.0 * s.key_offset - 1.0;
  for (int a = 0; a < 3; ++a) {
    if (hi[a] < 0 || lo[a] > key_max) return false;
    box->lo[a] = static_cast<int>(std::max(0.0, lo[a]));
    box->n[a] = static_cast<int>(std::min(key_max, hi[a])) - box->lo[a] + 1;
  }
  return true;
}

/// Up along key axis `axis` (the usual case): every column shares the same band keys, one lookup per cell.
void cutAlongAxis(const octomap::OcTree& tree, const GridCut& cut, const Sampler& s, int axis, KeyBox box,
                  float occupied_log_odds, std::vector<int8_t>* cells) {
  int k0 = s.key(s.origin[axis] + (cut.z_min_m + 0.5 * s.dz) * s.up[axis]);
  int k1 = s.key(s.origin[axis] + (cut.z_min_m + (s.levels - 0.5) * s.dz) * s.up[axis]);
  if (k0 > k1) std::swap(k0, k1);
  k0 = std::max(k0, box.lo[axis]);
  k1 = std::min(k1, box.lo[axis] + box.n[axis] - 1);
  if (k0 > k1) return;
  box.lo[axis] = k0;
  box.n[axis] = k1 - k0 + 1;
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const std::vector<uint8_t> column = fillColumns(tree, occupied_log_odds, box, axis);
  for (int row = 0; row < cut.height; ++row)
    for (int col = 0; col < cut.width; ++col) {
      const Vec3 c = s.origin + col * s.dx + row * s.dy;
      const int i = s.key(c[u]) - box.lo[u], j = s.key(c[v]) - box.lo[v];
      const bool in = i >= 0 && j >= 0 && i < box.n[u] && j < box.n[v];
      (*cells)[static_cast<size_t>(row) * cut.width + col] =
          encode(in ? column[static_cast<size_t>(i) * box.n[v] + j] : uint8_t{kUnknown});
    }
}

/// Any other up: a dense 3-D copy of the box, every sample looked up.
bool cutTilted(const octomap::OcTree& tree, const GridCut& cut, const Sampler& s, KeyBox box,
               float occupied_log_odds, std::vector<int8_t>* cells) {
  if (static_cast<double>(box.n[0]) * box.n[1] * box.n[2] > 256e6) return false;
  box.state.assign(static_cast<size_t>(box.n[0]) * box.n[1] * box.n[2], kUnknown);
  fillFromTree(tree, occupied_log_odds, &box);
  for (int row = 0; row < cut.height; ++row)
    for (int col = 0; col < cut.width; ++col) {
      const Vec3 c = s.origin + col * s.dx + row * s.dy;
      uint8_t best = kUnknown;
      for (int l = 0; l < s.levels && best != kOccupied; ++l) {
        const Vec3 p = c + (cut.z_min_m + (l + 0.5) * s.dz) * s.up;
        const int x = s.key(p.x()), y = s.key(p.y()), z = s.key(p.z());
        if (box.inside(x, y, z)) best = std::max(best, box.state[box.index(x, y, z)]);
      }
      (*cells)[static_cast<size_t>(row) * cut.width + col] = encode(best);
    }
  return true;
}

}  // namespace

Mat3 gridAxes(const Vec3& up) {
  Vec3 x = Vec3::UnitX() - up.x() * up;
  if (x.norm() < 1e-6) x = Vec3::UnitY() - up.y() * up;
  x.normalize();
  Mat3 R;
  R << x, up.cross(x), up;
  return R;
}

std::vector<int8_t> cutGrid(const octomap::OcTree& tree, const GridCut& cut, const char** error) {
  std::vector<int8_t> cells(static_cast<size_t>(cut.width) * cut.height, -1);
  const double res = tree.getResolution();
  Sampler s;
  s.key_offset = 1 << (tree.getTreeDepth() - 1);
  s.inv_res = 1.0 / res;
  s.levels = std::max(1, static_cast<int>(std::ceil((cut.z_max_m - cut.z_min_m) / res - 1e-9)));
  s.dz = (cut.z_max_m - cut.z_min_m) / s.levels;
  s.up = cut.T_map_grid.linear().col(2);
  s.dx = cut.T_map_grid.linear().col(0) * cut.resolution_m;
  s.dy = cut.T_map_grid.linear().col(1) * cut.resolution_m;
  s.origin = cut.T_map_grid * Vec3(0.5 * cut.resolution_m, 0.5 * cut.resolution_m, 0.0);
  KeyBox box{};
  if (!sampleBox(cut, s, &box)) return cells;  // entirely outside the tree's range: all unknown
  const float occupied_log_odds = octomap::logodds(cut.occupied_threshold);
  for (int a = 0; a < 3; ++a)
    if (std::abs(s.up[a]) > 1.0 - 1e-9) {
      cutAlongAxis(tree, cut, s, a, box, occupied_log_odds, &cells);
      return cells;
    }
  if (!cutTilted(tree, cut, s, box, occupied_log_odds, &cells)) {
    *error = "band too large for the tree's resolution";
    return {};
  }
  return cells;
}

}  // namespace rgbdmap::map_detail
