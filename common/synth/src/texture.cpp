// Procedural material textures: Mondrian-like rectangles at three scales, blobs, lines, planks or book
// spines, multi-scale value noise; a mip pyramid for anti-aliased (trilinear) sampling in metres.
#include <algorithm>
#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

#include "detail.hpp"

namespace rgbdmap::synth {
namespace {

struct TextureStyle {
  int size = 1024;  ///< texels, power of two
  float texel_m = 0.0025f;
  cv::Scalar base;                  ///< BGR
  std::vector<cv::Scalar> palette;  ///< BGR
  int strips = 0;                   ///< 0 none, 1 horizontal bands (planks), 2 vertical bands (book spines)
  double strip_min_m = 0.0, strip_max_m = 0.0;
  double grid_m = 0.0;                  ///< ceiling-tile grid pitch, 0 = none
  std::array<double, 3> rect_size_m{};  ///< large, medium, small rectangles
  std::array<double, 3> rects_per_m2{};
  double blobs_per_m2 = 0.0;
  double lines_per_m2 = 0.0;
  double noise_amplitude = 0.25;  ///< multiplicative value noise
  double grain_aspect = 1.0;      ///< > 1 stretches the noise along u (wood grain)
};

const std::vector<cv::Scalar> kPosterColors = {{40, 40, 200},  {200, 80, 30}, {40, 170, 60},
                                               {30, 200, 230}, {40, 40, 40},  {230, 230, 230},
                                               {150, 60, 150}, {20, 110, 220}};
const std::vector<cv::Scalar> kCoolColors = {{120, 60, 20}, {60, 140, 200},  {90, 90, 90},  {200, 200, 60},
                                             {30, 30, 110}, {250, 250, 250}, {80, 160, 90}, {170, 120, 200}};
const std::vector<cv::Scalar> kWoodColors = {{40, 80, 130}, {60, 110, 160}, {30, 60, 100}, {80, 140, 190}};
const std::vector<cv::Scalar> kGreyColors = {{160, 160, 160}, {110, 110, 110}, {200, 200, 200}, {60, 60, 60}};

/// Base style: a size, a background, a palette and rectangles (size and count per m^2) at three scales.
TextureStyle style(int size, float texel_m, const cv::Scalar& base, const std::vector<cv::Scalar>& palette,
                   const std::array<double, 3>& rect_size_m, const std::array<double, 3>& rects_per_m2) {
  TextureStyle s;
  s.size = size;
  s.texel_m = texel_m;
  s.base = base;
  s.palette = palette;
  s.rect_size_m = rect_size_m;
  s.rects_per_m2 = rects_per_m2;
  return s;
}

TextureStyle styleOf(Material m) {
  TextureStyle s;
  switch (m) {
    case kWallWarm:  // plaster with posters, notes and marks
      s = style(2048, 0.0035f, {185, 205, 220}, kPosterColors, {0.7, 0.18, 0.05}, {0.4, 5.0, 40.0});
      s.blobs_per_m2 = 4.0;
      s.lines_per_m2 = 3.0;
      break;
    case kWallCool:
      s = style(2048, 0.0035f, {210, 200, 180}, kCoolColors, {0.5, 0.15, 0.04}, {0.6, 6.0, 45.0});
      s.blobs_per_m2 = 6.0;
      s.lines_per_m2 = 2.0;
      break;
    case kFloor:  // wooden planks with rugs, papers and stains
      s = style(2048, 0.0035f, {70, 110, 150}, kWoodColors, {0.8, 0.25, 0.05}, {0.15, 1.5, 20.0});
      s.strips = 1;
      s.strip_min_m = 0.12;
      s.strip_max_m = 0.20;
      s.blobs_per_m2 = 6.0;
      s.lines_per_m2 = 2.0;
      s.grain_aspect = 8.0;
      break;
    case kCeiling:  // tiles in a 0.6 m grid
      s = style(1024, 0.007f, {215, 220, 220}, kGreyColors, {0.6, 0.12, 0.05}, {0.2, 3.0, 15.0});
      s.grid_m = 0.6;
      s.blobs_per_m2 = 3.0;
      s.noise_amplitude = 0.2;
      break;
    case kWood:
      s = style(1024, 0.0025f, {60, 100, 140}, kWoodColors, {0.3, 0.08, 0.025}, {1.0, 12.0, 60.0});
      s.blobs_per_m2 = 10.0;
      s.lines_per_m2 = 8.0;
      s.grain_aspect = 6.0;
      s.noise_amplitude = 0.3;
      break;
    case kPainted:
      s = style(1024, 0.0025f, {150, 170, 120}, kCoolColors, {0.3, 0.08, 0.025}, {1.5, 15.0, 70.0});
      s.blobs_per_m2 = 12.0;
      s.lines_per_m2 = 6.0;
      break;
    default:  // kBooks: spines with labels
      s = style(1024, 0.0025f, {50, 50, 60}, kPosterColors, {0.2, 0.05, 0.015}, {0.0, 20.0, 120.0});
      s.strips = 2;
      s.strip_min_m = 0.015;
      s.strip_max_m = 0.06;
      s.lines_per_m2 = 20.0;
      break;
  }
  return s;
}

cv::Scalar jitter(const cv::Scalar& c, Rng* rng, double amount) {
  cv::Scalar out;
  const double common = rng->uniform(-amount, amount);
  for (int i = 0; i < 3; ++i)
    out[i] = std::clamp(c[i] + common + rng->uniform(-0.3, 0.3) * amount, 0.0, 255.0);
  return out;
}

const cv::Scalar& pick(const std::vector<cv::Scalar>& palette, Rng* rng) {
  return palette[static_cast<size_t>(rng->uniformInt(0, static_cast<int>(palette.size()) - 1))];
}

/// Bands of random width and colour along the rows (planks), with joints; transposed for book spines.
void drawStrips(cv::Mat* img, const TextureStyle& s, Rng* rng) {
  const int n = img->rows;
  for (int y = 0; y < n;) {
    const int h = std::max(2, static_cast<int>(rng->uniform(s.strip_min_m, s.strip_max_m) / s.texel_m));
    const cv::Scalar band = jitter(pick(s.palette, rng), rng, 30.0);
    cv::rectangle(*img, cv::Rect(0, y, n, h), band, cv::FILLED);
    cv::line(*img, {0, y}, {n - 1, y}, band * 0.45, 1);
    if (s.strips == 1)  // plank joints
      for (int x = rng->uniformInt(0, 400); x < n; x += rng->uniformInt(250, 600))
        cv::line(*img, {x, y}, {x, y + h - 1}, band * 0.4, 2);
    y += h;
  }
  if (s.strips == 2) cv::transpose(*img, *img);
}

void drawShapes(cv::Mat* img, const TextureStyle& s, Rng* rng) {
  const double area_m2 = std::pow(img->cols * s.texel_m, 2);
  const double px_per_m = 1.0 / s.texel_m;
  const int n = img->cols;
  for (int scale = 0; scale < 3; ++scale) {
    const int count = static_cast<int>(s.rects_per_m2[scale] * area_m2);
    const double size_px = s.rect_size_m[scale] * px_per_m;
    for (int i = 0; i < count; ++i) {
      const int w = std::max(2, static_cast<int>(size_px * rng->uniform(0.3, 1.0)));
      const int h = std::max(2, static_cast<int>(size_px * rng->uniform(0.3, 1.0)));
      const cv::Rect r(rng->uniformInt(0, n - 1), rng->uniformInt(0, n - 1), w, h);
      const bool filled = rng->chance(0.75);
      const int thickness = filled ? cv::FILLED : std::max(1, static_cast<int>(size_px * 0.05));
      cv::rectangle(*img, r, jitter(pick(s.palette, rng), rng, 35.0), thickness);
    }
  }
  for (int i = 0; i < static_cast<int>(s.blobs_per_m2 * area_m2); ++i) {
    const cv::Point c(rng->uniformInt(0, n - 1), rng->uniformInt(0, n - 1));
    const cv::Size axes(std::max(2, static_cast<int>(rng->uniform(0.01, 0.08) * px_per_m)),
                        std::max(2, static_cast<int>(rng->uniform(0.01, 0.08) * px_per_m)));
    cv::ellipse(*img, c, axes, rng->uniform(0, 180), 0, 360, jitter(pick(s.palette, rng), rng, 35.0),
                cv::FILLED, cv::LINE_AA);
  }
  for (int i = 0; i < static_cast<int>(s.lines_per_m2 * area_m2); ++i) {
    const cv::Point a(rng->uniformInt(0, n - 1), rng->uniformInt(0, n - 1));
    const double len = rng->uniform(0.05, 0.4) * px_per_m, ang = rng->uniform(0, CV_PI);
    const cv::Point b(a.x + static_cast<int>(len * std::cos(ang)),
                      a.y + static_cast<int>(len * std::sin(ang)));
    cv::line(*img, a, b, jitter(pick(s.palette, rng), rng, 35.0), rng->uniformInt(1, 3), cv::LINE_AA);
  }
}

void drawGrid(cv::Mat* img, const TextureStyle& s) {
  const int pitch = static_cast<int>(s.grid_m / s.texel_m);
  for (int p = pitch / 2; p < img->cols; p += pitch) {
    cv::line(*img, {p, 0}, {p, img->rows - 1}, cv::Scalar(120, 120, 120), 2);
    cv::line(*img, {0, p}, {img->cols - 1, p}, cv::Scalar(120, 120, 120), 2);
  }
}

/// Sum of upsampled random grids (value noise) with cells of 256..4 texels, roughly zero mean. Upsampling
/// is OpenCV's bit-exact bilinear on 8-bit grids and the sum is plain C++ (no FMA), so the texture is the
/// same on every CPU, whatever SIMD code OpenCV dispatches to.
cv::Mat valueNoise(int n, double aspect, Rng* rng) {
  cv::Mat sum(n, n, CV_32F, cv::Scalar(0));
  const float amplitudes[] = {0.45f, 0.3f, 0.2f, 0.15f};
  int cell = 256;
  for (float amp : amplitudes) {
    const int rows = std::max(2, n / cell);
    const int cols = std::max(2, static_cast<int>(n / (cell * aspect)));
    cv::Mat grid(rows, cols, CV_8U);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) grid.at<uchar>(r, c) = static_cast<uchar>(rng->next() >> 56);
    cv::Mat up;
    cv::resize(grid, up, sum.size(), 0, 0, cv::INTER_LINEAR_EXACT);
    for (int r = 0; r < n; ++r) {
      float* out = sum.ptr<float>(r);
      const uchar* in = up.ptr<uchar>(r);
      for (int c = 0; c < n; ++c) out[c] += amp * (static_cast<float>(in[c]) * (1.0f / 255.0f) - 0.5f);
    }
    cell /= 4;
  }
  return sum;
}

void modulate(cv::Mat* img, const cv::Mat& noise, double amplitude) {
  for (int r = 0; r < img->rows; ++r) {
    auto* p = img->ptr<cv::Vec3b>(r);
    const float* q = noise.ptr<float>(r);
    for (int c = 0; c < img->cols; ++c) {
      const float f = 1.0f + static_cast<float>(2.0 * amplitude) * q[c];
      for (int k = 0; k < 3; ++k) p[c][k] = cv::saturate_cast<uchar>(p[c][k] * f);
    }
  }
}

/// Bilinear lookup with wrap-around; (x, y) in texels of that level.
cv::Vec3f bilinear(const TextureLevel& level, float x, float y) {
  const float fx = x - 0.5f, fy = y - 0.5f;  // texel centres sit at half-integers
  int xi = static_cast<int>(fx), yi = static_cast<int>(fy);
  xi -= fx < static_cast<float>(xi);  // floor without a libm call
  yi -= fy < static_cast<float>(yi);
  const float ax = fx - static_cast<float>(xi), ay = fy - static_cast<float>(yi);
  const int mask = level.size - 1;
  const int x0 = xi & mask, x1 = (x0 + 1) & mask;
  const int y0 = yi & mask, y1 = (y0 + 1) & mask;
  const uchar* a = level.texel(x0, y0);
  const uchar* b = level.texel(x1, y0);
  const uchar* c = level.texel(x0, y1);
  const uchar* d = level.texel(x1, y1);
  const float wa = (1 - ax) * (1 - ay), wb = ax * (1 - ay), wc = (1 - ax) * ay, wd = ax * ay;
  return {wa * a[0] + wb * b[0] + wc * c[0] + wd * d[0], wa * a[1] + wb * b[1] + wc * c[1] + wd * d[1],
          wa * a[2] + wb * b[2] + wc * c[2] + wd * d[2]};
}

/// log2(v) for normal v > 0 to within 0.005: exponent bits plus a quadratic in the mantissa (the
/// quadratic's 1.0 at m = 1 absorbs the exponent bias being taken as 128). Cheaper than log2f,
/// and plenty for choosing mip levels.
float fastLog2(float v) {
  uint32_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  const float exponent = static_cast<float>(static_cast<int>((bits >> 23) & 255u) - 128);
  bits = (bits & 0x007FFFFFu) | 0x3F800000u;  // mantissa in [1, 2)
  float m = 0.0f;
  std::memcpy(&m, &bits, sizeof m);
  return exponent + (-0.34484843f * m + 2.02466578f) * m - 0.67487759f;
}

TextureLevel toBlocks(const cv::Mat& bgr) {
  TextureLevel level;
  level.size = bgr.cols;
  level.texels.create(1, bgr.cols * bgr.rows, CV_8UC4);
  for (int y = 0; y < bgr.rows; ++y) {
    const auto* row = bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      uchar* t = level.texel(x, y);
      for (int c = 0; c < 3; ++c) t[c] = row[x][c];
      t[3] = 0;
    }
  }
  return level;
}

}  // namespace

MipTexture makeMaterialTexture(Material material, uint64_t seed) {
  const TextureStyle s = styleOf(material);
  Rng rng(mix64(seed) ^ (0x51ED270B2F3A5C97ull * static_cast<uint64_t>(material + 1)));
  cv::Mat img(s.size, s.size, CV_8UC3, s.base);
  if (s.strips) drawStrips(&img, s, &rng);
  if (s.grid_m > 0) drawGrid(&img, s);
  drawShapes(&img, s, &rng);
  modulate(&img, valueNoise(s.size, s.grain_aspect, &rng), s.noise_amplitude);
  MipTexture tex;
  tex.texel_m = s.texel_m;
  while (true) {
    tex.levels.push_back(toBlocks(img));
    tex.inv_texel_m.push_back(1.0f / (s.texel_m * static_cast<float>(s.size / img.cols)));
    if (img.cols <= 8) break;
    cv::Mat down;
    cv::pyrDown(img, down);
    img = down;
  }
  return tex;
}

cv::Vec3f MipTexture::sample(float u_m, float v_m, float footprint_m) const {
  const float lambda = fastLog2(std::max(footprint_m * inv_texel_m[0], 1e-6f));
  if (lambda <= 0.0f) return bilinear(levels[0], u_m * inv_texel_m[0], v_m * inv_texel_m[0]);
  const size_t last = levels.size() - 1;
  const size_t l0 = std::min(static_cast<size_t>(lambda), last);
  if (l0 == last) return bilinear(levels[last], u_m * inv_texel_m[last], v_m * inv_texel_m[last]);
  const float frac = lambda - static_cast<float>(l0);
  const cv::Vec3f a = bilinear(levels[l0], u_m * inv_texel_m[l0], v_m * inv_texel_m[l0]);
  const cv::Vec3f b = bilinear(levels[l0 + 1], u_m * inv_texel_m[l0 + 1], v_m * inv_texel_m[l0 + 1]);
  return a + frac * (b - a);
}

}  // namespace rgbdmap::synth
