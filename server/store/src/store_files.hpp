#pragma once
// Internal: POSIX file handling of the map store (directory, LOCK, MANIFEST, whole reads and writes,
// durability). Every failure is a Status naming the path and the system error.
#include <cstddef>
#include <cstdint>
#include <string>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap::store {

/// Owns a file descriptor; closes it on destruction.
class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  ~UniqueFd();
  UniqueFd(UniqueFd&& other) noexcept : fd_(other.release()) {}
  UniqueFd& operator=(UniqueFd&& other) noexcept;
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;
  int get() const { return fd_; }
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_ = -1;
};

/// "what 'path': strerror(errno)".
std::string systemError(const std::string& what, const std::string& path);

/// Creates `dir` (and missing parents, each made durable in its parent) unless it exists as a directory.
Status makeDirectory(const std::string& dir);
/// fsync of a directory, so that entries created or renamed in it survive a crash.
Status syncDirectory(const std::string& dir);
/// Opens (creating if missing) <dir>/LOCK and takes an exclusive, non-blocking flock on it.
Result<UniqueFd> lockDirectory(const std::string& dir);
/// Checks <dir>/MANIFEST; writes it (atomically: temporary file, fsync, rename, fsync dir) when missing
/// and the directory holds no log yet. Fails on another format or message schema version.
Status checkOrCreateManifest(const std::string& dir, const std::string& log_name);
/// Opens a log file read/write, creating it (and syncing the directory) when missing.
Result<UniqueFd> openLog(const std::string& dir, const std::string& name);

Result<int64_t> fileSize(int fd, const std::string& path);
/// pread/pwrite of exactly `size` bytes (retrying on short transfers and EINTR).
Status readAt(int fd, void* data, size_t size, int64_t offset, const std::string& path);
Status writeAt(int fd, const void* data, size_t size, int64_t offset, const std::string& path);
Status truncateTo(int fd, int64_t size, const std::string& path);
Status syncData(int fd, const std::string& path);

}  // namespace rgbdmap::store
