// The room and its furniture: a 6 x 5 x 2.8 m room centred on the origin, furniture along the walls
// (cabinets, shelves with books, desks, crates) placed from the seed, the centre kept free for the camera.
#include <algorithm>

#include "detail.hpp"

namespace rgbdmap::synth {
namespace {

constexpr double kRoomHalfX = 3.0, kRoomHalfY = 2.5, kRoomHeight = 2.8;
constexpr double kMaxDepth = 0.6;  ///< furniture depth from its wall; keeps the room centre free

/// A wall seen from inside: furniture is placed at along-wall coordinate s, distance d from the wall.
struct Wall {
  int along_axis;       ///< world axis along the wall (0 = x, 1 = y)
  double wall_coord;    ///< world coordinate of the wall on the other horizontal axis
  double inward;        ///< +1 or -1: direction into the room
  double s_min, s_max;  ///< usable span (corners are left to the perpendicular walls)
};

class Placer {
 public:
  Placer(SceneData* scene, Rng* rng) : scene_(scene), rng_(rng) {}

  void furnishWall(const Wall& wall);

 private:
  /// Adds a box given in wall coordinates [s0, s1] x [d0, d1] x [z0, z1].
  void add(const Wall& w, double s0, double s1, double d0, double d1, double z0, double z1, Material m,
           const char* kind);
  void cabinet(const Wall& w, double s0, double width);
  void shelf(const Wall& w, double s0, double width);
  void desk(const Wall& w, double s0, double width);
  void crate(const Wall& w, double s0, double width);
  void objectsOn(const Wall& w, double s0, double s1, double depth, double z, double max_height);

  SceneData* scene_;
  Rng* rng_;
};

/// A texture window chosen at random inside the material texture, so that faces do not repeat each other.
FaceLook makeFaceLook(const Vec3& lo, const Vec3& hi, int face, Material m,
                      const std::vector<MipTexture>& textures, Rng* rng) {
  int au = 0, av = 0;
  faceAxes(face / 2, &au, &av);
  const double extent = textures[static_cast<size_t>(m)].extentMetres();
  const double free_u = std::max(0.0, extent - (hi[au] - lo[au]));
  const double free_v = std::max(0.0, extent - (hi[av] - lo[av]));
  FaceLook look;
  look.material = m;
  look.off_u = static_cast<float>(-lo[au] + rng->uniform(0.0, free_u));
  look.off_v = static_cast<float>(-lo[av] + rng->uniform(0.0, free_v));
  return look;
}

RenderBox makeRenderBox(const Eigen::AlignedBox3d& bounds, const std::array<Material, 6>& materials,
                        const std::vector<MipTexture>& textures, Rng* rng) {
  RenderBox b;
  b.lo = bounds.min();
  b.hi = bounds.max();
  for (int face = 0; face < 6; ++face) {
    const size_t f = static_cast<size_t>(face);
    b.faces[f] = makeFaceLook(b.lo, b.hi, face, materials[f], textures, rng);
  }
  return b;
}

void Placer::add(const Wall& w, double s0, double s1, double d0, double d1, double z0, double z1, Material m,
                 const char* kind) {
  Vec3 a, b;
  const int across = 1 - w.along_axis;
  a[w.along_axis] = s0;
  b[w.along_axis] = s1;
  a[across] = w.wall_coord + w.inward * d0;
  b[across] = w.wall_coord + w.inward * d1;
  a.z() = z0;
  b.z() = z1;
  const Eigen::AlignedBox3d bounds(a.cwiseMin(b), a.cwiseMax(b));
  scene_->furniture.push_back({bounds, kind});
  scene_->boxes.push_back(makeRenderBox(bounds, {m, m, m, m, m, m}, scene_->textures, rng_));
}

void Placer::objectsOn(const Wall& w, double s0, double s1, double depth, double z, double max_height) {
  for (double s = s0 + rng_->uniform(0.02, 0.15); s < s1 - 0.12;) {
    const double width = std::min(rng_->uniform(0.1, 0.4), s1 - s);
    const double d0 = rng_->uniform(0.02, 0.3 * depth), d1 = std::min(depth, d0 + rng_->uniform(0.1, 0.35));
    const Material m = rng_->chance(0.5) ? kPainted : kBooks;
    add(w, s, s + width, d0, d1, z, z + rng_->uniform(0.06, max_height), m, "object");
    s += width + rng_->uniform(0.05, 0.5);
  }
}

void Placer::cabinet(const Wall& w, double s0, double width) {
  const double depth = rng_->uniform(0.4, kMaxDepth), height = rng_->uniform(0.7, 1.1);
  add(w, s0, s0 + width, 0.0, depth, 0.0, height, rng_->chance(0.5) ? kPainted : kWood, "cabinet");
  objectsOn(w, s0, s0 + width, depth, height, 0.4);
}

void Placer::shelf(const Wall& w, double s0, double width) {
  const double depth = rng_->uniform(0.3, 0.4), height = rng_->uniform(1.6, 2.2), board = 0.025;
  const double s1 = s0 + width;
  add(w, s0, s1, 0.0, 0.02, 0.0, height, kWood, "shelf");           // back panel
  add(w, s0, s0 + board, 0.0, depth, 0.0, height, kWood, "shelf");  // sides
  add(w, s1 - board, s1, 0.0, depth, 0.0, height, kWood, "shelf");
  const int levels = std::max(2, static_cast<int>(height / 0.4));
  const double pitch = (height - board) / levels;
  for (int k = 0; k <= levels; ++k) {
    const double z = k * pitch;
    add(w, s0 + board, s1 - board, 0.02, depth, z, z + board, kWood, "shelf");
    if (k == levels) break;
    for (double s = s0 + board + rng_->uniform(0.0, 0.1); s < s1 - board - 0.08;) {  // rows of books
      const double books = std::min(rng_->uniform(0.1, 0.45), s1 - board - s);
      const double top = z + board + rng_->uniform(0.55, 0.9) * (pitch - board);
      add(w, s, s + books, 0.03, depth - rng_->uniform(0.0, 0.08), z + board, top, kBooks, "book");
      s += books + rng_->uniform(0.02, 0.3);
    }
  }
}

void Placer::desk(const Wall& w, double s0, double width) {
  const double depth = rng_->uniform(0.5, kMaxDepth), height = rng_->uniform(0.72, 0.76), leg = 0.05;
  const double s1 = s0 + width;
  add(w, s0, s1, 0.0, depth, height - 0.03, height, kWood, "desk");
  for (double s : {s0, s1 - leg})
    for (double d : {0.0, depth - leg}) add(w, s, s + leg, d, d + leg, 0.0, height - 0.03, kPainted, "desk");
  objectsOn(w, s0, s1, depth, height, 0.45);
}

void Placer::crate(const Wall& w, double s0, double width) {
  const double depth = rng_->uniform(0.3, 0.5), height = rng_->uniform(0.3, 0.6);
  add(w, s0, s0 + width, rng_->uniform(0.0, 0.05), depth, 0.0, height, kPainted, "crate");
}

void Placer::furnishWall(const Wall& wall) {
  double s = wall.s_min + rng_->uniform(0.0, 0.4);
  while (true) {
    const int type = rng_->uniformInt(0, 3);
    const double width = type == 0   ? rng_->uniform(0.5, 1.2)   // cabinet
                         : type == 1 ? rng_->uniform(0.6, 1.2)   // shelf
                         : type == 2 ? rng_->uniform(1.0, 1.6)   // desk
                                     : rng_->uniform(0.3, 0.6);  // crate
    if (s + width > wall.s_max) break;
    if (type == 0) cabinet(wall, s, width);
    if (type == 1) shelf(wall, s, width);
    if (type == 2) desk(wall, s, width);
    if (type == 3) crate(wall, s, width);
    s += width + rng_->uniform(0.05, 0.6);
  }
}

}  // namespace

void buildRoom(SceneData* scene) {
  Rng rng(mix64(scene->config.seed) ^ 0x7A3C5E1F9B2D4680ull);
  scene->room_bounds =
      Eigen::AlignedBox3d(Vec3(-kRoomHalfX, -kRoomHalfY, 0.0), Vec3(kRoomHalfX, kRoomHalfY, kRoomHeight));
  // Walls alternate between two materials; floor and ceiling have their own (faces: 2 * axis + high).
  scene->room =
      makeRenderBox(scene->room_bounds, {kWallWarm, kWallCool, kWallCool, kWallWarm, kFloor, kCeiling},
                    scene->textures, &rng);
  const double corner = kMaxDepth + 0.1;
  const Wall walls[4] = {{0, -kRoomHalfY, +1.0, -kRoomHalfX + 0.05, kRoomHalfX - 0.05},
                         {0, +kRoomHalfY, -1.0, -kRoomHalfX + 0.05, kRoomHalfX - 0.05},
                         {1, -kRoomHalfX, +1.0, -kRoomHalfY + corner, kRoomHalfY - corner},
                         {1, +kRoomHalfX, -1.0, -kRoomHalfY + corner, kRoomHalfY - corner}};
  Placer placer(scene, &rng);
  for (const Wall& w : walls) placer.furnishWall(w);
  const double lx = 0.5 * kRoomHalfX, lz = kRoomHeight - 0.2;
  scene->lights = {{Vec3(-lx, 0.0, lz), 1.0}, {Vec3(lx, 0.0, lz), 1.0}};
}

}  // namespace rgbdmap::synth
