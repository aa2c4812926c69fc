#include "rgbdmap/common/config_reader.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>

#include <yaml-cpp/yaml.h>

namespace rgbdmap {
namespace {

std::vector<std::string> splitKey(const std::string& key) {
  std::vector<std::string> parts;
  std::stringstream ss(key);
  std::string p;
  while (std::getline(ss, p, '.')) parts.push_back(p);
  return parts;
}

// All leaf keys of a map, dotted; sequences count as leaves.
void collectLeaves(const YAML::Node& node, const std::string& prefix, std::vector<std::string>* out) {
  if (!node.IsMap()) {
    out->push_back(prefix);
    return;
  }
  for (const auto& kv : node) {
    const std::string k = kv.first.as<std::string>();
    collectLeaves(kv.second, prefix.empty() ? k : prefix + "." + k, out);
  }
}

template <typename T>
std::string show(const T& v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

ConfigReader::ConfigReader() : root_(std::make_shared<YAML::Node>()) {}

Result<ConfigReader> ConfigReader::fromString(const std::string& yaml, const std::string& source_name) {
  ConfigReader r;
  r.source_ = source_name;
  try {
    *r.root_ = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    return Result<ConfigReader>::failure(source_name + ": " + e.what());
  }
  if (!r.root_->IsNull() && !r.root_->IsMap())
    return Result<ConfigReader>::failure(source_name + ": top level must be a map of sections");
  return r;
}

Result<ConfigReader> ConfigReader::fromFile(const std::string& path) {
  try {
    const YAML::Node n = YAML::LoadFile(path);
    std::ostringstream os;
    os << n;
    return fromString(os.str(), path);
  } catch (const YAML::BadFile&) {
    return Result<ConfigReader>::failure(path + ": cannot open");
  } catch (const YAML::Exception& e) {
    return Result<ConfigReader>::failure(path + ": " + e.what());
  }
}

bool ConfigReader::lookup(const std::string& key, YAML::Node* out) const {
  if (!root_->IsMap()) return false;
  YAML::Node cur = YAML::Clone(*root_);
  for (const auto& part : splitKey(key)) {
    if (!cur.IsMap() || !cur[part]) return false;
    cur = cur[part];
  }
  *out = cur;
  return true;
}

bool ConfigReader::present(const std::string& key, YAML::Node* out) {
  if (!lookup(key, out)) return false;
  if (!out->IsNull()) return true;
  errors_.push_back(source_ + ": " + key + ": has no value (give one, or remove the key for its default)");
  return false;
}

bool ConfigReader::has(const std::string& key) const {
  YAML::Node n;
  return lookup(key, &n);
}

template <typename T>
void ConfigReader::read(const std::string& key, T* value, const ConfigRange& range) {
  read_keys_.push_back(key);
  YAML::Node n;
  if (present(key, &n)) {
    try {
      const T v = n.as<T>();
      if constexpr (std::is_floating_point_v<T>) {
        if (!std::isfinite(v)) throw YAML::Exception(YAML::Mark(), "not finite");
      }
      if (!range.contains(v))
        errors_.push_back(source_ + ": " + key + " = " + show(v) + " is outside " + range.str());
      else
        *value = v;
    } catch (const YAML::Exception&) {
      errors_.push_back(source_ + ": " + key + ": '" + n.as<std::string>("?") + "' is not a valid number");
    }
  }
  effective_.push_back(key + " = " + show(*value));
}

template void ConfigReader::read(const std::string&, int*, const ConfigRange&);
template void ConfigReader::read(const std::string&, unsigned*, const ConfigRange&);
template void ConfigReader::read(const std::string&, unsigned long*, const ConfigRange&);
template void ConfigReader::read(const std::string&, long long*, const ConfigRange&);
template void ConfigReader::read(const std::string&, float*, const ConfigRange&);
template void ConfigReader::read(const std::string&, double*, const ConfigRange&);

void ConfigReader::read(const std::string& key, int* v, int min, int max) {
  read(key, v, ConfigRange::closed(min, max));
}
void ConfigReader::read(const std::string& key, unsigned* v, unsigned min, unsigned max) {
  read(key, v, ConfigRange::closed(min, max));
}
void ConfigReader::read(const std::string& key, double* v, double min, double max) {
  read(key, v, ConfigRange::closed(min, max));
}
void ConfigReader::read(const std::string& key, float* v, float min, float max) {
  read(key, v, ConfigRange::closed(min, max));
}

void ConfigReader::read(const std::string& key, bool* value) {
  read_keys_.push_back(key);
  YAML::Node n;
  if (present(key, &n)) {
    try {
      *value = n.as<bool>();
    } catch (const YAML::Exception&) {
      errors_.push_back(source_ + ": " + key + ": expected true or false");
    }
  }
  effective_.push_back(key + " = " + (*value ? "true" : "false"));
}

void ConfigReader::read(const std::string& key, std::string* value, const std::vector<std::string>& allowed) {
  read_keys_.push_back(key);
  YAML::Node n;
  if (present(key, &n)) {
    const std::string v = n.IsScalar() ? n.as<std::string>() : "";
    if (!n.IsScalar() ||
        (!allowed.empty() && std::find(allowed.begin(), allowed.end(), v) == allowed.end())) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : "|") + a;
      errors_.push_back(source_ + ": " + key + ": '" + v + "' is not one of " + list);
    } else {
      *value = v;
    }
  }
  effective_.push_back(key + " = " + *value);
}

void ConfigReader::readList(const std::string& key, double* values, size_t count) {
  read_keys_.push_back(key);
  YAML::Node n;
  if (present(key, &n)) {
    bool ok = n.IsSequence() && n.size() == count;
    std::vector<double> tmp(count);
    for (size_t i = 0; ok && i < count; ++i) {
      try {
        tmp[i] = n[i].as<double>();
        ok = std::isfinite(tmp[i]);
      } catch (const YAML::Exception&) {
        ok = false;
      }
    }
    if (ok)
      std::copy(tmp.begin(), tmp.end(), values);
    else
      errors_.push_back(source_ + ": " + key + ": expected a list of " + std::to_string(count) +
                        " finite numbers");
  }
  std::string shown;
  for (size_t i = 0; i < count; ++i) shown += (i ? ", " : "") + show(values[i]);
  effective_.push_back(key + " = [" + shown + "]");
}

std::vector<std::string> ConfigReader::errors() const {
  std::vector<std::string> all = errors_;
  std::vector<std::string> leaves;
  if (root_->IsMap()) collectLeaves(*root_, "", &leaves);
  for (const auto& leaf : leaves)
    if (std::find(read_keys_.begin(), read_keys_.end(), leaf) == read_keys_.end())
      all.push_back(source_ + ": unknown key '" + leaf + "'");
  return all;
}

std::string ConfigReader::effectiveValues() const {
  std::string out;
  for (const auto& e : effective_) out += "  " + e + "\n";
  return out;
}

}  // namespace rgbdmap
