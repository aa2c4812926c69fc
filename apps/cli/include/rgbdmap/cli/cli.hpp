#pragma once
// Small command-line helpers shared by the rgbdmap subcommands (apps only; libraries never parse argv).
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace rgbdmap::cli {

/// Parsed `--key value` / `--flag` arguments. Unknown keys are reported by checkAllowed().
class Args {
 public:
  /// `flags` lists the options that take no value.
  Args(int argc, char** argv, const std::vector<std::string>& flags = {});

  bool has(const std::string& key) const { return values_.count(key) > 0; }
  std::optional<std::string> get(const std::string& key) const;
  std::string getOr(const std::string& key, const std::string& fallback) const;
  /// Parse a number; records an error (see errors()) when present but malformed.
  std::optional<double> getDouble(const std::string& key);
  std::optional<long long> getInt(const std::string& key);
  /// Comma-separated numbers, e.g. --intrinsics fx,fy,cx,cy.
  std::optional<std::vector<double>> getList(const std::string& key);

  /// Records an error for each option not in `allowed`.
  void checkAllowed(const std::vector<std::string>& allowed);
  void addError(const std::string& e) { errors_.push_back(e); }
  const std::vector<std::string>& errors() const { return errors_; }
  const std::vector<std::string>& positional() const { return positional_; }

 private:
  std::map<std::string, std::string> values_;
  std::vector<std::string> positional_;
  std::vector<std::string> errors_;
};

/// --log-level debug|info|warn|error, when given, set as the log level; a bad value appended to *errors.
void applyLogLevel(const Args& args, std::vector<std::string>* errors);

/// Prints all errors (one per line) to stderr and, when one is about the command line, the usage text's
/// first line (the synopsis); returns exit code 2.
int usageError(const std::vector<std::string>& errors, const char* usage);

}  // namespace rgbdmap::cli
