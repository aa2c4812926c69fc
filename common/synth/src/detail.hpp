#pragma once
// Internals of the synthetic scene shared by synth_*.cpp (not installed, not part of the API).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap::synth {

/// SplitMix64 finaliser: a well-mixed 64-bit hash. Fully specified, so results are the same everywhere.
inline uint64_t mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// Small deterministic generator (std distributions differ between standard libraries).
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(mix64(seed)) {}
  uint64_t next() { return mix64(state_ += 0x9E3779B97F4A7C15ull); }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  ///< [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int uniformInt(int lo, int hi) { return lo + static_cast<int>(uniform() * (hi - lo + 1)); }  ///< [lo, hi]
  bool chance(double p) { return uniform() < p; }

 private:
  uint64_t state_;
};

/// Standard normal deviate from 12 random bits (inverse-CDF table lookup; fast and deterministic).
float gaussianFromBits(uint32_t bits);

/// Procedural texture families; each surface picks one and a random window into it.
enum Material : int { kWallWarm, kWallCool, kFloor, kCeiling, kWood, kPainted, kBooks, kMaterialCount };

/// One mip level stored in 4x4-texel blocks (64 bytes, one cache line each) so that lookups walking the
/// texture in any direction (floors are seen diagonally) stay cache-friendly.
struct TextureLevel {
  int size = 0;    ///< texels per side, a power of two >= 4
  cv::Mat texels;  ///< 1 x size*size, CV_8UC4 (B, G, R, unused), 64-byte aligned by OpenCV
  /// Byte offset of texel (x, y): blocks in row-major order, texels row-major inside a block.
  int offset(int x, int y) const {
    return 4 * (16 * ((y >> 2) * (size >> 2) + (x >> 2)) + 4 * (y & 3) + (x & 3));
  }
  const uchar* texel(int x, int y) const { return texels.ptr<uchar>() + offset(x, y); }
  uchar* texel(int x, int y) { return texels.ptr<uchar>() + offset(x, y); }
};

/// A square texture with its mip pyramid, addressed in metres (wraps around at its size).
struct MipTexture {
  std::vector<TextureLevel> levels;  ///< level 0 finest
  std::vector<float> inv_texel_m;    ///< texels per metre of each level
  float texel_m = 0.0035f;           ///< size of a level-0 texel

  float extentMetres() const { return texel_m * static_cast<float>(levels.empty() ? 0 : levels[0].size); }
  /// Trilinear colour (BGR, 0..255) at metric coordinates for a pixel footprint of footprint_m metres.
  cv::Vec3f sample(float u_m, float v_m, float footprint_m) const;
};

/// Generates the texture of a material (deterministic in seed).
MipTexture makeMaterialTexture(Material material, uint64_t seed);

/// How one face of a box is painted: texture coordinates (u, v) = face-plane world coordinates + offset.
struct FaceLook {
  int material = kWallWarm;
  float off_u = 0.0f;
  float off_v = 0.0f;
};

/// A box as the renderer sees it. Face index 2 * axis + (0 for the low side, 1 for the high side).
struct RenderBox {
  Vec3 lo = Vec3::Zero();
  Vec3 hi = Vec3::Zero();
  std::array<FaceLook, 6> faces;
};

struct PointLight {
  Vec3 position_world = Vec3::Zero();
  double strength = 1.0;
};

struct SceneData {
  SynthConfig config;
  Trajectory trajectory;
  Eigen::AlignedBox3d room_bounds;
  RenderBox room;  ///< seen from inside
  std::vector<SynthBox> furniture;
  std::vector<RenderBox> boxes;      ///< same order as furniture
  std::vector<MipTexture> textures;  ///< indexed by Material
  std::vector<PointLight> lights;
};

/// In-plane coordinates of a face perpendicular to `axis`: (y, z), (x, z) or (x, y).
inline void faceAxes(int axis, int* axis_u, int* axis_v) {
  *axis_u = axis == 0 ? 1 : 0;
  *axis_v = axis == 2 ? 1 : 2;
}

/// Component-wise 1/d, with zero components replaced by a huge finite value (keeps slab tests NaN-free).
inline Vec3 safeInverse(const Vec3& d) {
  Vec3 inv;
  for (int i = 0; i < 3; ++i) inv[i] = std::abs(d[i]) > 1e-12 ? 1.0 / d[i] : (d[i] < 0 ? -1e12 : 1e12);
  return inv;
}

/// Slab test. If the ray o + t * d enters the box at some t in (0, *t), sets *t and the entered *face.
/// A ray starting inside the box does not hit it.
inline bool enterBox(const RenderBox& b, const Vec3& o, const Vec3& inv_d, double* t, int* face) {
  double t_enter = -std::numeric_limits<double>::infinity();
  double t_exit = std::numeric_limits<double>::infinity();
  int axis = 0;
  for (int i = 0; i < 3; ++i) {
    double t0 = (b.lo[i] - o[i]) * inv_d[i], t1 = (b.hi[i] - o[i]) * inv_d[i];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_enter) {
      t_enter = t0;
      axis = i;
    }
    t_exit = std::min(t_exit, t1);
  }
  if (t_enter > t_exit || t_enter <= 0.0 || t_enter >= *t) return false;
  *t = t_enter;
  *face = 2 * axis + (inv_d[axis] < 0 ? 1 : 0);
  return true;
}

/// Where a ray from inside the room leaves it, and through which face (origin must be inside).
inline double exitRoom(const RenderBox& room, const Vec3& o, const Vec3& inv_d, int* face) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    const bool high = inv_d[i] >= 0;
    const double t = ((high ? room.hi[i] : room.lo[i]) - o[i]) * inv_d[i];
    if (t < best) {
      best = t;
      *face = 2 * i + (high ? 1 : 0);
    }
  }
  return best;
}

/// Unit normal of a face; room faces point into the room, furniture faces out of the box.
inline Vec3 faceNormal(int face, bool room_face) {
  Vec3 n = Vec3::Zero();
  const bool high = face & 1;
  n[face / 2] = (high != room_face) ? 1.0 : -1.0;
  return n;
}

/// Furniture layout and materials of the room (synth_scene.cpp).
void buildRoom(SceneData* scene);

/// Depth sensor model: true metric depth (CV_32F, camera z) and per-pixel grazing flags (CV_8U, 1 =
/// too oblique) to raw CV_16U depth with noise, quantisation and holes (synth_sensor.cpp).
cv::Mat applyDepthSensor(const cv::Mat& depth_true_m, const cv::Mat& grazing, const SynthConfig& config,
                         uint64_t frame_key);
/// Optical blur and pixel noise on a rendered colour image, in place.
void applyImageSensor(cv::Mat* color, const SynthConfig& config, uint64_t frame_key);

/// Key for per-frame noise: different for each (seed, frame).
inline uint64_t frameKey(uint64_t seed, int frame_index) {
  return mix64(mix64(seed) ^ (0xD1B54A32D192ED03ull * static_cast<uint64_t>(frame_index + 1)));
}

}  // namespace rgbdmap::synth
