#include "rgbdmap/common/text_lines.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fcntl.h>
#include <unistd.h>

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

Result<std::string> readTextFile(const std::string& path) {
  std::ifstream f(path);
  if (!f) return Result<std::string>::failure(path + ": cannot open");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

namespace {

Status writeAll(int fd, const std::string& text, const std::string& path) {
  for (size_t done = 0; done < text.size();) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return Status::failure(path + ": write failed: " + std::strerror(errno));
    done += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) return Status::failure(path + ": fsync failed: " + std::strerror(errno));
  return Status::success();
}

void syncFolderOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  (void)::fsync(fd);
  ::close(fd);
}

}  // namespace

Status writeTextFileAtomic(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp" + std::to_string(::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Status::failure(tmp + ": cannot open for writing: " + std::strerror(errno));
  Status written = writeAll(fd, text, tmp);
  if (::close(fd) != 0 && written) written = Status::failure(tmp + ": close failed: " + std::strerror(errno));
  if (written && std::rename(tmp.c_str(), path.c_str()) != 0)
    written = Status::failure("cannot rename " + tmp + " to " + path + ": " + std::strerror(errno));
  if (!written) {
    ::unlink(tmp.c_str());
    return written;
  }
  syncFolderOf(path);
  return Status::success();
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
