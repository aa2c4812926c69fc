// The OpenNI2 source builds and links; without a device it reports one clear reason naming what it tried.
#include <gtest/gtest.h>

#include "rgbdmap/source/frame_source.hpp"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
// OpenNI2 2.2 leaks ~2 KB per initialise in the driver plugins it loads and unloads (allocations from
// "<unknown module>"): not this code's; the leak checker ignores what is allocated while opening.
using OpenNiLeakScope = __lsan::ScopedDisabler;
#else
struct OpenNiLeakScope {};
#endif

namespace rgbdmap {
namespace {

TEST(OpenNi2Source, WithoutADeviceSaysWhatItTried) {
  auto url = SourceUrl::parse("openni2:");
  ASSERT_TRUE(url);
  [[maybe_unused]] const OpenNiLeakScope leak_scope;
  auto source = openFrameSource(*url, {});
  if (source) GTEST_SKIP() << "an OpenNI2 device is attached: " << (*source)->describe();
  const std::string& e = source.error();
  EXPECT_EQ(e.rfind("openni2:", 0), 0u) << e;
  EXPECT_NE(e.find("OpenNI2 2."), std::string::npos) << e;  // the library and its drivers
  EXPECT_NE(e.find("PS1080"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << "one line: " << e;
}

TEST(OpenNi2Source, ANamedDeviceThatIsNotThereIsNamed) {
  auto url = SourceUrl::parse("openni2:/nonexistent/device.oni");
  ASSERT_TRUE(url);
  [[maybe_unused]] const OpenNiLeakScope leak_scope;
  auto source = openFrameSource(*url, {});
  ASSERT_FALSE(source);
  EXPECT_NE(source.error().find("cannot open '/nonexistent/device.oni'"), std::string::npos)
      << source.error();
  EXPECT_EQ(source.error().find('\n'), std::string::npos) << source.error();
}

}  // namespace
}  // namespace rgbdmap
