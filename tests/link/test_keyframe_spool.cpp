// KeyframeSpool on its own: records survive a reopen and resume their session, answered ids are never
// given out again, damage at any byte is counted and leaves the other records intact, the budget and the
// lock hold.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "link_test_util.hpp"
#include "rgbdmap/link/keyframe_spool.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;

std::string freshDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("spool_" + name);
  fs::remove_all(dir);
  return dir.string();
}

msg::Keyframe spoolMessage(int id, int segment = 0, const std::string& robot = "robot0") {
  const Keyframe kf = testing::smallKeyframe(id, segment, testing::testPose(id), id - 1);
  Result<EncodedImages> images = encodeImages(testing::smallFrame(id), ImageCodecOptions{});
  EXPECT_TRUE(images.ok());
  Result<msg::Keyframe> m = keyframeToMessage(kf, robot, std::move(*images), true);
  EXPECT_TRUE(m.ok()) << m.error();
  return *m;
}

std::unique_ptr<KeyframeSpool> openSpool(const std::string& dir, uint64_t max_bytes = uint64_t{1} << 30) {
  auto spool = KeyframeSpool::open({dir, max_bytes}, "robot0");
  EXPECT_TRUE(spool.ok()) << spool.error();
  return spool ? std::move(*spool) : nullptr;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void writeFile(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

TEST(KeyframeSpool, RecordsSurviveAReopenAndResumeTheirSession) {
  const std::string dir = freshDir("resume");
  int64_t session = 0;
  std::vector<msg::Keyframe> sent;
  {
    auto spool = openSpool(dir);
    ASSERT_TRUE(spool);
    EXPECT_FALSE(spool->resumed());
    EXPECT_EQ(spool->firstKeyframeId(), 0);
    EXPECT_EQ(spool->firstSeq(), 0);
    session = spool->session();
    for (int id = 0; id < 5; ++id) {
      sent.push_back(spoolMessage(id));
      ASSERT_TRUE(spool->append(sent.back()));
    }
    EXPECT_FALSE(spool->append(spoolMessage(2))) << "an id is spooled once";
    spool->remove(1);
    spool->remove(3);
    EXPECT_EQ(spool->stats().depth, 3u);
    EXPECT_EQ(spool->stats().appended, 5u);
    EXPECT_GT(spool->stats().oldest_utime, 0);
  }
  auto spool = openSpool(dir);
  ASSERT_TRUE(spool);
  EXPECT_TRUE(spool->resumed());
  EXPECT_EQ(spool->session(), session);
  EXPECT_GT(spool->firstSeq(), 0) << "above every seq the session used";
  EXPECT_EQ(spool->pending(), (std::vector<int>{0, 2, 4}));
  EXPECT_EQ(spool->stats().recovered, 3u);
  EXPECT_GE(spool->firstKeyframeId(), 5);
  EXPECT_GE(spool->firstSegment(), 1) << "this process's odometry starts a new chain";
  Result<msg::Keyframe> back = spool->read(2);
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_EQ(back->keyframe_id, 2);
  EXPECT_EQ(back->images.color, sent[2].images.color);
  EXPECT_EQ(back->keypoints.size(), 20u);
  EXPECT_FALSE(spool->append(spoolMessage(5, 0))) << "an earlier segment is not this process's";
}

TEST(KeyframeSpool, AnsweredIdsAreNeverGivenOutAgainAndAnEmptySpoolStartsANewSession) {
  const std::string dir = freshDir("ids");
  int64_t session = 0;
  {
    auto spool = openSpool(dir);
    session = spool->session();
    for (int id = 0; id < 300; ++id) ASSERT_TRUE(spool->append(spoolMessage(id, id / 100)));
    for (int id = 0; id < 300; ++id)
      if (id != 7) spool->remove(id);
  }
  {
    auto spool = openSpool(dir);
    EXPECT_EQ(spool->session(), session);
    EXPECT_GE(spool->firstKeyframeId(), 300) << "keyframe 299 was acknowledged and removed, not forgotten";
    EXPECT_GE(spool->firstSegment(), 3);
    spool->remove(7);
  }
  auto spool = openSpool(dir);
  EXPECT_FALSE(spool->resumed());
  EXPECT_GT(spool->session(), session);
  EXPECT_EQ(spool->firstKeyframeId(), 0);
  EXPECT_TRUE(spool->pending().empty());
}

// Every byte of one record flipped, and every truncation of it: the other two records are delivered, the
// damaged one is counted and moved aside, nothing crashes.
TEST(KeyframeSpool, DamageAtAnyByteIsCountedAndTheOtherRecordsStayIntact) {
  const std::string pristine = freshDir("pristine");
  {
    auto spool = openSpool(pristine);
    for (int id = 0; id < 3; ++id) {
      const Status s = spool->append(spoolMessage(id));
      ASSERT_TRUE(s) << s.error();
    }
  }
  const std::string name = "kf-000000001.rec";
  const std::string good = readFile(pristine + "/" + name);
  ASSERT_GT(good.size(), 1000u);
  const std::string dir = freshDir("damaged");
  const size_t step = std::max<size_t>(1, good.size() / 600);  // ~600 offsets, the header's all
  size_t cases = 0;
  for (size_t at = 0; at < good.size(); at += (at < 40 ? 1 : step)) {
    for (const bool truncate : {false, true}) {
      fs::remove_all(dir);
      fs::copy(pristine, dir);
      std::string bad = good;
      if (truncate)
        bad.resize(at);
      else
        bad[at] = static_cast<char>(bad[at] ^ 0x5A);
      writeFile(dir + "/" + name, bad);
      auto spool = KeyframeSpool::open({dir, uint64_t{1} << 30}, "robot0");
      ASSERT_TRUE(spool.ok()) << spool.error();
      EXPECT_EQ((*spool)->pending(), (std::vector<int>{0, 2})) << "offset " << at << " truncate " << truncate;
      EXPECT_EQ((*spool)->stats().damaged, 1u);
      EXPECT_TRUE(fs::exists(dir + "/damaged/" + name));
      EXPECT_TRUE((*spool)->read(2).ok());
      ++cases;
    }
  }
  EXPECT_GT(cases, 600u);
}

TEST(KeyframeSpool, ADamagedStateFileFallsBackToTheRecords) {
  const std::string dir = freshDir("state");
  int64_t session = 0;
  {
    auto spool = openSpool(dir);
    session = spool->session();
    for (int id = 0; id < 4; ++id) ASSERT_TRUE(spool->append(spoolMessage(id)));
  }
  writeFile(dir + "/SPOOL", "garbage\n");
  auto spool = openSpool(dir);
  ASSERT_TRUE(spool);
  EXPECT_EQ(spool->session(), session);
  EXPECT_EQ(spool->pending().size(), 4u);
  EXPECT_GE(spool->firstKeyframeId(), 4);
}

TEST(KeyframeSpool, TheBudgetRefusesWhatDoesNotFitAndCountsIt) {
  const std::string dir = freshDir("budget");
  const size_t record = encodeSpoolRecord(1, spoolMessage(0))->size();
  auto spool = openSpool(dir, 2 * record + record / 2);
  ASSERT_TRUE(spool->append(spoolMessage(0)));
  ASSERT_TRUE(spool->append(spoolMessage(1)));
  const Status full = spool->append(spoolMessage(2));
  ASSERT_FALSE(full);
  EXPECT_NE(full.error().find("spool full"), std::string::npos) << full.error();
  EXPECT_EQ(spool->stats().not_spooled, 1u);
  spool->remove(0);
  EXPECT_TRUE(spool->append(spoolMessage(3))) << "room again once one is answered";
}

TEST(KeyframeSpool, OneProcessPerSpoolAndOneRobotPerFolder) {
  const std::string dir = freshDir("lock");
  auto first = openSpool(dir);
  ASSERT_TRUE(first);
  auto second = KeyframeSpool::open({dir, uint64_t{1} << 30}, "robot0");
  ASSERT_FALSE(second.ok());
  EXPECT_NE(second.error().find("in use"), std::string::npos) << second.error();
  first.reset();
  auto other = KeyframeSpool::open({dir, uint64_t{1} << 30}, "robot1");
  ASSERT_FALSE(other.ok());
  EXPECT_NE(other.error().find("belongs to robot 'robot0'"), std::string::npos) << other.error();
}

}  // namespace
}  // namespace rgbdmap
