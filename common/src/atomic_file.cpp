#include "rgbdmap/common/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>

namespace rgbdmap {
namespace {

std::string systemError(const std::string& what, const std::string& path) {
  return path + ": " + what + ": " + std::strerror(errno);
}

/// Unique within the process too (two threads may write the same target): "<path>.tmp<pid>-<n>".
std::string temporaryNameFor(const std::string& path) {
  static std::atomic<unsigned long> counter{0};
  return path + ".tmp" + std::to_string(::getpid()) + "-" + std::to_string(counter.fetch_add(1));
}

Status writeAll(int fd, std::string_view bytes, const std::string& path) {
  for (size_t done = 0; done < bytes.size();) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return Status::failure(systemError("write failed", path));
    if (n == 0) return Status::failure(path + ": write failed: no progress");
    done += static_cast<size_t>(n);
  }
  return Status::success();
}

/// Writes, syncs (when asked) and closes the temporary file; every error is returned.
Status writeTemporary(const std::string& tmp, std::string_view bytes, bool sync) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Status::failure(systemError("cannot open for writing", tmp));
  Status s = writeAll(fd, bytes, tmp);
  if (s && sync && ::fsync(fd) != 0) s = Status::failure(systemError("fsync failed", tmp));
  if (::close(fd) != 0 && s) s = Status::failure(systemError("close failed", tmp));
  return s;
}

}  // namespace

std::string folderOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

Status syncFolder(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return Status::failure(systemError("cannot open folder", dir));
  Status s = Status::success();
  if (::fsync(fd) != 0) s = Status::failure(systemError("fsync of the folder failed", dir));
  ::close(fd);
  return s;
}

Status writeFileAtomic(const std::string& path, std::string_view bytes, AtomicWriteOptions options) {
  if (path.empty()) return Status::failure("empty file name");
  const std::string tmp = temporaryNameFor(path);
  Status s = writeTemporary(tmp, bytes, options.sync);
  if (s && std::rename(tmp.c_str(), path.c_str()) != 0)
    s = Status::failure("cannot rename " + tmp + " to " + path + ": " + std::strerror(errno));
  if (!s) {
    ::unlink(tmp.c_str());
    return s;
  }
  // The new file is in place; a failed folder sync means it may not survive power loss: say so.
  if (options.sync) return syncFolder(folderOf(path));
  return Status::success();
}

}  // namespace rgbdmap
