// Map store crash recovery: a kill -9 mid-append leaves a prefix of the last record (truncation at every
// offset), power loss may leave garbage, bits rot (flipped bytes in headers and payloads). Earlier records
// must survive, the damage be counted and reported, and appending must work afterwards.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <set>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "common/temp_dir.hpp"
#include "store/map_store_test_util.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;
using testing::expectSameKeyframe;
using testing::makeKeyframe;
using testing::makeLoop;
using Bytes = std::vector<uint8_t>;

Bytes readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), {});
}

/// Makes the file the first `size` bytes of `bytes`. Rewrites in place and then shortens it: truncating to
/// zero first would make ext4 flush the file on every close (auto_da_alloc), slowing the sweeps 10x.
void writeFile(const std::string& path, const Bytes& bytes, size_t size) {
  {
    std::fstream file(path, std::ios::binary | std::ios::in | std::ios::out);
    ASSERT_TRUE(file) << path;
    file.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(size));
  }
  fs::resize_file(path, size);
}

using testing::openStore;

/// Four keyframes and two loops between nodes 0 and 2; records where the records start.
struct Written {
  std::vector<StoredKeyframe> keyframes;
  std::vector<int64_t> starts;  ///< keyframe record i spans [starts[i], starts[i + 1])
  int64_t last_keyframe_at = 0, last_loop_at = 0;
  Bytes keyframe_log, loop_log;
};

Written writeFour(const std::string& dir, const EncodedImages& images, int keypoints) {
  Written w;
  auto store = openStore(dir);
  for (int64_t id = 0; id < 4; ++id) {
    w.keyframes.push_back(makeKeyframe(id, 0, images, keypoints));
    w.starts.push_back(store->bytesOnDisk());
    EXPECT_TRUE(store->appendKeyframe(w.keyframes.back()).ok());
  }
  w.starts.push_back(store->bytesOnDisk());
  w.last_keyframe_at = w.starts[3];
  EXPECT_TRUE(store->appendLoop(makeLoop(0, 2)).ok());
  w.last_loop_at = static_cast<int64_t>(fs::file_size(dir + "/loops.log"));
  EXPECT_TRUE(store->appendLoop(makeLoop(2, 0)).ok());
  store.reset();
  w.keyframe_log = readFile(dir + "/keyframes.log");
  w.loop_log = readFile(dir + "/loops.log");
  return w;
}

/// Truncates keyframes.log at `size` (inside the last record), reopens, checks; with `append_after` also
/// appends the lost keyframe again and checks that it survives another reopen.
void expectTruncationRecovered(const std::string& dir, const Written& w, size_t size, bool append_after) {
  SCOPED_TRACE("keyframes.log truncated to " + std::to_string(size) + " bytes");
  writeFile(dir + "/keyframes.log", w.keyframe_log, size);
  auto store = openStore(dir);
  ASSERT_TRUE(store);
  const MapStoreRecovery& r = store->recovery();
  ASSERT_EQ(r.keyframes, 3);
  EXPECT_EQ(r.loops, 2);
  EXPECT_EQ(r.corrupt_records, 0);
  EXPECT_EQ(r.truncated_bytes, static_cast<int64_t>(size) - w.last_keyframe_at);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_EQ(static_cast<int64_t>(fs::file_size(dir + "/keyframes.log")), w.last_keyframe_at);  // repaired
  if (!append_after) return;
  ASSERT_TRUE(store->appendKeyframe(w.keyframes[3]).ok());
  store.reset();  // releases the directory lock
  store = openStore(dir);
  ASSERT_TRUE(store);
  EXPECT_EQ(store->recovery().keyframes, 4);
  EXPECT_TRUE(store->recovery().problems.empty());
  for (const StoredKeyframe& k : w.keyframes) {
    Result<StoredKeyframe> read = store->readKeyframe(k.node_id);
    ASSERT_TRUE(read) << read.error();
    expectSameKeyframe(*read, k, true);
  }
}

TEST(MapStoreRecovery, TruncationAtEveryOffsetOfTheLastRecord) {
  const testing::QuietLog quiet;
  testing::TempDir tmp;
  const Written w = writeFour(tmp.dir(), testing::randomImages(16, 12, 1), 10);
  ASSERT_LT(w.keyframe_log.size(), 12000u);  // keeps this sweep fast
  for (size_t size = w.last_keyframe_at + 1; size < w.keyframe_log.size(); ++size)
    expectTruncationRecovered(tmp.dir(), w, size, (size - w.last_keyframe_at) % 97 == 1);
  writeFile(tmp.path("keyframes.log"), w.keyframe_log, w.keyframe_log.size());
  for (size_t size = w.last_loop_at + 1; size < w.loop_log.size(); ++size) {
    writeFile(tmp.path("loops.log"), w.loop_log, size);
    auto store = openStore(tmp.dir());
    ASSERT_TRUE(store);
    EXPECT_EQ(store->recovery().loops, 1);
    EXPECT_EQ(store->recovery().truncated_bytes, static_cast<int64_t>(size) - w.last_loop_at);
    EXPECT_EQ(store->recovery().keyframes, 4);
  }
}

TEST(MapStoreRecovery, TruncationOfARealisticRecordAtSampledOffsets) {
  const testing::QuietLog quiet;
  testing::TempDir tmp;
  const Written w = writeFour(tmp.dir(), testing::renderedImages()[0], 300);
  const size_t record = w.keyframe_log.size() - w.last_keyframe_at;
  ASSERT_GT(record, 40000u);
  std::vector<size_t> inside = {1, 2, 15, 19, 20, 21, 36, record - 1};
  for (size_t at = 4099; at < record; at += 4099) inside.push_back(at);
  for (size_t i = 0; i < inside.size(); ++i)
    expectTruncationRecovered(tmp.dir(), w, w.last_keyframe_at + inside[i], i % 3 == 0);
}

/// Flips one byte of keyframes.log (or loops.log) at `at` and expects exactly the damaged record skipped.
void expectFlipSkipsOneRecord(const std::string& dir, const Written& w, const std::string& log, size_t at) {
  SCOPED_TRACE(log + ": byte " + std::to_string(at) + " flipped");
  const bool keyframes = log == "keyframes.log";
  Bytes bytes = keyframes ? w.keyframe_log : w.loop_log;
  bytes[at] ^= 0x5a;
  writeFile(dir + "/" + log, bytes, bytes.size());
  auto store = openStore(dir);
  ASSERT_TRUE(store);
  const MapStoreRecovery& r = store->recovery();
  EXPECT_EQ(r.corrupt_records, 1);
  EXPECT_EQ(r.truncated_bytes, 0);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_NE(r.problems[0].find(dir + "/" + log + ": "), std::string::npos) << r.problems[0];
  EXPECT_EQ(r.keyframes, keyframes ? 3 : 4);
  EXPECT_EQ(r.loops, keyframes ? 2 : 1);
  if (keyframes) {
    EXPECT_FALSE(store->readKeyframe(1));
    for (int64_t id : {0, 2, 3}) {
      Result<StoredKeyframe> kept = store->readKeyframe(id);
      ASSERT_TRUE(kept) << kept.error();
      expectSameKeyframe(*kept, w.keyframes[id], true);
    }
  }
  writeFile(dir + "/" + log, keyframes ? w.keyframe_log : w.loop_log, bytes.size());  // restore
}

TEST(MapStoreRecovery, FlippedByteInTheMiddleRecordIsSkippedOthersKept) {
  const testing::QuietLog quiet;
  testing::TempDir tmp;
  const Written w = writeFour(tmp.dir(), testing::randomImages(32, 24, 2), 20);
  const size_t first = w.starts[1];
  const size_t middle_size = w.starts[2] - w.starts[1];
  for (size_t i = 0; i < 20; ++i)
    expectFlipSkipsOneRecord(tmp.dir(), w, "keyframes.log", first + i);  // header
  for (size_t i = 20; i < middle_size; i += 211)
    expectFlipSkipsOneRecord(tmp.dir(), w, "keyframes.log", first + i);
  expectFlipSkipsOneRecord(tmp.dir(), w, "keyframes.log", first + middle_size / 2);
  expectFlipSkipsOneRecord(tmp.dir(), w, "loops.log", 5);
  expectFlipSkipsOneRecord(tmp.dir(), w, "loops.log", w.last_loop_at / 2 + 7);
}

TEST(MapStoreRecovery, RecordDamagedWhileOpenNoLongerReads) {
  testing::TempDir tmp;
  const Written w = writeFour(tmp.dir(), testing::randomImages(32, 24, 3), 20);
  auto store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  Bytes bytes = w.keyframe_log;
  bytes[w.last_keyframe_at - 100] ^= 1;  // inside the payload of node 2
  writeFile(tmp.path("keyframes.log"), bytes, bytes.size());
  Result<StoredKeyframe> damaged = store->readKeyframe(2);
  ASSERT_FALSE(damaged);
  EXPECT_NE(damaged.error().find("CRC"), std::string::npos) << damaged.error();
  EXPECT_TRUE(store->readKeyframe(1));
  EXPECT_TRUE(store->readKeyframe(3));
}

TEST(MapStoreRecovery, GarbageTailIsCutOffAndAppendingWorks) {
  testing::TempDir tmp;
  const Written w = writeFour(tmp.dir(), testing::randomImages(32, 24, 4), 20);
  Bytes bytes = w.keyframe_log;
  bytes.resize(bytes.size() + 4096, 0);  // power loss: the file grew but the data never arrived
  writeFile(tmp.path("keyframes.log"), bytes, bytes.size());
  {
    std::vector<std::string> warnings;
    log::setSink([&](log::Level level, const std::string& line) {
      if (level == log::Level::kWarn) warnings.push_back(line);
    });
    auto store = openStore(tmp.dir());
    log::setSink(nullptr);
    ASSERT_TRUE(store);
    ASSERT_EQ(warnings.size(), 1u);  // each problem is logged
    EXPECT_NE(warnings[0].find("4096 bytes cut off"), std::string::npos) << warnings[0];
    EXPECT_EQ(store->recovery().keyframes, 4);
    EXPECT_EQ(store->recovery().corrupt_records, 1);
    EXPECT_EQ(store->recovery().truncated_bytes, 4096);
    EXPECT_EQ(fs::file_size(tmp.path("keyframes.log")), w.keyframe_log.size());
    ASSERT_TRUE(store->appendKeyframe(makeKeyframe(4, 0, testing::randomImages(32, 24, 5), 20)).ok());
  }
  auto store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  EXPECT_EQ(store->recovery().keyframes, 5);
  EXPECT_TRUE(store->recovery().problems.empty());
}

TEST(MapStoreRecovery, LoopOfALostKeyframeIsDropped) {
  testing::TempDir tmp;
  const Written w = writeFour(tmp.dir(), testing::randomImages(32, 24, 6), 20);
  {
    auto store = openStore(tmp.dir());
    ASSERT_TRUE(store->appendLoop(makeLoop(3, 1)).ok());
  }
  writeFile(tmp.path("keyframes.log"), w.keyframe_log, w.last_keyframe_at + 50);  // node 3 torn
  auto store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  EXPECT_EQ(store->recovery().keyframes, 3);
  EXPECT_EQ(store->recovery().loops, 2);
  EXPECT_EQ(store->recovery().corrupt_records, 1);
  EXPECT_EQ(store->recovery().truncated_bytes, 50);
  bool named = false;
  for (const std::string& p : store->recovery().problems) named |= p.find("not stored") != std::string::npos;
  EXPECT_TRUE(named);
}

TEST(MapStoreRecovery, RandomDamageKeepsExactlyTheIntactRecords) {
  const testing::QuietLog quiet;
  testing::TempDir tmp;
  std::vector<int64_t> starts;  // record i spans [starts[i], starts[i + 1])
  {
    auto store = openStore(tmp.dir());
    for (int64_t id = 0; id < 6; ++id) {
      starts.push_back(store->bytesOnDisk());
      ASSERT_TRUE(
          store->appendKeyframe(makeKeyframe(id, 0, testing::randomImages(16, 12, 10 + id), 10)).ok());
    }
    starts.push_back(store->bytesOnDisk());
  }
  const Bytes original = readFile(tmp.path("keyframes.log"));
  std::mt19937 rng(2024);
  for (int trial = 0; trial < 150; ++trial) {
    Bytes bytes = original;
    std::set<int64_t> damaged;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) {
      const size_t at = rng() % bytes.size();
      bytes[at] ^= static_cast<uint8_t>(1 + rng() % 255);
      damaged.insert(std::upper_bound(starts.begin(), starts.end(), static_cast<int64_t>(at)) -
                     starts.begin() - 1);
    }
    size_t size = bytes.size();
    if (trial % 3 == 0) size = rng() % bytes.size();  // and a crash at a random point
    writeFile(tmp.path("keyframes.log"), bytes, size);
    auto store = openStore(tmp.dir());
    ASSERT_TRUE(store);
    std::vector<int64_t> expected, kept;
    for (int64_t id = 0; id < 6; ++id)
      if (!damaged.count(id) && starts[id + 1] <= static_cast<int64_t>(size)) expected.push_back(id);
    for (const StoredKeyframe& k : store->keyframes()) kept.push_back(k.node_id);
    EXPECT_EQ(kept, expected) << "trial " << trial;
    for (int64_t id : kept) EXPECT_TRUE(store->readKeyframe(id)) << "trial " << trial;
  }
}

TEST(MapStoreRecovery, FailedAppendCutsItsPartialRecordAndStopsAppends) {
  const testing::QuietLog quiet;
  testing::TempDir tmp;
  const Written w = writeFour(tmp.dir(), testing::randomImages(32, 24, 7), 20);
  {
    auto store = openStore(tmp.dir());
    ASSERT_TRUE(store);
    // A file size limit makes the write stop part-way (EFBIG), like a full disk.
    rlimit saved{};
    ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &saved), 0);
    rlimit limited = saved;
    limited.rlim_cur = w.keyframe_log.size() + 1000;
    auto* previous_handler = ::signal(SIGXFSZ, SIG_IGN);
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limited), 0);
    const Status failed = store->appendKeyframe(makeKeyframe(4, 0, testing::randomImages(32, 24, 8), 20));
    ::setrlimit(RLIMIT_FSIZE, &saved);
    ::signal(SIGXFSZ, previous_handler);
    ASSERT_FALSE(failed);
    EXPECT_NE(failed.error().find("cannot write"), std::string::npos) << failed.error();
    EXPECT_EQ(fs::file_size(tmp.path("keyframes.log")), w.keyframe_log.size());  // partial record cut off
    EXPECT_EQ(store->keyframes().size(), 4u);
    const Status after = store->appendKeyframe(makeKeyframe(5, 0, testing::randomImages(32, 24, 9), 20));
    EXPECT_NE(after.error().find("until it recovers"), std::string::npos) << after.error();
    EXPECT_TRUE(store->readKeyframe(3));  // reading still works
  }
  auto store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  EXPECT_EQ(store->recovery().keyframes, 4);
  EXPECT_TRUE(store->recovery().problems.empty());
  EXPECT_TRUE(store->appendKeyframe(makeKeyframe(4, 0, testing::randomImages(32, 24, 8), 20)).ok());
}

/// Child process: opens the store, appends keyframes (ids after the stored ones) with sync on and writes each
/// acknowledged node id to `ack_fd`, until killed. Uses no test macros (they are not fork-safe); exits with 3
/// on an unexpected failure.
[[noreturn]] void appendUntilKilled(const std::string& dir, const EncodedImages& images, int ack_fd) {
  Result<std::unique_ptr<MapStore>> store = MapStore::open(dir, MapStoreOptions{true});
  const int64_t first = store ? static_cast<int64_t>(store.value()->keyframes().size()) : 0;
  for (int64_t id = first; store; ++id) {
    if (!store.value()->appendKeyframe(makeKeyframe(id, 0, images, 50))) break;
    if (::write(ack_fd, &id, sizeof id) != static_cast<ssize_t>(sizeof id)) break;
  }
  ::_exit(3);
}

TEST(MapStoreRecovery, KilledWriterLosesNoAcknowledgedKeyframe) {
  const testing::QuietLog quiet;
  testing::TempDir tmp;
  const EncodedImages images = testing::randomImages(160, 120, 8);
  for (int round = 0; round < 3; ++round) {
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      ::close(fds[0]);
      appendUntilKilled(tmp.dir(), images, fds[1]);
    }
    ::close(fds[1]);
    int64_t acked = -1, id = 0;
    for (int acks = 0; acks < 15 && ::read(fds[0], &id, sizeof id) == static_cast<ssize_t>(sizeof id); ++acks)
      acked = id;
    ::kill(child, SIGKILL);
    while (::read(fds[0], &id, sizeof id) == static_cast<ssize_t>(sizeof id)) acked = id;  // acks sent before
    ::close(fds[0]);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status)) << "writer failed on its own, status " << status;

    auto store = openStore(tmp.dir());  // the restarted server
    ASSERT_TRUE(store);
    ASSERT_GE(acked, 14 * (round + 1));
    const int kept = store->recovery().keyframes;
    EXPECT_GE(kept, acked + 1) << "round " << round;  // every acknowledged keyframe, maybe one more
    EXPECT_LE(kept, acked + 2) << "round " << round;
    EXPECT_EQ(store->recovery().corrupt_records, 0);
    for (int64_t n = 0; n < kept; ++n) {
      Result<StoredKeyframe> read = store->readKeyframe(n);
      ASSERT_TRUE(read) << read.error();
      EXPECT_TRUE(read->keyframe.images.color == images.color);
    }
  }
}

}  // namespace
}  // namespace rgbdmap
