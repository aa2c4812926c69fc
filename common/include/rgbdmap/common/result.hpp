#pragma once
// A value or the reason there is none (C++17 stand-in for std::expected<T, std::string>).
#include <optional>
#include <string>
#include <utility>

namespace rgbdmap {

template <typename T>
class Result {
 public:
  Result(T value) : value_(std::move(value)) {}  // NOLINT(google-explicit-constructor)
  static Result failure(std::string reason) {
    Result r;
    r.error_ = std::move(reason);
    return r;
  }

  bool ok() const { return value_.has_value(); }
  explicit operator bool() const { return ok(); }
  const std::string& error() const { return error_; }

  T& value() & { return *value_; }
  const T& value() const& { return *value_; }
  T&& value() && { return std::move(*value_); }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }
  T& operator*() & { return *value_; }
  const T& operator*() const& { return *value_; }

 private:
  Result() = default;
  std::optional<T> value_;
  std::string error_;
};

/// Result for operations with no value: ok, or the reason they failed.
class Status {
 public:
  static Status success() { return Status(); }
  static Status failure(std::string reason) {
    Status s;
    s.error_ = std::move(reason);
    s.ok_ = false;
    return s;
  }
  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const std::string& error() const { return error_; }

 private:
  bool ok_ = true;
  std::string error_;
};

}  // namespace rgbdmap
