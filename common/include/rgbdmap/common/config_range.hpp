#pragma once
// The range of one numeric configuration value: both ends closed or open, or absent (infinite). A value in
// range is always finite. Written once per value, in the value's config table (config_table.hpp).
#include <limits>
#include <string>
#include <type_traits>

namespace rgbdmap {

struct ConfigRange {
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  double min = -kInf, max = kInf;
  bool min_open = false, max_open = false;

  static ConfigRange closed(double lo, double hi) { return {lo, hi, false, false}; }     ///< [lo, hi]
  static ConfigRange open(double lo, double hi) { return {lo, hi, true, true}; }         ///< (lo, hi)
  static ConfigRange openClosed(double lo, double hi) { return {lo, hi, true, false}; }  ///< (lo, hi]
  static ConfigRange closedOpen(double lo, double hi) { return {lo, hi, false, true}; }  ///< [lo, hi)
  static ConfigRange atLeast(double lo) { return {lo, kInf, false, true}; }              ///< [lo, inf)
  static ConfigRange above(double lo) { return {lo, kInf, true, true}; }                 ///< (lo, inf)
  static ConfigRange any() { return {-kInf, kInf, true, true}; }                         ///< finite

  /// v is finite and within. Single precision values are compared with the ends rounded to float, so that
  /// a float member whose default is written as an end (1.01f) stays in range.
  template <typename T>
  bool contains(T v) const {
    if constexpr (std::is_same_v<T, float>)
      return within(v, static_cast<float>(min), static_cast<float>(max));
    else
      return within(static_cast<double>(v), min, max);
  }
  /// "[0.005, 1]", "(0.5, 1)", "[0, inf)".
  std::string str() const;

 private:
  bool within(double v, double lo, double hi) const;
};

/// A number as the configuration shows it (up to 10 significant digits: 0.995, 1e-06, 4294967295).
std::string formatConfigNumber(double v);

}  // namespace rgbdmap
