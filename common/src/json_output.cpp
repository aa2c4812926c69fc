#include "rgbdmap/common/json_output.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "rgbdmap/common/text_lines.hpp"

namespace rgbdmap {
namespace {

/// printf %g with the fewest digits that read back as the same double (whole numbers below 1e6 in full).
std::string shortestNumber(double value) {
  if (!std::isfinite(value)) return "null";
  char buf[40];
  if (std::fabs(value) < 1e6 && std::nearbyint(value) == value) {
    std::snprintf(buf, sizeof buf, "%.0f", value);
    return buf;
  }
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, value);
    if (std::strtod(buf, nullptr) == value) break;
  }
  return buf;
}

std::string scalar(const Json& value) {
  if (value.is_number_float()) return shortestNumber(value.get<double>());
  // Invalid UTF-8 (e.g. in a path) is replaced rather than thrown on.
  return value.dump(-1, ' ', false, Json::error_handler_t::replace);
}

bool containsObject(const Json& value) {
  if (value.is_object()) return true;
  return value.is_array() && std::any_of(value.begin(), value.end(), containsObject);
}

bool fitsOnOneLine(const Json& value) {
  if (value.is_object())
    return std::none_of(value.begin(), value.end(), [](const Json& v) { return v.is_structured(); });
  return !containsObject(value);
}

struct Layout {
  const char* separator;  ///< between members
  const char* colon;      ///< between key and value
};

void writeLine(const Json& value, const Layout& layout, std::string* out) {
  if (!value.is_structured()) {
    *out += scalar(value);
    return;
  }
  const bool object = value.is_object();
  *out += object ? '{' : '[';
  for (auto it = value.begin(); it != value.end(); ++it) {
    if (it != value.begin()) *out += layout.separator;
    if (object) *out += scalar(Json(it.key())) + layout.colon;
    writeLine(*it, layout, out);
  }
  *out += object ? '}' : ']';
}

void writeBlock(const Json& value, int indent, std::string* out) {
  if (!value.is_structured() || value.empty() || (indent > 0 && fitsOnOneLine(value))) {
    writeLine(value, {", ", ": "}, out);
    return;
  }
  const bool object = value.is_object();
  const std::string pad(static_cast<size_t>(indent) + 2, ' ');
  *out += object ? "{\n" : "[\n";
  for (auto it = value.begin(); it != value.end(); ++it) {
    if (it != value.begin()) *out += ",\n";
    *out += pad;
    if (object) *out += scalar(Json(it.key())) + ": ";
    writeBlock(*it, indent + 2, out);
  }
  *out += "\n" + std::string(static_cast<size_t>(indent), ' ') + (object ? "}" : "]");
}

}  // namespace

Json jsonNumber(double value, int digits) {
  if (!std::isfinite(value)) return nullptr;
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, value);
  const double rounded = std::strtod(buf, nullptr);
  // printf shows whole numbers below 10^digits in full ("60"), larger ones with an exponent ("1.23457e+06").
  if (std::nearbyint(rounded) == rounded && std::fabs(rounded) < std::pow(10.0, digits))
    return static_cast<int64_t>(rounded);
  return rounded;
}

std::string formatJson(const Json& value) {
  std::string out;
  writeBlock(value, 0, &out);
  return out + "\n";
}

std::string compactJson(const Json& value) {
  std::string out;
  writeLine(value, {",", ":"}, &out);
  return out;
}

Status writeJsonFile(const std::string& path, const Json& value) {
  return writeTextFileAtomic(path, formatJson(value));
}

}  // namespace rgbdmap
