#include "atomic_file.hpp"

#include <filesystem>
#include <fstream>
#include <system_error>

#include "rgbdmap/common/atomic_file.hpp"

namespace rgbdmap::export_detail {

Status writeFileAtomically(const std::string& path, const std::string& bytes) {
  return writeFileAtomic(path, bytes);
}

Result<std::string> readWholeFile(const std::string& path, size_t max_bytes) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) return Result<std::string>::failure(path + ": cannot read (" + ec.message() + ")");
  if (size > max_bytes) return Result<std::string>::failure(path + ": file too large");
  std::ifstream in(path, std::ios::binary);
  if (!in) return Result<std::string>::failure(path + ": cannot open");
  std::string bytes(static_cast<size_t>(size), '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (static_cast<size_t>(in.gcount()) != bytes.size())
    return Result<std::string>::failure(path + ": short read");
  return bytes;
}

}  // namespace rgbdmap::export_detail
