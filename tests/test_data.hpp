#pragma once
// Locations of the real recordings shared beside the repository (../shared/data).
#include <filesystem>
#include <string>

namespace rgbdmap::testing {

inline std::string sharedDataDir(const std::string& name) {
  return std::string(RGBDMAP_SHARED_DATA_DIR) + "/" + name;
}

inline bool haveSharedData(const std::string& name) {
  return std::filesystem::is_directory(sharedDataDir(name));
}

}  // namespace rgbdmap::testing

/// Skip the current test with a message when a shared recording is absent.
#define RGBDMAP_REQUIRE_SHARED_DATA(name)                                                          \
  do {                                                                                             \
    if (!::rgbdmap::testing::haveSharedData(name))                                                 \
      GTEST_SKIP() << "shared recording '" << name << "' not found at " << RGBDMAP_SHARED_DATA_DIR \
                   << " (clone with ../shared beside the repository to run it)";                   \
  } while (0)
