#include "rgbdmap/cli/cli.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::cli {

Args::Args(int argc, char** argv, const std::vector<std::string>& flags) {
  const std::set<std::string> flag_set(flags.begin(), flags.end());
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    if (a.rfind("--", 0) != 0) {
      positional_.push_back(a);
      continue;
    }
    std::string key = a.substr(2), value;
    const auto eq = key.find('=');
    if (eq != std::string::npos) {
      value = key.substr(eq + 1);
      key = key.substr(0, eq);
    } else if (flag_set.count(key)) {
      value = "1";
    } else if (i + 1 < argc) {
      value = argv[++i];
    } else {
      errors_.push_back("--" + key + " needs a value");
      continue;
    }
    values_[key] = value;
  }
}

std::optional<std::string> Args::get(const std::string& key) const {
  auto it = values_.find(key);
  if (it == values_.end()) return std::nullopt;
  return it->second;
}

std::string Args::getOr(const std::string& key, const std::string& fallback) const {
  auto v = get(key);
  return v ? *v : fallback;
}

std::optional<double> Args::getDouble(const std::string& key) {
  auto v = get(key);
  if (!v) return std::nullopt;
  char* end = nullptr;
  const double d = std::strtod(v->c_str(), &end);
  if (end == v->c_str() || *end != '\0' || !std::isfinite(d)) {
    errors_.push_back("--" + key + ": '" + *v + "' is not a finite number");
    return std::nullopt;
  }
  return d;
}

std::optional<long long> Args::getInt(const std::string& key) {
  auto v = get(key);
  if (!v) return std::nullopt;
  char* end = nullptr;
  const long long n = std::strtoll(v->c_str(), &end, 10);
  if (end == v->c_str() || *end != '\0') {
    errors_.push_back("--" + key + ": '" + *v + "' is not an integer");
    return std::nullopt;
  }
  return n;
}

std::optional<std::vector<double>> Args::getList(const std::string& key) {
  auto v = get(key);
  if (!v) return std::nullopt;
  std::vector<double> out;
  std::stringstream ss(*v);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const double d = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(d)) {
      errors_.push_back("--" + key + ": '" + item + "' is not a finite number");
      return std::nullopt;
    }
    out.push_back(d);
  }
  return out;
}

void Args::checkAllowed(const std::vector<std::string>& allowed) {
  const std::set<std::string> ok(allowed.begin(), allowed.end());
  for (const auto& kv : values_)
    if (!ok.count(kv.first)) errors_.push_back("unknown option --" + kv.first);
}

int usageError(const std::vector<std::string>& errors, const char* usage) {
  bool command_line = false;
  for (const auto& e : errors) {
    std::fprintf(stderr, "error: %s\n", e.c_str());
    command_line = command_line || e.find("--") != std::string::npos || e.rfind("unknown option", 0) == 0 ||
                   e.rfind("unexpected argument", 0) == 0 || e.rfind("expected", 0) == 0;
  }
  // A configuration file's errors stand alone; a command-line mistake gets the synopsis, not every option.
  if (command_line) {
    const std::string text(usage);
    std::fprintf(stderr, "%s (--help: every option)\n", text.substr(0, text.find('\n')).c_str());
  }
  return 2;
}

void applyLogLevel(const Args& args, std::vector<std::string>* errors) {
  const auto level = args.get("log-level");
  if (!level) return;
  log::Level l;
  if (log::parseLevel(*level, &l))
    log::setLevel(l);
  else
    errors->push_back("--log-level: unknown level '" + *level + "' (debug, info, warn or error)");
}

}  // namespace rgbdmap::cli
