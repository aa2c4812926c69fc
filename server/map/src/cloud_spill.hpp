#pragma once
// Kept keyframe clouds moved out of RAM (server memory proportional to the working set, not to the
// map's history). One anonymous file per OccupancyMap (O_TMPFILE in the spill directory: it has no name, so
// nothing can find it half written, and the kernel frees it when the map is destroyed, also after a crash).
// Clouds are appended as they are spilled and read back with pread, from any thread; the file is a cache of
// clouds that the server can make again from the stored keyframes, never state to recover.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/map/occupancy_map.hpp"

namespace rgbdmap::detail {

class CloudSpill {
 public:
  struct Ref {
    uint64_t offset = 0;
    uint64_t bytes = 0;  ///< 0: not spilled
  };
  /// Opens an anonymous file in `dir` (which must exist). Fails when the file system has no O_TMPFILE.
  static Result<std::unique_ptr<CloudSpill>> open(const std::string& dir);
  ~CloudSpill();
  CloudSpill(const CloudSpill&) = delete;
  CloudSpill& operator=(const CloudSpill&) = delete;

  /// Appends the cloud (exact floats and colours, a header and a checksum). Thread-safe.
  Result<Ref> write(const KeyframeCloud& cloud);
  /// Reads a cloud back; fails on a short read, a wrong keyframe id or a checksum mismatch. Thread-safe.
  Result<std::shared_ptr<const KeyframeCloud>> read(const Ref& ref, int64_t keyframe_id) const;
  uint64_t bytes() const { return end_.load(); }  ///< the file's size

 private:
  explicit CloudSpill(int fd) : fd_(fd) {}
  int fd_;
  std::mutex append_mutex_;
  std::atomic<uint64_t> end_{0};
};

}  // namespace rgbdmap::detail
