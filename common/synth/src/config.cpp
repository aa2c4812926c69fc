// SynthConfig::validate: every value's range, all reasons at once.
#include <cmath>
#include <sstream>

#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap {
namespace {

bool inRange(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

void checkDepthNoise(const SynthDepthNoise& n, double depth_scale, std::ostringstream* err) {
  if (!inRange(n.min_range_m, 0.0, 10.0)) *err << "depth_noise.min_range_m must be in [0, 10]; ";
  if (!inRange(n.max_range_m, n.min_range_m, 65535.0 / depth_scale))
    *err << "depth_noise.max_range_m must be in [min_range_m, 65535 / depth_scale]; ";
  if (!inRange(n.sigma_base_m, 0.0, 1.0) || !inRange(n.sigma_quad, 0.0, 1.0))
    *err << "depth_noise sigma_base_m and sigma_quad must be in [0, 1]; ";
  if (!inRange(n.baseline_m, 1e-3, 1.0)) *err << "depth_noise.baseline_m must be in [0.001, 1]; ";
  if (!inRange(n.disparity_step_px, 0.0, 1.0)) *err << "depth_noise.disparity_step_px must be in [0, 1]; ";
  if (!inRange(n.grazing_max_deg, 1.0, 90.0)) *err << "depth_noise.grazing_max_deg must be in [1, 90]; ";
  if (!inRange(n.edge_jump_m, 0.0, 10.0) || !inRange(n.edge_jump_rel, 0.0, 10.0))
    *err << "depth_noise edge_jump_m and edge_jump_rel must be in [0, 10]; ";
  if (!inRange(n.dropout_probability, 0.0, 1.0))
    *err << "depth_noise.dropout_probability must be in [0, 1]; ";
}

}  // namespace

std::string SynthConfig::validate() const {
  std::ostringstream err;
  if (scene != "loop" && scene != "sweep") err << "scene must be 'loop' or 'sweep', not '" << scene << "'; ";
  if (frames < 2 || frames > 100000) err << "frames must be in [2, 100000]; ";
  if (!inRange(fps, 0.1, 1000.0)) err << "fps must be in [0.1, 1000]; ";
  if (!inRange(t0, 0.0, 1e10)) err << "t0 must be in [0, 1e10]; ";
  if (!std::isfinite(depth_time_offset_s) || std::abs(depth_time_offset_s) >= 0.5 / fps)
    err << "depth_time_offset_s must be finite and smaller than half a frame period; ";
  const std::string camera_error = camera.validate();
  if (!camera_error.empty()) err << "camera: " << camera_error;
  if (camera.hasDistortion()) err << "camera: the renderer is an ideal pinhole, distortion must be zero; ";
  if (camera.readout_s != 0.0) err << "camera: the renderer has a global shutter, readout_s must be 0; ";
  if (camera.width > 4096 || camera.height > 4096) err << "camera: image size must be at most 4096x4096; ";
  checkDepthNoise(depth_noise, camera.depth_scale, &err);
  if (!inRange(image_noise.blur_sigma_px, 0.0, 5.0)) err << "image_noise.blur_sigma_px must be in [0, 5]; ";
  if (!inRange(image_noise.sigma, 0.0, 50.0)) err << "image_noise.sigma must be in [0, 50]; ";
  std::string out = err.str();
  if (out.size() >= 2) out.resize(out.size() - 2);  // drop the trailing "; "
  return out;
}

}  // namespace rgbdmap
