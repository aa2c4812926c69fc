#include "rgbdmap/common/text_lines.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "rgbdmap/common/atomic_file.hpp"

namespace rgbdmap {

std::vector<TextLine> dataLines(const std::string& text) {
  std::vector<TextLine> out;
  std::istringstream in(text);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    TextLine tl;
    tl.number = number;
    std::istringstream ls(line);
    for (std::string token; ls >> token;) tl.fields.push_back(token);
    out.push_back(std::move(tl));
  }
  return out;
}

Result<double> parseFiniteNumber(const std::string& token, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (token.empty() || end == token.c_str() || *end != '\0')
    return Result<double>::failure((what.empty() ? "" : what + " ") + "'" + token + "' is not a number");
  if (!std::isfinite(v))
    return Result<double>::failure(what.empty() ? "non-finite value" : what + " is not finite");
  return v;
}

std::string formatShort(double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", value);
  return buf;
}

std::string formatExact(double value) {
  char buf[64];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, value);
    if (std::strtod(buf, nullptr) == value) break;
  }
  return buf;
}

std::string formatTimestamp(double seconds) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6f", seconds);
  return buf;
}

Result<std::string> readTextFile(const std::string& path) {
  std::ifstream f(path);
  if (!f) return Result<std::string>::failure(path + ": cannot open");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

Status writeTextFileAtomic(const std::string& path, const std::string& text) {
  return writeFileAtomic(path, text);
}

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(text);
  while (std::getline(in, item, ',')) {
    const size_t b = item.find_first_not_of(" \t");
    const size_t e = item.find_last_not_of(" \t");
    if (b != std::string::npos) out.push_back(item.substr(b, e - b + 1));
  }
  return out;
}

}  // namespace rgbdmap
