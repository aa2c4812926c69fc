#pragma once
// Summary statistics of an unbounded stream of samples (per-keyframe timings) in bounded memory: the count
// and the maximum exactly, quantiles from a uniform random sample of at most `capacity` values (reservoir
// sampling, Vitter's algorithm R, fixed seed: the same stream gives the same numbers). Up to `capacity`
// samples nothing is dropped and the quantiles are exact; beyond, they are those of the whole stream within
// sampling noise (the median of 4096 samples is within ~0.02 quantile of the true one).
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

namespace rgbdmap {

/// q-quantile (0..1) with linear interpolation between order statistics; 0 for an empty vector.
double quantileOf(std::vector<double> values, double q);

class SampleReservoir {
 public:
  static constexpr size_t kDefaultCapacity = 4096;

  explicit SampleReservoir(size_t capacity = kDefaultCapacity, uint64_t seed = 1);

  void add(double value);
  uint64_t count() const { return count_; }  ///< every sample added
  double max() const { return count_ ? max_ : 0.0; }
  double quantile(double q) const;  ///< of the kept samples; 0 when empty
  double median() const { return quantile(0.5); }
  /// The kept samples in the order they were added (all of them while count() <= capacity()).
  std::vector<double> samples() const;
  size_t capacity() const { return capacity_; }

 private:
  struct Kept {
    uint64_t index = 0;  ///< position in the stream
    double value = 0.0;
  };
  size_t capacity_;
  std::vector<Kept> kept_;
  uint64_t count_ = 0;
  double max_ = 0.0;
  std::mt19937_64 rng_;
};

}  // namespace rgbdmap
