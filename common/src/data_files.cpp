#include "rgbdmap/common/data_files.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <system_error>

namespace rgbdmap {
namespace {

std::string executableFolder() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : exe.parent_path().string();
}

}  // namespace

std::vector<std::string> dataSearchPath(const std::string& installed_data_dir) {
  std::vector<std::string> folders;
  if (const char* dir = std::getenv("RGBDMAP_DATA_DIR"); dir && *dir) folders.emplace_back(dir);
  if (const std::string exe = executableFolder(); !exe.empty())
    folders.push_back((std::filesystem::path(exe).parent_path() / "share" / "rgbdmap").string());
  if (!installed_data_dir.empty()) folders.push_back(installed_data_dir);
  return folders;
}

Result<std::string> findDataFile(const std::string& relative, const std::string& installed_data_dir) {
  std::string looked;
  for (const std::string& folder : dataSearchPath(installed_data_dir)) {
    const std::string path = (std::filesystem::path(folder) / relative).lexically_normal().string();
    std::error_code ec;
    if (std::filesystem::is_regular_file(path, ec)) return path;
    looked += (looked.empty() ? "" : ", ") + path;
  }
  return Result<std::string>::failure(relative + " not found (looked in " + looked +
                                      "); set RGBDMAP_DATA_DIR to the folder that holds " + relative);
}

}  // namespace rgbdmap
