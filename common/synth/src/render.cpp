// Ray-cast rendering through an ideal pinhole: exact depth, trilinear-textured Lambertian colour.
// Speed: boxes are culled per frame and per 16x16 tile against the tile's frustum, so each ray is tested
// against the room and the few boxes its tile can see; tile rows are rendered in parallel.
#include <cmath>

#include <opencv2/core/utility.hpp>

#include "detail.hpp"

namespace rgbdmap::synth {
namespace {

constexpr int kTile = 16;

/// Renders one frame's geometry: colour before sensor effects, true depth, grazing flags.
class FrameRenderer {
 public:
  FrameRenderer(const SceneData& scene, const SE3& T_world_cam);
  void renderTileRow(int tile_row, cv::Mat* color, cv::Mat* depth_m, cv::Mat* grazing) const;

 private:
  /// World-frame ray through image point (x, y) (pixel units), scaled so that its camera z is 1.
  Vec3 ray(double x, double y) const {
    return R_.col(2) + ((x - k_.cx) / k_.fx) * R_.col(0) + ((y - k_.cy) / k_.fy) * R_.col(1);
  }
  /// Boxes among `from` that may be seen through the pixel rectangle [x0, x1] x [y0, y1].
  void cull(const std::vector<int>& from, double x0, double y0, double x1, double y1,
            std::vector<int>* out) const;
  cv::Vec3b shade(const Vec3& d, double t, int face, int box, float* cos_incidence) const;

  const SceneData& s_;
  const CameraIntrinsics& k_;
  Mat3 R_;
  Vec3 o_;
  float cos_grazing_;
  std::vector<int> visible_;
  std::vector<double> x_norm_, y_norm_;  ///< normalised image coordinates of pixel columns and rows
};

FrameRenderer::FrameRenderer(const SceneData& scene, const SE3& T_world_cam)
    : s_(scene),
      k_(scene.config.camera),
      R_(T_world_cam.linear()),
      o_(T_world_cam.translation()),
      cos_grazing_(static_cast<float>(std::cos(scene.config.depth_noise.grazing_max_deg * CV_PI / 180.0))) {
  for (int x = 0; x < k_.width; ++x) x_norm_.push_back((x - k_.cx) / k_.fx);
  for (int y = 0; y < k_.height; ++y) y_norm_.push_back((y - k_.cy) / k_.fy);
  std::vector<int> all(s_.boxes.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  cull(all, -0.5, -0.5, k_.width - 0.5, k_.height - 0.5, &visible_);
}

void FrameRenderer::cull(const std::vector<int>& from, double x0, double y0, double x1, double y1,
                         std::vector<int>* out) const {
  const Vec3 corners[4] = {ray(x0, y0), ray(x1, y0), ray(x1, y1), ray(x0, y1)};
  const Vec3 centre = ray(0.5 * (x0 + x1), 0.5 * (y0 + y1));
  Vec3 normals[4];
  for (int k = 0; k < 4; ++k) {  // side planes through the camera centre, normals pointing inside
    normals[k] = corners[k].cross(corners[(k + 1) % 4]);
    if (normals[k].dot(centre) < 0) normals[k] = -normals[k];
  }
  out->clear();
  for (int b : from) {
    const RenderBox& box = s_.boxes[static_cast<size_t>(b)];
    bool outside = false;
    for (int k = 0; k < 4 && !outside; ++k) {  // the box corner farthest along the normal decides
      const Vec3& n = normals[k];
      const Vec3 p(n.x() >= 0 ? box.hi.x() : box.lo.x(), n.y() >= 0 ? box.hi.y() : box.lo.y(),
                   n.z() >= 0 ? box.hi.z() : box.lo.z());
      outside = n.dot(p - o_) < 0;
    }
    if (!outside) out->push_back(b);
  }
}

cv::Vec3b FrameRenderer::shade(const Vec3& d, double t, int face, int box, float* cos_incidence) const {
  const bool room_face = box < 0;
  const RenderBox& rb = room_face ? s_.room : s_.boxes[static_cast<size_t>(box)];
  const FaceLook& look = rb.faces[static_cast<size_t>(face)];
  const int axis = face / 2;
  const float n_sign = static_cast<float>(faceNormal(face, room_face)[axis]);  // the normal is +-e_axis
  const Vec3 p = o_ + t * d;
  *cos_incidence = static_cast<float>(std::abs(d[axis]) / d.norm());
  int au = 0, av = 0;
  faceAxes(axis, &au, &av);
  // Footprint of the pixel on the surface: z / f across the ray, stretched by the slant (geometric mean).
  const float footprint = static_cast<float>(t / k_.fx) / std::sqrt(std::max(*cos_incidence, 0.05f));
  const cv::Vec3f albedo = s_.textures[static_cast<size_t>(look.material)].sample(
      static_cast<float>(p[au]) + look.off_u, static_cast<float>(p[av]) + look.off_v, footprint);
  // Lambertian: ambient (a little brighter on upward faces) plus point lights with soft falloff.
  float light = 0.42f + (axis == 2 ? 0.08f * n_sign : 0.0f);
  for (const PointLight& l : s_.lights) {
    const Eigen::Vector3f to_light = (l.position_world - p).cast<float>();
    const float facing = n_sign * to_light[axis];
    if (facing <= 0.0f) continue;
    const float dist2 = to_light.squaredNorm();
    light +=
        static_cast<float>(0.6 * l.strength) * facing / (std::sqrt(dist2) * (1.0f + dist2 * (1.0f / 9.0f)));
  }
  return {cv::saturate_cast<uchar>(albedo[0] * light), cv::saturate_cast<uchar>(albedo[1] * light),
          cv::saturate_cast<uchar>(albedo[2] * light)};
}

void FrameRenderer::renderTileRow(int tile_row, cv::Mat* color, cv::Mat* depth_m, cv::Mat* grazing) const {
  const int y_begin = tile_row * kTile, y_end = std::min(y_begin + kTile, k_.height);
  const int tile_cols = (k_.width + kTile - 1) / kTile;
  std::vector<std::vector<int>> candidates(static_cast<size_t>(tile_cols));
  for (int tc = 0; tc < tile_cols; ++tc) {
    const int x_begin = tc * kTile, x_end = std::min(x_begin + kTile, k_.width);
    cull(visible_, x_begin - 0.5, y_begin - 0.5, x_end - 0.5, y_end - 0.5,
         &candidates[static_cast<size_t>(tc)]);
  }
  for (int y = y_begin; y < y_end; ++y) {  // whole image rows: sequential texture access
    const Vec3 row_ray = R_.col(2) + y_norm_[static_cast<size_t>(y)] * R_.col(1);
    auto* c_row = color->ptr<cv::Vec3b>(y);
    float* z_row = depth_m->ptr<float>(y);
    uchar* g_row = grazing->ptr<uchar>(y);
    for (int x = 0; x < k_.width; ++x) {
      const Vec3 d = row_ray + x_norm_[static_cast<size_t>(x)] * R_.col(0);
      const Vec3 inv_d = safeInverse(d);
      int face = 0, box = -1;
      double t = exitRoom(s_.room, o_, inv_d, &face);
      for (int b : candidates[static_cast<size_t>(x / kTile)])
        if (enterBox(s_.boxes[static_cast<size_t>(b)], o_, inv_d, &t, &face)) box = b;
      if (!(t > 0.0) || !std::isfinite(t)) {  // camera on the room boundary: nothing to see
        c_row[x] = cv::Vec3b(0, 0, 0);
        z_row[x] = 0.0f;
        g_row[x] = 1;
        continue;
      }
      float cos_incidence = 1.0f;
      c_row[x] = shade(d, t, face, box, &cos_incidence);
      z_row[x] = static_cast<float>(t);  // the ray's camera z is 1, so t is the depth
      g_row[x] = cos_incidence < cos_grazing_ ? 1 : 0;
    }
  }
}

}  // namespace
}  // namespace rgbdmap::synth

namespace rgbdmap {

RgbdFrame SyntheticScene::render(const SE3& T_world_cam, int frame_index) const {
  const SynthConfig& cfg = data_->config;
  const CameraIntrinsics& k = cfg.camera;
  cv::Mat color(k.height, k.width, CV_8UC3), depth_m(k.height, k.width, CV_32F),
      grazing(k.height, k.width, CV_8U);
  if (data_->room_bounds.contains(T_world_cam.translation())) {
    const synth::FrameRenderer renderer(*data_, T_world_cam);
    const int tile_rows = (k.height + synth::kTile - 1) / synth::kTile;
    cv::parallel_for_(cv::Range(0, tile_rows), [&](const cv::Range& r) {
      for (int row = r.start; row < r.end; ++row) renderer.renderTileRow(row, &color, &depth_m, &grazing);
    });
  } else {  // outside the room there is nothing to see
    color.setTo(cv::Scalar::all(0));
    depth_m.setTo(cv::Scalar::all(0));
    grazing.setTo(cv::Scalar::all(1));
  }
  const uint64_t key = synth::frameKey(cfg.seed, frame_index);
  RgbdFrame frame;
  frame.timestamp = cfg.colorTimestamp(frame_index);
  frame.depth_scale = k.depth_scale;
  synth::applyImageSensor(&color, cfg, key);
  frame.color = color;
  frame.depth = synth::applyDepthSensor(depth_m, grazing, cfg, key);
  return frame;
}

}  // namespace rgbdmap
