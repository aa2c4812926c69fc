// MemoryTrim (rgbdmap_server, private): freed heap goes back to the kernel. Without it, memory freed in
// the middle of an arena (an octree's nodes, between blocks still in use) stays in the RSS.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <thread>
#include <vector>

#include "rgbdmap/workers/memory_trim.hpp"

namespace rgbdmap {
namespace {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kOwnAllocator = true;  // the sanitizer's allocator: malloc_trim does not reach it
#else
constexpr bool kOwnAllocator = false;
#endif

/// ~256 MB in 2 KB blocks (below the mmap threshold: from the arena), then all but every 64th freed: the
/// pages between the survivors are free but not at the arena's top, so free() alone keeps them.
std::vector<std::unique_ptr<char[]>> fragmentHeap() {
  std::vector<std::unique_ptr<char[]>> blocks(128 * 1024);
  for (auto& b : blocks) {
    b.reset(new char[2048]);
    for (int i = 0; i < 2048; i += 512) b[i] = 1;  // touched: resident
  }
  std::vector<std::unique_ptr<char[]>> kept;
  for (size_t i = 0; i < blocks.size(); i += 64) kept.push_back(std::move(blocks[i]));
  return kept;
}

TEST(MemoryTrim, GivesFreedPagesInTheMiddleOfTheHeapBack) {
  if (kOwnAllocator) GTEST_SKIP() << "under a sanitizer: its allocator, not glibc's, holds the heap";
  const auto kept = fragmentHeap();
  const int64_t released = MemoryTrim::trimNow();
  std::printf("[ measured ] malloc_trim released %.0f MB of ~250 MB freed\n",
              static_cast<double>(released) / 1e6);
  EXPECT_GT(released, 100'000'000) << "the freed pages between the kept blocks";
  EXPECT_EQ(kept.size(), 2048u);
}

TEST(MemoryTrim, RunsEveryPeriodAndCountsWhatItReleased) {
  if (kOwnAllocator) GTEST_SKIP() << "under a sanitizer: its allocator, not glibc's, holds the heap";
  MemoryTrim trim(0.05);
  trim.start();
  const auto kept = fragmentHeap();
  const uint64_t before = trim.stats().trims;  // some may have run while the heap was being fragmented
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (trim.stats().trims < before + 2 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  trim.stop();
  const MemoryTrimStats s = trim.stats();
  EXPECT_GE(s.trims, before + 2);
  EXPECT_GT(s.released_bytes, 100'000'000);
  EXPECT_GE(s.cpu_ms, 0.0);
  trim.stop();  // idempotent
}

}  // namespace
}  // namespace rgbdmap
