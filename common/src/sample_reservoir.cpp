#include "rgbdmap/common/sample_reservoir.hpp"

#include <algorithm>

namespace rgbdmap {

double quantileOf(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double pos = q * static_cast<double>(values.size() - 1);
  const size_t lo = static_cast<size_t>(pos);
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (pos - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

SampleReservoir::SampleReservoir(size_t capacity, uint64_t seed)
    : capacity_(std::max<size_t>(capacity, 1)), rng_(seed) {}

void SampleReservoir::add(double value) {
  max_ = count_ == 0 ? value : std::max(max_, value);
  const uint64_t index = count_++;
  if (kept_.size() < capacity_) {
    kept_.push_back({index, value});
    return;
  }
  // Keep the new sample with probability capacity / count, in place of a uniformly chosen kept one.
  const uint64_t slot = std::uniform_int_distribution<uint64_t>(0, index)(rng_);
  if (slot < capacity_) kept_[static_cast<size_t>(slot)] = {index, value};
}

double SampleReservoir::quantile(double q) const {
  std::vector<double> values;
  values.reserve(kept_.size());
  for (const Kept& k : kept_) values.push_back(k.value);
  return quantileOf(std::move(values), q);
}

std::vector<double> SampleReservoir::samples() const {
  std::vector<Kept> sorted = kept_;
  std::sort(sorted.begin(), sorted.end(), [](const Kept& a, const Kept& b) { return a.index < b.index; });
  std::vector<double> out;
  out.reserve(sorted.size());
  for (const Kept& k : sorted) out.push_back(k.value);
  return out;
}

}  // namespace rgbdmap
