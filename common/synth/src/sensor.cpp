// Sensor models applied to a rendered frame: Kinect-like depth (range limits, grazing-angle and edge
// holes, random dropout, axial noise growing with range, disparity quantisation) and colour (optical blur,
// Gaussian pixel noise). Noise comes from a hash of (seed, frame, pixel): deterministic and thread-safe.
#include <array>
#include <cmath>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "detail.hpp"

namespace rgbdmap::synth {
namespace {

/// Inverse of the standard normal CDF by bisection (used once to fill the lookup table).
double inverseNormalCdf(double p) {
  double lo = -10.0, hi = 10.0;
  for (int i = 0; i < 80; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

uint64_t pixelHash(uint64_t key, int x, int y, int width) {
  return mix64(key ^ (0x9E3779B97F4A7C15ull * static_cast<uint64_t>(y * width + x + 1)));
}

/// The four true-depth rows around row y at distances 1 and 2 (nullptr outside the image).
struct Neighbourhood {
  const float* up[3] = {nullptr, nullptr, nullptr};
  const float* down[3] = {nullptr, nullptr, nullptr};
  const float* row = nullptr;
  int cols = 0;
  Neighbourhood(const cv::Mat& z, int y) : row(z.ptr<float>(y)), cols(z.cols) {
    for (int dist = 1; dist <= 2; ++dist) {
      if (y - dist >= 0) up[dist] = z.ptr<float>(y - dist);
      if (y + dist < z.rows) down[dist] = z.ptr<float>(y + dist);
    }
  }
  /// True if a 4-neighbour `dist` pixels from x is valid and nearer than `limit`.
  bool nearerAt(int x, int dist, float limit) const {
    auto nearer = [limit](float zn) { return zn > 0.0f && zn < limit; };
    return (x - dist >= 0 && nearer(row[x - dist])) || (x + dist < cols && nearer(row[x + dist])) ||
           (up[dist] && nearer(up[dist][x])) || (down[dist] && nearer(down[dist][x]));
  }
};

/// Noisy depth in metres of one pixel, or 0 when the sensor would return nothing. Depth edges: a pixel
/// with a neighbour nearer by more than the jump threshold is on the far side of an edge and gets no
/// depth; one two pixels away removes it when the coin (a hash bit) says so.
double sensePixel(const Neighbourhood& nb, int x, bool grazing, const SynthConfig& cfg, uint64_t hash) {
  const SynthDepthNoise& n = cfg.depth_noise;
  const float zf = nb.row[x];
  const double z = zf;
  if (!(z > 0.0)) return 0.0;
  if (!n.enabled) return z;
  if (z < n.min_range_m || z > n.max_range_m || grazing) return 0.0;
  const float limit = zf - static_cast<float>(n.edge_jump_m + n.edge_jump_rel * z);
  if (nb.nearerAt(x, 1, limit) || ((hash & 1) && nb.nearerAt(x, 2, limit))) return 0.0;
  if (static_cast<double>((hash >> 1) & 0xFFFFF) * 0x1.0p-20 < n.dropout_probability) return 0.0;
  const double sigma = n.sigma_base_m + n.sigma_quad * (z - n.min_range_m) * (z - n.min_range_m);
  double z_noisy = z + sigma * gaussianFromBits(static_cast<uint32_t>(hash >> 40));
  if (n.disparity_step_px > 0.0) {
    if (!(z_noisy > 0.0)) return 0.0;
    const double bf_in_steps = n.baseline_m * cfg.camera.fx / n.disparity_step_px;  // z * disparity / step
    const double steps = static_cast<double>(static_cast<int64_t>(bf_in_steps / z_noisy + 0.5));
    if (!(steps > 0.0)) return 0.0;
    z_noisy = bf_in_steps / steps;
  }
  return z_noisy;
}

}  // namespace

float gaussianFromBits(uint32_t bits) {
  static const std::array<float, 4096> kTable = [] {
    std::array<float, 4096> t{};
    for (size_t i = 0; i < t.size(); ++i) t[i] = static_cast<float>(inverseNormalCdf((i + 0.5) / t.size()));
    return t;
  }();
  return kTable[bits & 4095u];
}

cv::Mat applyDepthSensor(const cv::Mat& depth_true_m, const cv::Mat& grazing, const SynthConfig& cfg,
                         uint64_t frame_key) {
  cv::Mat raw(depth_true_m.size(), CV_16UC1);
  const double scale = cfg.camera.depth_scale;
  const uint64_t key = mix64(frame_key ^ 0x2545F4914F6CDD1Dull);
  cv::parallel_for_(cv::Range(0, raw.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const Neighbourhood nb(depth_true_m, y);
      const uchar* grazing_row = grazing.ptr<uchar>(y);
      auto* out = raw.ptr<uint16_t>(y);
      for (int x = 0; x < raw.cols; ++x) {
        const double z = sensePixel(nb, x, grazing_row[x] != 0, cfg, pixelHash(key, x, y, raw.cols));
        const double value = z * scale + 0.5;  // z >= 0: rounds to nearest
        out[x] = (value >= 1.0 && value < 65536.0) ? static_cast<uint16_t>(value) : 0;
      }
    }
  });
  return raw;
}

void applyImageSensor(cv::Mat* color, const SynthConfig& cfg, uint64_t frame_key) {
  const SynthImageNoise& n = cfg.image_noise;
  if (n.blur_sigma_px > 0.0) cv::GaussianBlur(*color, *color, cv::Size(0, 0), n.blur_sigma_px);
  if (!(n.sigma > 0.0)) return;
  const uint64_t key = mix64(frame_key ^ 0x6A09E667F3BCC909ull);
  const float sigma = static_cast<float>(n.sigma);
  cv::parallel_for_(cv::Range(0, color->rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      auto* p = color->ptr<cv::Vec3b>(y);
      for (int x = 0; x < color->cols; ++x) {
        const uint64_t h = pixelHash(key, x, y, color->cols);
        for (int c = 0; c < 3; ++c) {
          const float noise = sigma * gaussianFromBits(static_cast<uint32_t>(h >> (12 * c)));
          p[x][c] = cv::saturate_cast<uchar>(p[x][c] + noise);
        }
      }
    }
  });
}

}  // namespace rgbdmap::synth
