// Codec benchmark: bytes per keyframe and encode/decode time on one core, per depth filter, zstd level
// and colour mode, on ~30 frames of a TUM recording. Usage: bench_codec [google-benchmark flags]
// (the recording folder can be set with RGBDMAP_BENCH_DATA=/path/to/tum_sequence). Run it pinned, e.g.
// `taskset -c 1 build/bin/bench_codec --benchmark_repetitions=5` (the summary shows medians).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "rgbdmap/codec/image_codec.hpp"

namespace {

using rgbdmap::ColorCodec;
using rgbdmap::DepthFilter;
using rgbdmap::EncodedImages;
using rgbdmap::ImageCodecOptions;

/// kDepthPng and kColorPng are references outside the codec: PNG at its fastest level via OpenCV (the TUM
/// recordings store depth as PNG; PNG is the obvious alternative for lossless colour).
enum class Part { kDepth, kColor, kKeyframe, kDepthPng, kColorPng };

struct Mode {
  std::string name;
  Part part;
  ImageCodecOptions options;
  std::vector<EncodedImages> encoded;  // one per frame
  double mean_bytes = 0.0, max_bytes = 0.0;
};

std::vector<rgbdmap::RgbdFrame> loadFrames(const std::string& dir, size_t count) {
  std::vector<std::string> rgb, depth;
  for (const auto& e : std::filesystem::directory_iterator(dir + "/rgb")) rgb.push_back(e.path().string());
  for (const auto& e : std::filesystem::directory_iterator(dir + "/depth"))
    depth.push_back(e.path().string());
  std::sort(rgb.begin(), rgb.end());
  std::sort(depth.begin(), depth.end());
  const size_t n = std::min(rgb.size(), depth.size()), step = std::max<size_t>(1, n / count);
  std::vector<rgbdmap::RgbdFrame> frames;
  for (size_t i = 0; i < n && frames.size() < count; i += step) {
    rgbdmap::RgbdFrame f;
    f.color = cv::imread(rgb[i], cv::IMREAD_COLOR);
    f.depth = cv::imread(depth[i], cv::IMREAD_UNCHANGED);
    if (f.color.empty() || f.depth.type() != CV_16UC1) continue;
    frames.push_back(f);
  }
  return frames;
}

std::vector<Mode> makeModes() {
  std::vector<Mode> modes;
  for (DepthFilter filter : {DepthFilter::kNone, DepthFilter::kRowDelta, DepthFilter::kRankMed}) {
    for (int level : {1, 3}) {
      ImageCodecOptions o;
      o.depth_filter = filter;
      o.zstd_level = level;
      modes.push_back(
          {"depth/" + rgbdmap::toString(filter) + "/zstd" + std::to_string(level), Part::kDepth, o, {}});
    }
  }
  ImageCodecOptions ctx;
  ctx.depth_filter = DepthFilter::kRankCtx;
  modes.push_back({"depth/rank-ctx/range-coded", Part::kDepth, ctx, {}});
  for (int quality : {50, 60, 70, 75, 90, 95}) {
    ImageCodecOptions o;
    o.jpeg_quality = quality;
    modes.push_back({"colour/jpeg/q" + std::to_string(quality), Part::kColor, o, {}});
  }
  ImageCodecOptions lossless;
  lossless.color = ColorCodec::kLossless;
  modes.push_back({"colour/lossless/zstd1", Part::kColor, lossless, {}});
  modes.push_back({"colour/png-fast (reference, cv::imencode)", Part::kColorPng, ImageCodecOptions{}, {}});
  modes.push_back({"depth/png-fast (reference, cv::imencode)", Part::kDepthPng, ImageCodecOptions{}, {}});
  ImageCodecOptions none;
  none.color = ColorCodec::kNone;
  modes.push_back({"colour/none", Part::kColor, none, {}});
  modes.push_back({"keyframe/default(rank-ctx + jpeg q70)", Part::kKeyframe, ImageCodecOptions{}, {}});
  return modes;
}

bool encode(const Mode& m, const rgbdmap::RgbdFrame& f, EncodedImages& out) {
  if (m.part == Part::kDepthPng)
    return cv::imencode(".png", f.depth, out.depth, {cv::IMWRITE_PNG_COMPRESSION, 1});
  if (m.part == Part::kColorPng)
    return cv::imencode(".png", f.color, out.color, {cv::IMWRITE_PNG_COMPRESSION, 1});
  if (m.part == Part::kKeyframe) {
    auto r = rgbdmap::encodeImages(f, m.options);
    if (r) out = std::move(*r);
    return r.ok();
  }
  auto r = m.part == Part::kDepth ? rgbdmap::encodeDepth(f.depth, m.options)
                                  : rgbdmap::encodeColor(f.color, m.options);
  if (!r) return false;
  (m.part == Part::kDepth ? out.depth : out.color) = std::move(*r);
  out.width = static_cast<uint16_t>(f.depth.cols);
  out.height = static_cast<uint16_t>(f.depth.rows);
  out.color_codec = m.options.color;
  return true;
}

bool decodePng(const std::vector<uint8_t>& bytes, const cv::Mat* original) {
  const cv::Mat image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  return !image.empty() && (original == nullptr || cv::norm(image, *original, cv::NORM_INF) == 0);
}

/// Decodes and, for lossless parts, checks the result; returns false on any failure.
bool decode(const Mode& m, const EncodedImages& e, const rgbdmap::RgbdFrame* check) {
  if (m.part == Part::kDepthPng) return decodePng(e.depth, check ? &check->depth : nullptr);
  if (m.part == Part::kColorPng) return decodePng(e.color, check ? &check->color : nullptr);
  cv::Mat depth, color;
  if (m.part != Part::kColor) {
    auto r = rgbdmap::decodeDepth(e.depth.data(), e.depth.size(), e.width, e.height);
    if (!r) return false;
    depth = *r;
  }
  if (m.part != Part::kDepth) {
    auto r = rgbdmap::decodeColor(e.color.data(), e.color.size(), e.color_codec, e.width, e.height);
    if (!r) return false;
    color = *r;
  }
  if (check == nullptr) return true;
  if (!depth.empty() && cv::norm(depth, check->depth, cv::NORM_INF) != 0) return false;
  if (m.options.color == ColorCodec::kLossless && cv::norm(color, check->color, cv::NORM_INF) != 0)
    return false;
  return true;
}

/// Encodes every frame once, checks the round trip, and records the sizes.
bool prepare(Mode& m, const std::vector<rgbdmap::RgbdFrame>& frames) {
  m.encoded.resize(frames.size());
  double total = 0.0;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (!encode(m, frames[i], m.encoded[i]) || !decode(m, m.encoded[i], &frames[i])) return false;
    const double bytes = static_cast<double>(m.encoded[i].depth.size() + m.encoded[i].color.size());
    total += bytes;
    m.max_bytes = std::max(m.max_bytes, bytes);
  }
  m.mean_bytes = total / static_cast<double>(frames.size());
  return true;
}

/// Console output plus the CPU milliseconds per keyframe of each run, for the summary table: the median
/// over --benchmark_repetitions. CPU time rather than wall time: on a shared machine the wall time also
/// counts other processes' turns.
class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  SummaryReporter() : ConsoleReporter(OO_Tabular) {}
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs)
      if (r.run_type == Run::RT_Iteration && !r.error_occurred)
        ms_[r.run_name.str()].push_back(r.GetAdjustedCPUTime());
  }
  double ms(const std::string& name) const {
    const auto it = ms_.find(name);
    if (it == ms_.end()) return 0.0;
    std::vector<double> v = it->second;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  }

 private:
  std::map<std::string, std::vector<double>> ms_;
};

void printSummary(const std::vector<Mode>& modes, const SummaryReporter& reporter, size_t frame_count) {
  std::printf("\nSummary: %zu frames, one core, CPU ms per keyframe; bytes include the blob headers\n",
              frame_count);
  std::printf("%-46s %10s %10s %9s %9s %9s %12s\n", "mode", "mean B", "max B", "enc ms", "dec ms", "sum ms",
              "vs raw zstd");
  std::map<int, double> raw_zstd;  // zstd level -> mean bytes of unfiltered depth
  for (const Mode& m : modes) {
    if (m.part == Part::kDepth && m.options.depth_filter == DepthFilter::kNone)
      raw_zstd[m.options.zstd_level] = m.mean_bytes;
    const double enc = reporter.ms(m.name + "/encode"), dec = reporter.ms(m.name + "/decode");
    std::string gain = "";
    if (m.part == Part::kDepth && raw_zstd.count(m.options.zstd_level)) {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%+.1f%%",
                    100.0 * (m.mean_bytes / raw_zstd[m.options.zstd_level] - 1.0));
      gain = buf;
    }
    std::printf("%-46s %10.0f %10.0f %9.3f %9.3f %9.3f %12s\n", m.name.c_str(), m.mean_bytes, m.max_bytes,
                enc, dec, enc + dec, gain.c_str());
  }
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // the target is one core; the library itself never changes threading
  benchmark::Initialize(&argc, argv);
  const char* env = std::getenv("RGBDMAP_BENCH_DATA");
  const std::string dir = env ? env : RGBDMAP_BENCH_DATA_DIR;
  if (!std::filesystem::is_directory(dir + "/rgb") || !std::filesystem::is_directory(dir + "/depth")) {
    std::printf("bench_codec: skipped, no TUM recording at %s (set RGBDMAP_BENCH_DATA)\n", dir.c_str());
    return 0;
  }
  const std::vector<rgbdmap::RgbdFrame> frames = loadFrames(dir, 30);
  if (frames.empty()) {
    std::printf("bench_codec: no readable frames in %s\n", dir.c_str());
    return 1;
  }
  std::vector<Mode> modes = makeModes();
  for (Mode& m : modes) {
    if (!prepare(m, frames)) {
      std::printf("bench_codec: %s failed to round-trip\n", m.name.c_str());
      return 1;
    }
    benchmark::RegisterBenchmark((m.name + "/encode").c_str(), [&m, &frames](benchmark::State& state) {
      EncodedImages out;
      size_t i = 0;
      for (auto _ : state) benchmark::DoNotOptimize(encode(m, frames[i++ % frames.size()], out));
      state.counters["bytes"] = m.mean_bytes;
    })->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((m.name + "/decode").c_str(), [&m](benchmark::State& state) {
      size_t i = 0;
      for (auto _ : state) benchmark::DoNotOptimize(decode(m, m.encoded[i++ % m.encoded.size()], nullptr));
    })->Unit(benchmark::kMillisecond);
  }
  SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  printSummary(modes, reporter, frames.size());
  benchmark::Shutdown();
  return 0;
}
