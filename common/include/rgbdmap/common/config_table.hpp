#pragma once
// One table per configuration struct: for every value its YAML key, the member that holds it, its range
// (or allowed names) and what it means. The same table
//   - reads the YAML file through ConfigReader (range checked, every error collected),
//   - checks a struct built in code (the struct's validate() calls problems()),
//   - renders the documented example file (deploy/config/*.yaml; a test keeps the files equal to it),
//   - lists the values in effect for the one start-up log block of every program.
// So a range is written once. Checks between values (min < max) stay in validate() and the readers.
// Tables of nested structs are composed with nest(); a field marked codeOnly() is checked but neither read
// from files nor documented. No yaml-cpp here: libraries may define their tables.
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "rgbdmap/common/config_range.hpp"
#include "rgbdmap/common/config_reader.hpp"

namespace rgbdmap {

/// One value (or a section's note) as documented and logged.
struct ConfigValue {
  std::string key;      ///< dotted YAML key
  std::string value;    ///< its text ("" for a section note)
  std::string allowed;  ///< "[0, 1]", "jpeg | lossless | none", or "" (any text, true | false)
  std::string meaning;
  bool quoted = false;   ///< text value: written in double quotes in YAML
  bool section = false;  ///< a note on the section `key`, not a value
};

template <typename S>
struct ConfigField {
  std::string key;
  std::string meaning;
  std::string allowed;
  std::string complaint;  ///< why an invalid value is wrong: "is outside [0, 1]"
  bool in_files = true;   ///< false: set by code only (checked, not read, not documented)
  bool quoted = false;
  /// Empty for a section note.
  std::function<void(ConfigReader&, const std::string& key, S&)> read;
  std::function<std::string(const S&)> show;
  std::function<bool(const S&)> valid;
};

namespace config_detail {
template <typename T>
struct Number {  // int, unsigned, size_t, long long, float, double: read as themselves
  using Stored = T;
  static Stored get(T v) { return v; }
  static T make(Stored v) { return v; }
};
template <typename Rep, typename Period>
struct Number<std::chrono::duration<Rep, Period>> {  // a duration: its count in its own unit
  using Stored = long long;
  static Stored get(std::chrono::duration<Rep, Period> v) { return static_cast<long long>(v.count()); }
  static std::chrono::duration<Rep, Period> make(Stored v) { return std::chrono::duration<Rep, Period>(v); }
};
std::string show(double v);
std::string show(float v);
std::string show(long long v);
std::string show(unsigned long long v);
template <typename T>
std::string showNumber(T v) {
  if constexpr (std::is_floating_point_v<T>)
    return show(v);
  else if constexpr (std::is_signed_v<T>)
    return show(static_cast<long long>(v));
  else
    return show(static_cast<unsigned long long>(v));
}
std::string joinChoices(const std::vector<std::string>& names);
std::string joinList(const std::vector<std::string>& items);  ///< "a,b,c"
std::vector<std::string> splitList(const std::string& text);
}  // namespace config_detail

template <typename S>
class ConfigTable {
 public:
  using Field = ConfigField<S>;

  /// A number: int, unsigned, size_t, long long, float, double or a std::chrono::duration (its count).
  template <typename T>
  ConfigTable& add(const std::string& key, T S::*member, const ConfigRange& range,
                   const std::string& meaning) {
    using N = config_detail::Number<T>;
    Field f = make(key, meaning, range.str(), "is outside " + range.str(), false);
    f.read = [member, range](ConfigReader& r, const std::string& k, S& s) {
      typename N::Stored v = N::get(s.*member);
      r.read(k, &v, range);
      s.*member = N::make(v);
    };
    f.show = [member](const S& s) { return config_detail::showNumber(N::get(s.*member)); };
    f.valid = [member, range](const S& s) { return range.contains(N::get(s.*member)); };
    return push(std::move(f));
  }
  ConfigTable& add(const std::string& key, bool S::*member, const std::string& meaning) {
    Field f = make(key, meaning, "", "", false);
    f.read = [member](ConfigReader& r, const std::string& k, S& s) { r.read(k, &(s.*member)); };
    f.show = [member](const S& s) { return std::string(s.*member ? "true" : "false"); };
    f.valid = [](const S&) { return true; };
    return push(std::move(f));
  }
  /// Text, optionally one of `choices`.
  ConfigTable& add(const std::string& key, std::string S::*member, const std::string& meaning,
                   const std::vector<std::string>& choices = {}) {
    const std::string allowed = config_detail::joinChoices(choices);
    Field f = make(key, meaning, allowed, "is not one of " + allowed, true);
    f.read = [member, choices](ConfigReader& r, const std::string& k, S& s) {
      r.read(k, &(s.*member), choices);
    };
    f.show = [member](const S& s) { return s.*member; };
    f.valid = [member, choices](const S& s) {
      for (const std::string& c : choices)
        if (c == s.*member) return true;
      return choices.empty();
    };
    return push(std::move(f));
  }
  /// A list of names, written as one comma-separated text ("robot0,robot1").
  ConfigTable& add(const std::string& key, std::vector<std::string> S::*member, const std::string& meaning) {
    Field f = make(key, meaning, "", "", true);
    f.read = [member](ConfigReader& r, const std::string& k, S& s) {
      std::string text = config_detail::joinList(s.*member);
      r.read(k, &text);
      s.*member = config_detail::splitList(text);
    };
    f.show = [member](const S& s) { return config_detail::joinList(s.*member); };
    f.valid = [](const S&) { return true; };
    return push(std::move(f));
  }
  /// A fixed-length list of finite numbers ([k1, k2, p1, p2, k3]).
  template <size_t N>
  ConfigTable& add(const std::string& key, std::array<double, N> S::*member, const std::string& meaning) {
    Field f = make(key, meaning, "", "is not a list of " + std::to_string(N) + " finite numbers", false);
    f.read = [member](ConfigReader& r, const std::string& k, S& s) { r.readList(k, (s.*member).data(), N); };
    f.show = [member](const S& s) {
      std::string out;
      for (double v : s.*member) out += (out.empty() ? "[" : ", ") + config_detail::show(v);
      return out + "]";
    };
    f.valid = [member](const S& s) {
      for (double v : s.*member)
        if (!std::isfinite(v)) return false;
      return true;
    };
    return push(std::move(f));
  }
  /// An enum written as one of its names.
  template <typename E>
  ConfigTable& addChoice(const std::string& key, E S::*member,
                         const std::vector<std::pair<E, std::string>>& names, const std::string& meaning) {
    std::vector<std::string> choices;
    for (const auto& n : names) choices.push_back(n.second);
    const std::string allowed = config_detail::joinChoices(choices);
    Field f = make(key, meaning, allowed, "is not one of " + allowed, false);
    const auto name_of = [names](E e) {
      for (const auto& n : names)
        if (n.first == e) return n.second;
      return std::string("?");
    };
    f.read = [member, names, choices, name_of](ConfigReader& r, const std::string& k, S& s) {
      std::string text = name_of(s.*member);
      r.read(k, &text, choices);
      for (const auto& n : names)
        if (n.second == text) s.*member = n.first;
    };
    f.show = [member, name_of](const S& s) { return name_of(s.*member); };
    f.valid = [member, name_of](const S& s) { return name_of(s.*member) != "?"; };
    return push(std::move(f));
  }
  /// Every field of `sub` (a table of the member's type), its keys prefixed with `prefix` ("loop."). With
  /// in_files false they are all code-only.
  template <typename M>
  ConfigTable& nest(const std::string& prefix, M S::*member, const ConfigTable<M>& sub,
                    bool in_files = true) {
    for (const ConfigField<M>& m : sub.fields()) {
      Field f = make(prefix + m.key, m.meaning, m.allowed, m.complaint, m.quoted);
      f.in_files = m.in_files && in_files;
      if (m.read)
        f.read = [member, read = m.read](ConfigReader& r, const std::string& k, S& s) {
          read(r, k, s.*member);
        };
      if (m.show) f.show = [member, show = m.show](const S& s) { return show(s.*member); };
      if (m.valid) f.valid = [member, valid = m.valid](const S& s) { return valid(s.*member); };
      fields_.push_back(std::move(f));
    }
    return *this;
  }
  /// Every field of `other` (a table of the same struct), in its order.
  ConfigTable& append(const ConfigTable& other) {
    fields_.insert(fields_.end(), other.fields_.begin(), other.fields_.end());
    return *this;
  }
  /// A note on a section of the documented file (`key` without a value, e.g. "loop").
  ConfigTable& section(const std::string& key, const std::string& meaning) {
    return push(make(key, meaning, "", "", false));
  }
  /// The field added last is set by code only: checked by problems(), not read, not documented or logged.
  ConfigTable& codeOnly() {
    fields_.back().in_files = false;
    return *this;
  }

  const std::vector<Field>& fields() const { return fields_; }

  /// Reads every file key (under `prefix`, e.g. "odometry.") present in the reader into *config; absent
  /// keys keep their values.
  void read(ConfigReader& reader, S* config, const std::string& prefix = "") const {
    for (const Field& f : fields_)
      if (f.in_files && f.read) f.read(reader, prefix + f.key, *config);
  }
  /// One "key = value is outside [a, b]" per value out of its range (code-only fields included).
  std::vector<std::string> problems(const S& config) const {
    std::vector<std::string> out;
    for (const Field& f : fields_)
      if (f.valid && !f.valid(config)) out.push_back(f.key + " = " + f.show(config) + " " + f.complaint);
    return out;
  }
  /// The file keys with their values in `config` (and the section notes), in table order.
  std::vector<ConfigValue> values(const S& config, const std::string& prefix = "") const {
    std::vector<ConfigValue> out;
    for (const Field& f : fields_) {
      if (!f.in_files) continue;
      if (!f.show)
        out.push_back({prefix + f.key, "", "", f.meaning, false, true});
      else
        out.push_back({prefix + f.key, f.show(config), f.allowed, f.meaning, f.quoted, false});
    }
    return out;
  }

 private:
  static Field make(const std::string& key, const std::string& meaning, const std::string& allowed,
                    const std::string& complaint, bool quoted) {
    Field f;
    f.key = key;
    f.meaning = meaning;
    f.allowed = allowed;
    f.complaint = complaint;
    f.quoted = quoted;
    return f;
  }
  ConfigTable& push(Field f) {
    fields_.push_back(std::move(f));
    return *this;
  }
  std::vector<Field> fields_;
};

/// Problems "; "-separated ("" when there are none), as the structs' validate() return them.
std::string joinProblems(const std::vector<std::string>& problems);

/// The documented YAML file: `header` as comment lines, then every value under its sections, each with
/// "# [range] meaning" (multi-line meanings continue on aligned comment lines).
std::string renderConfigYaml(const std::string& header, const std::vector<ConfigValue>& values);

/// One compact block for the start-up log: a line per section, "section: key = value, key = value".
std::string formatConfigValues(const std::vector<ConfigValue>& values);

/// a followed by b.
std::vector<ConfigValue> concatConfigValues(std::vector<ConfigValue> a, const std::vector<ConfigValue>& b);

/// Logs the configuration under `title`: at info one line naming the values that differ from `defaults`
/// (the same keys for the default structs; the first 10 named, the rest counted), and every value
/// (formatConfigValues) at debug level.
void logConfiguration(const std::string& title, const std::vector<ConfigValue>& values,
                      const std::vector<ConfigValue>& defaults);

}  // namespace rgbdmap
