#pragma once
// Reads a YAML configuration once: typed values by dotted key ("odometry.orb.n_features") with range
// checks. Every problem is collected (not just the first), keys that nothing reads are reported as
// unknown, and the values in effect can be logged. Apps use it; libraries only see plain structs.
#include <memory>
#include <string>
#include <vector>

#include "rgbdmap/common/config_range.hpp"
#include "rgbdmap/common/result.hpp"

namespace YAML {
class Node;
}

namespace rgbdmap {

class ConfigReader {
 public:
  /// An empty configuration: every read() keeps the default.
  ConfigReader();
  static Result<ConfigReader> fromFile(const std::string& path);
  static Result<ConfigReader> fromString(const std::string& yaml,
                                         const std::string& source_name = "<string>");

  /// If the key exists, parse it into *value and check min <= value <= max; record an error otherwise.
  /// Records "key = value" (default or read) for effectiveValues().
  void read(const std::string& key, int* value, int min, int max);
  void read(const std::string& key, unsigned* value, unsigned min, unsigned max);
  void read(const std::string& key, double* value, double min, double max);
  void read(const std::string& key, float* value, float min, float max);
  /// The same with a range that may have open or absent ends (config_range.hpp). T is int, unsigned,
  /// unsigned long, long long, float or double.
  template <typename T>
  void read(const std::string& key, T* value, const ConfigRange& range);
  void read(const std::string& key, bool* value);
  void read(const std::string& key, std::string* value, const std::vector<std::string>& allowed = {});
  /// A fixed-length list of finite numbers, e.g. distortion [k1, k2, p1, p2, k3].
  void readList(const std::string& key, double* values, size_t count);

  bool has(const std::string& key) const;
  void addError(const std::string& error) { errors_.push_back(error); }
  /// Errors so far plus one per key present in the file that no read() asked for.
  std::vector<std::string> errors() const;
  std::string effectiveValues() const;
  const std::string& source() const { return source_; }

 private:
  bool lookup(const std::string& key, YAML::Node* out) const;
  /// lookup(), and a key given without a value ("key:") is an error, not its default.
  bool present(const std::string& key, YAML::Node* out);

  std::shared_ptr<YAML::Node> root_;
  std::string source_;
  std::vector<std::string> errors_;
  std::vector<std::string> read_keys_;
  std::vector<std::string> effective_;
};

}  // namespace rgbdmap
