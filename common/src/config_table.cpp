#include "rgbdmap/common/config_table.hpp"

#include <algorithm>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/text_lines.hpp"

namespace rgbdmap {

bool ConfigRange::within(double v, double lo, double hi) const {
  if (!std::isfinite(v)) return false;
  const bool above_min = min_open ? v > lo : v >= lo;
  const bool below_max = max_open ? v < hi : v <= hi;
  return above_min && below_max;
}

std::string ConfigRange::str() const {
  const auto end = [](double v) {
    if (std::isinf(v)) return std::string(v < 0 ? "-inf" : "inf");
    return formatConfigNumber(v);
  };
  return std::string(min_open ? "(" : "[") + end(min) + ", " + end(max) + (max_open ? ")" : "]");
}

std::string formatConfigNumber(double v) {
  std::ostringstream os;
  os << std::setprecision(10) << v;
  return os.str();
}

namespace config_detail {

std::string show(double v) { return formatConfigNumber(v); }
std::string show(float v) {
  std::ostringstream os;
  os << std::setprecision(std::numeric_limits<float>::digits10) << v;
  return os.str();
}
std::string show(long long v) { return std::to_string(v); }
std::string show(unsigned long long v) { return std::to_string(v); }

std::string joinChoices(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : " | ") + n;
  return out;
}

std::string joinList(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) out += (out.empty() ? "" : ",") + s;
  return out;
}

std::vector<std::string> splitList(const std::string& text) { return rgbdmap::splitList(text); }

}  // namespace config_detail

std::string joinProblems(const std::vector<std::string>& problems) {
  std::string out;
  for (const std::string& p : problems) out += (out.empty() ? "" : "; ") + p;
  return out;
}

namespace {

// A section of the documented file: its values and subsections in first-appearance order.
struct Section {
  std::string name;
  const ConfigValue* note = nullptr;
  const ConfigValue* value = nullptr;  // a leaf
  std::vector<Section> children;

  Section& child(const std::string& n) {
    for (Section& c : children)
      if (c.name == n) return c;
    children.push_back(Section{n, nullptr, nullptr, {}});
    return children.back();
  }
};

constexpr size_t kCommentColumn = 26;
constexpr size_t kLineWidth = 110;

// `text` split at spaces into lines of at most `first_width` (the first) and `width` characters (a longer
// word keeps its own line); '\n' starts a new line.
std::vector<std::string> wrap(const std::string& text, size_t first_width, size_t width) {
  std::vector<std::string> lines;
  std::istringstream paragraphs(text);
  std::string paragraph;
  while (std::getline(paragraphs, paragraph)) {
    std::istringstream words(paragraph);
    std::string word, line;
    while (words >> word) {
      if (!line.empty() && line.size() + 1 + word.size() > (lines.empty() ? first_width : width)) {
        lines.push_back(line);
        line.clear();
      }
      line += (line.empty() ? "" : " ") + word;
    }
    lines.push_back(line);
  }
  return lines;
}

// `line`, then the comment "allowed meaning" at the comment column, continued on aligned lines.
void writeWithComment(std::ostringstream& out, const std::string& line, const std::string& allowed,
                      const std::string& meaning) {
  std::string comment = allowed;
  if (!meaning.empty()) comment += (comment.empty() ? "" : " ") + meaning;
  out << line;
  if (comment.empty()) {
    out << "\n";
    return;
  }
  const size_t column = std::max(kCommentColumn, line.size() + 2);
  const size_t first_width = std::max<size_t>(kLineWidth, column + 32) - column - 2;
  bool first = true;
  for (const std::string& part : wrap(comment, first_width, kLineWidth - kCommentColumn - 2)) {
    out << std::string(first ? column - line.size() : kCommentColumn, ' ') << "# " << part << "\n";
    first = false;
  }
}

void writeSection(std::ostringstream& out, const Section& s, int depth) {
  const std::string indent(static_cast<size_t>(2 * depth), ' ');
  if (s.value) {
    const ConfigValue& v = *s.value;
    const std::string text = v.quoted ? "\"" + v.value + "\"" : v.value;
    writeWithComment(out, indent + s.name + ": " + text, v.allowed, v.meaning);
    return;
  }
  writeWithComment(out, indent + s.name + ":", "", s.note ? s.note->meaning : "");
  for (const Section& c : s.children) writeSection(out, c, depth + 1);
}

}  // namespace

std::string renderConfigYaml(const std::string& header, const std::vector<ConfigValue>& values) {
  Section root;
  for (const ConfigValue& v : values) {
    Section* s = &root;
    std::istringstream parts(v.key);
    std::string part;
    while (std::getline(parts, part, '.')) s = &s->child(part);
    (v.section ? s->note : s->value) = &v;
  }
  std::ostringstream out;
  std::istringstream lines(header);
  std::string line;
  while (std::getline(lines, line)) out << (line.empty() ? "#" : "# " + line) << "\n";
  for (const Section& top : root.children) {
    out << "\n";
    writeSection(out, top, 0);
  }
  return out.str();
}

std::string formatConfigValues(const std::vector<ConfigValue>& values) {
  std::vector<std::pair<std::string, std::string>> sections;  // section -> "k = v, ..." in first-seen order
  for (const ConfigValue& v : values) {
    if (v.section) continue;
    const size_t dot = v.key.rfind('.');
    const std::string section = dot == std::string::npos ? "" : v.key.substr(0, dot);
    const std::string item = (dot == std::string::npos ? v.key : v.key.substr(dot + 1)) + " = " +
                             (v.quoted ? "\"" + v.value + "\"" : v.value);
    auto it =
        std::find_if(sections.begin(), sections.end(), [&](const auto& s) { return s.first == section; });
    if (it == sections.end())
      sections.emplace_back(section, item);
    else
      it->second += ", " + item;
  }
  std::string out;
  for (const auto& [section, items] : sections)
    out += "  " + (section.empty() ? "" : section + ": ") + items + "\n";
  return out;
}

std::vector<ConfigValue> concatConfigValues(std::vector<ConfigValue> a, const std::vector<ConfigValue>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

void logConfiguration(const std::string& title, const std::vector<ConfigValue>& values,
                      const std::vector<ConfigValue>& defaults) {
  constexpr size_t kNamed = 10;
  std::map<std::string, std::string> default_of;
  for (const ConfigValue& d : defaults)
    if (!d.section) default_of[d.key] = d.value;
  std::vector<std::string> changed;
  size_t settings = 0;
  for (const ConfigValue& v : values) {
    if (v.section) continue;
    ++settings;
    const auto it = default_of.find(v.key);
    if (it == default_of.end() || it->second != v.value)
      changed.push_back(v.key + " = " + (v.quoted ? "\"" + v.value + "\"" : v.value));
  }
  std::string line = title + ": " + std::to_string(settings) + " settings, ";
  if (changed.empty()) {
    line += "all at their defaults";
  } else {
    line += std::to_string(changed.size()) + " not at their defaults: ";
    for (size_t i = 0; i < changed.size() && i < kNamed; ++i) line += (i ? ", " : "") + changed[i];
    if (changed.size() > kNamed) line += " and " + std::to_string(changed.size() - kNamed) + " more";
  }
  log::info(line, " (every value: --log-level debug)");
  std::string block = formatConfigValues(values);
  if (!block.empty()) block.pop_back();  // the logger ends the line
  log::debug(title, ":\n", block);
}

}  // namespace rgbdmap
