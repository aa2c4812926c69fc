#include "store_files.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/store/map_store.hpp"

namespace rgbdmap::store {
namespace fs = std::filesystem;
namespace {

constexpr const char* kManifestFirstLine = "rgbdmap map store";

std::string manifestText() {
  std::ostringstream os;
  os << kManifestFirstLine << "\nformat_version " << kMapStoreFormatVersion << "\nmessage_schema_version "
     << msg::kSchemaVersion << "\n";
  return os.str();
}

Status writeManifest(const std::string& dir) {
  const std::string tmp = dir + "/MANIFEST.tmp", path = dir + "/MANIFEST";
  UniqueFd fd(::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (fd.get() < 0) return Status::failure(systemError("cannot create", tmp));
  const std::string text = manifestText();
  if (Status s = writeAt(fd.get(), text.data(), text.size(), 0, tmp); !s) return s;
  if (::fsync(fd.get()) != 0) return Status::failure(systemError("cannot fsync", tmp));
  if (::rename(tmp.c_str(), path.c_str()) != 0) return Status::failure(systemError("cannot rename", tmp));
  return syncDirectory(dir);
}

/// Reads "key value" lines after the first; fails with a clear message on anything unexpected.
Status checkManifest(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line) || line != kManifestFirstLine)
    return Status::failure("'" + path + "' is not a map store manifest (first line must be '" +
                           kManifestFirstLine + "')");
  int format = -1, schema = -1;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string key;
    int value = 0;
    if (!(fields >> key >> value)) continue;
    if (key == "format_version") format = value;
    if (key == "message_schema_version") schema = value;
  }
  if (format != kMapStoreFormatVersion)
    return Status::failure("map store '" + path + "' has format version " + std::to_string(format) +
                           "; this build reads format version " + std::to_string(kMapStoreFormatVersion) +
                           " only");
  if (!msg::isReadableStoredSchema(schema))
    return Status::failure("map store '" + path + "' holds messages of schema version " +
                           std::to_string(schema) + "; this build decodes schema versions " +
                           msg::readableStoredSchemas());
  return Status::success();
}

}  // namespace

UniqueFd::~UniqueFd() {
  if (fd_ >= 0) ::close(fd_);
}

UniqueFd& UniqueFd::operator=(UniqueFd&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.release();
  }
  return *this;
}

std::string systemError(const std::string& what, const std::string& path) {
  return what + " '" + path + "': " + std::strerror(errno);
}

Status makeDirectory(const std::string& dir) {
  std::error_code ec;
  if (fs::is_directory(dir, ec)) return Status::success();
  if (fs::exists(dir, ec)) return Status::failure("'" + dir + "' exists and is not a directory");
  const fs::path path = fs::absolute(dir, ec);
  if (ec) return Status::failure("cannot resolve '" + dir + "': " + ec.message());
  if (Status s = makeDirectory(path.parent_path().string()); !s) return s;
  if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST)
    return Status::failure(systemError("cannot create directory", dir));
  return syncDirectory(path.parent_path().string());
}

Status syncDirectory(const std::string& dir) {
  UniqueFd fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (fd.get() < 0) return Status::failure(systemError("cannot open directory", dir));
  if (::fsync(fd.get()) != 0) return Status::failure(systemError("cannot fsync directory", dir));
  return Status::success();
}

Result<UniqueFd> lockDirectory(const std::string& dir) {
  const std::string path = dir + "/LOCK";
  UniqueFd fd(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644));
  if (fd.get() < 0) return Result<UniqueFd>::failure(systemError("cannot open lock file", path));
  if (::flock(fd.get(), LOCK_EX | LOCK_NB) != 0) {
    if (errno == EWOULDBLOCK)
      return Result<UniqueFd>::failure("map directory '" + dir +
                                       "' is in use: another map store holds its LOCK file");
    return Result<UniqueFd>::failure(systemError("cannot lock", path));
  }
  return fd;
}

Status checkOrCreateManifest(const std::string& dir, const std::string& log_name) {
  const std::string path = dir + "/MANIFEST";
  std::error_code ec;
  if (fs::exists(path, ec)) return checkManifest(path);
  if (fs::exists(dir + "/" + log_name, ec))
    return Status::failure("map directory '" + dir + "' has '" + log_name +
                           "' but no MANIFEST: not a map store of this format (refusing to guess)");
  return writeManifest(dir);
}

Result<UniqueFd> openLog(const std::string& dir, const std::string& name) {
  const std::string path = dir + "/" + name;
  UniqueFd fd(::open(path.c_str(), O_RDWR | O_CLOEXEC));
  if (fd.get() >= 0) return fd;
  if (errno != ENOENT) return Result<UniqueFd>::failure(systemError("cannot open", path));
  fd = UniqueFd(::open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0644));
  if (fd.get() < 0) return Result<UniqueFd>::failure(systemError("cannot create", path));
  if (Status s = syncDirectory(dir); !s) return Result<UniqueFd>::failure(s.error());
  return fd;
}

Result<int64_t> fileSize(int fd, const std::string& path) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return Result<int64_t>::failure(systemError("cannot stat", path));
  return static_cast<int64_t>(st.st_size);
}

Status readAt(int fd, void* data, size_t size, int64_t offset, const std::string& path) {
  auto* p = static_cast<uint8_t*>(data);
  while (size > 0) {
    const ssize_t n = ::pread(fd, p, size, offset);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return Status::failure(systemError("cannot read", path));
    if (n == 0) return Status::failure("unexpected end of '" + path + "'");
    p += n;
    size -= static_cast<size_t>(n);
    offset += n;
  }
  return Status::success();
}

Status writeAt(int fd, const void* data, size_t size, int64_t offset, const std::string& path) {
  const auto* p = static_cast<const uint8_t*>(data);
  while (size > 0) {
    const ssize_t n = ::pwrite(fd, p, size, offset);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return Status::failure(systemError("cannot write", path));
    p += n;
    size -= static_cast<size_t>(n);
    offset += n;
  }
  return Status::success();
}

Status truncateTo(int fd, int64_t size, const std::string& path) {
  if (::ftruncate(fd, size) != 0) return Status::failure(systemError("cannot truncate", path));
  return Status::success();
}

Status syncData(int fd, const std::string& path) {
  if (::fdatasync(fd) != 0) return Status::failure(systemError("cannot fdatasync", path));
  return Status::success();
}

}  // namespace rgbdmap::store
