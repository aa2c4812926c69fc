// kRankCtx: the rank-table depth of kRankMed, coded with context models and a binary range coder instead
// of zstd (format in image_codec.hpp). One templated pass serves the encoder and the decoder, so both
// always update the same models in the same order.
//
// Per pixel, in scan order, with a = left, b = above, c = above-left, d = above-right (ranks; outside the
// image counts as a hole):
//  1. the hole flag, under the hole pattern of a, b, c, d and the pixel two to the left (32 contexts);
//  2. for a pixel with depth, the residual rank - prediction. The prediction is kRankMed's: the LOCO-I
//     median of a, b, c when all have depth, else b when a is a hole, else a, else d, else the last rank.
//     The residual is binarised as
//       zero flag   under the prediction's kind (4), the local activity |a - c| + |b - c| + |d - b| over
//                   the pairs with depth (8 levels), whether the residuals left and above were non-zero
//                   (2 x 2), and how many of a, b, c, d equal the prediction (0..4): 640 contexts;
//       sign        under the kind, the side of the prediction a and b are on (3 x 3) and the sign of the
//                   residual to the left (3): 108 contexts;
//       magnitude   minus one, in unary up to kUnary with an adaptive bit per position and zero-flag
//                   context, then an escape in adaptive Elias-gamma per kind.
// The rank table (K entries, ascending) is coded first: its first value and every later step minus one in
// adaptive Elias-gamma. On TUM fr1 depth this takes 31 KB per frame against 60 KB for the same ranks
// through zstd (bench_codec); most of it is the zero flag, i.e. the sensor's +-1 disparity noise.
#include <algorithm>
#include <cstdlib>
#include <memory>
#include <string>

#include "depth_filters.hpp"
#include "range_coder.hpp"

namespace rgbdmap::detail {
namespace {

constexpr int kKinds = 4;
constexpr int kLevels = 8;
constexpr int kResidualContexts = kKinds * kLevels * 4 * 5;
constexpr int kSignContexts = kKinds * 9 * 3;
constexpr int kUnary = 14;

struct DepthModel {
  Prob hole[32];
  Prob nonzero[kResidualContexts];
  Prob negative[kSignContexts];
  Prob unary[kResidualContexts][kUnary];
  GammaModel escape[kKinds];
  GammaModel table;
};

inline int level(int activity) {
  if (activity <= 2) return activity;  // 0, 1, 2
  if (activity <= 4) return 3;
  if (activity <= 8) return 4;
  if (activity <= 16) return 5;
  if (activity <= 40) return 6;
  return 7;
}

/// Prediction and context of a pixel with depth; `last` is the rank of the previous pixel with depth.
struct Context {
  int prediction;
  int kind;
  int activity;
};

inline Context contextOf(int a, int b, int c, int d, int last) {
  int activity = 0;
  if (a != kHole && c != kHole) activity += std::abs(a - c);
  if (b != kHole && c != kHole) activity += std::abs(b - c);
  if (b != kHole && d != kHole) activity += std::abs(d - b);
  if (a != kHole && b != kHole && c != kHole)
    return {std::max(std::min(a, b), std::min(std::max(a, b), a + b - c)), 0, activity};
  if (a == kHole && b != kHole) return {b, 1, activity};
  if (a != kHole) return {a, 2, activity};
  return {d != kHole ? d : last, 3, activity};
}

/// Codes one residual (encoder) or decodes it (decoder; e is ignored). Returns INT32_MIN on forged input.
template <class Io>
int codeResidual(Io& io, DepthModel& m, int escape_kind, int ctx, int sign_ctx, int e) {
  if (io.bit(m.nonzero[ctx], e != 0) == 0) return 0;
  const int negative = io.bit(m.negative[sign_ctx], e < 0);
  const uint32_t v = static_cast<uint32_t>(std::abs(e)) - 1u;  // encoder only: magnitude - 1
  int64_t mag = 0;
  while (mag < kUnary && io.bit(m.unary[ctx][mag], v > static_cast<uint32_t>(mag)) == 1) ++mag;
  if (mag == kUnary) {
    const int64_t rest = codeGamma(io, m.escape[escape_kind], v - kUnary);
    if (rest < 0 || rest > 65535) return INT32_MIN;
    mag += rest;
  }
  return negative ? -static_cast<int>(mag + 1) : static_cast<int>(mag + 1);
}

/// The pixel pass. On the encoder `ranks` holds every pixel's rank (kHole for no depth) and is read; on the
/// decoder it is written. Returns false when a decoded rank falls outside the table (forged input).
template <class Io>
bool codePixels(Io& io, DepthModel& m, int cols, int rows, int table_size, std::vector<int>& ranks) {
  std::vector<int> above(cols + 2, kHole);  // [x + 1] is column x; [0] and [cols + 1] are outside
  std::vector<int> here(cols + 2, kHole);
  std::vector<uint8_t> nz_above(cols + 2, 0), nz_here(cols + 2, 0);  // residual != 0, indexed like above
  int last = 0;
  bool ok = true;
  for (int y = 0; y < rows; ++y) {
    int* row = ranks.data() + static_cast<size_t>(y) * cols;
    int left_nonzero = 0, left_sign = 1;
    for (int x = 0; x < cols; ++x) {
      const int a = here[x], b = above[x + 1], c = above[x], d = above[x + 2];
      const int aa = x >= 1 ? here[x - 1] : kHole;  // two to the left
      const int hole_ctx =
          (a == kHole) | (b == kHole) << 1 | (c == kHole) << 2 | (d == kHole) << 3 | (aa == kHole) << 4;
      const int rank_in = row[x];
      if (io.bit(m.hole[hole_ctx], rank_in == kHole) == 1) {
        row[x] = kHole;
        here[x + 1] = kHole;
        left_nonzero = 0;
        left_sign = 1;
        continue;
      }
      const Context cx = contextOf(a, b, c, d, last);
      const int agree =
          (a == cx.prediction) + (b == cx.prediction) + (c == cx.prediction) + (d == cx.prediction);
      const int ctx =
          ((cx.kind * kLevels + level(cx.activity)) * 4 + left_nonzero * 2 + nz_above[x + 1]) * 5 + agree;
      auto sgn = [&](int v) { return v == kHole ? 1 : (v > cx.prediction) - (v < cx.prediction) + 1; };
      const int sign_ctx = ((cx.kind * 3 + sgn(a)) * 3 + sgn(b)) * 3 + left_sign;
      const int r = codeResidual(io, m, cx.kind, ctx, sign_ctx, rank_in - cx.prediction);
      const int64_t rank = static_cast<int64_t>(cx.prediction) + r;
      if (r == INT32_MIN || rank < 0 || rank >= table_size) {
        ok = false;  // a decoder only: keep a defined state and report after the row
        row[x] = kHole;
        here[x + 1] = kHole;
        continue;
      }
      row[x] = static_cast<int>(rank);
      here[x + 1] = static_cast<int>(rank);
      last = static_cast<int>(rank);
      left_nonzero = r != 0;
      left_sign = (r > 0) - (r < 0) + 1;
      nz_here[x + 1] = r != 0;
    }
    if (!ok) return false;
    std::swap(above, here);
    std::fill(here.begin(), here.end(), kHole);
    std::swap(nz_above, nz_here);
    std::fill(nz_here.begin(), nz_here.end(), 0);
  }
  return true;
}

}  // namespace

void packRankCtx(const cv::Mat& depth, const std::vector<uint16_t>& table, Bytes& out) {
  std::vector<int> rank_of(65536, kHole);
  for (size_t t = 0; t < table.size(); ++t) rank_of[table[t]] = static_cast<int>(t);
  std::vector<int> ranks(depth.total());
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* row = depth.ptr<uint16_t>(y);
    for (int x = 0; x < depth.cols; ++x) ranks[static_cast<size_t>(y) * depth.cols + x] = rank_of[row[x]];
  }
  out.clear();
  out.reserve(depth.total() / 8);
  RangeEncoder rc(out);
  BitWriter io{rc};
  auto model = std::make_unique<DepthModel>();
  for (size_t t = 0; t < table.size(); ++t)
    codeGamma(io, model->table, t == 0 ? table[0] - 1u : table[t] - table[t - 1] - 1u);
  codePixels(io, *model, depth.cols, depth.rows, static_cast<int>(table.size()), ranks);
  rc.finish();
}

Status unpackRankCtx(const uint8_t* in, size_t size, size_t table_size, cv::Mat& depth) {
  RangeDecoder rc(in, size);
  BitReader io{rc};
  auto model = std::make_unique<DepthModel>();
  std::vector<uint16_t> value_of(table_size + 1, 0);  // [0] is the hole
  for (size_t t = 0; t < table_size; ++t) {
    const int64_t step = codeGamma(io, model->table, 0);
    const int64_t next = value_of[t] + step + 1;
    if (rc.overrun() > 0)
      return Status::failure("depth blob: the coded stream ends early, in the rank table");
    if (step < 0 || next > 65535)
      return Status::failure("depth blob: rank table entry " + std::to_string(t) + " is outside 1..65535");
    value_of[t + 1] = static_cast<uint16_t>(next);
  }
  std::vector<int> ranks(depth.total(), 0);
  if (!codePixels(io, *model, depth.cols, depth.rows, static_cast<int>(table_size), ranks))
    return Status::failure("depth blob: a residual points outside the rank table");
  if (rc.overrun() > 0)
    return Status::failure("depth blob: the coded stream ends " + std::to_string(rc.overrun()) +
                           " bytes early");
  if (rc.consumed() != size)
    return Status::failure("depth blob: " + std::to_string(size - rc.consumed()) +
                           " bytes after the coded stream");
  for (int y = 0; y < depth.rows; ++y) {
    uint16_t* row = depth.ptr<uint16_t>(y);
    const int* r = ranks.data() + static_cast<size_t>(y) * depth.cols;
    for (int x = 0; x < depth.cols; ++x) row[x] = value_of[r[x] + 1];
  }
  return Status::success();
}

}  // namespace rgbdmap::detail
