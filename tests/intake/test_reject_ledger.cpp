// Rejected messages named by their claimed sender: the rate-limited log line per claimed id and the bounded
// tables hostile senders cannot grow (the server end to end: tests/server/test_map_server_rejects.cpp).
#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rgbdmap/intake/reject_ledger.hpp"

namespace rgbdmap {
namespace {

using Clock = RejectLedger::Clock;
using std::chrono::seconds;

int64_t countOf(const std::vector<msg::RejectCount>& counts, const std::string& robot,
                const std::string& reason) {
  for (const msg::RejectCount& c : counts)
    if (c.robot_id == robot && c.reason == reason) return c.count;
  return 0;
}

RejectLedger knowing(std::vector<std::string> robots, RejectLedgerOptions options = {}) {
  return RejectLedger(options, [robots](const std::string& id) {
    return std::find(robots.begin(), robots.end(), id) != robots.end();
  });
}

TEST(RejectLedger, NamesTheClaimedSenderAtMostOncePerIntervalWithTheSuppressedCount) {
  RejectLedger ledger = knowing({"robot1"});
  const Clock::time_point t0 = Clock::now();
  const std::string first = ledger.add("robot1", "bad_signature", "", t0);
  EXPECT_NE(first.find("claiming to be from 'robot1': bad signature"), std::string::npos) << first;
  EXPECT_NE(first.find("1 bad_signature from robot1 so far"), std::string::npos) << first;
  for (int i = 1; i <= 9; ++i) EXPECT_EQ(ledger.add("robot1", "bad_signature", "", t0 + seconds(i)), "");
  EXPECT_NE(ledger.add("robot2", "bad_signature", "", t0 + seconds(1)), "")
      << "another claimed id has its own limit";
  const std::string next = ledger.add("robot1", "bad_signature", "", t0 + seconds(10));
  EXPECT_NE(next.find("11 bad_signature from robot1 so far"), std::string::npos) << next;
  EXPECT_NE(next.find("9 from this sender not logged since its last line"), std::string::npos) << next;
  EXPECT_EQ(countOf(ledger.counts(), "robot1", "bad_signature"), 11);
  EXPECT_EQ(countOf(ledger.counts(), "", "bad_signature"), 1) << "robot2 is not known: the unknown bucket";
}

TEST(RejectLedger, ClaimedIdsAreSanitisedForTheLog) {
  EXPECT_EQ(RejectLedger::sanitize("robot_1"), "robot_1");
  EXPECT_EQ(RejectLedger::sanitize(std::string("a\nb\x1b[31m'\xff", 10)), "a?b?[31m??");
  EXPECT_EQ(RejectLedger::sanitize(std::string(100, 'x')), std::string(msg::kMaxIdLength, 'x') + "...");
  RejectLedger ledger = knowing({});
  const std::string line =
      ledger.add(std::string("evil\n[fake] server: all good") + std::string(200, 'z'), "invalid_sender");
  EXPECT_EQ(line.find('\n'), std::string::npos) << line;
  EXPECT_LT(line.size(), 300u) << line;
  EXPECT_EQ(RejectLedger::reasonKey(msg::RejectReason::kBadSignature), "bad_signature");
  EXPECT_EQ(RejectLedger::reasonKeyOf("header mismatch"), "header_mismatch");
  EXPECT_EQ(RejectLedger::reasonKeyOf("invalid content: too many keypoints"), "invalid_content");
}

TEST(RejectLedger, HostileClaimedIdsCannotGrowTheTables) {
  RejectLedgerOptions options;
  options.max_claimed_ids = 64;
  RejectLedger ledger = knowing({"robot0"}, options);
  const Clock::time_point t0 = Clock::now();
  int lines = 0;
  for (int i = 0; i < 100000; ++i)
    lines +=
        !ledger.add("fake" + std::to_string(i), i % 2 ? "bad_signature" : "unknown_sender", "", t0).empty();
  EXPECT_NE(ledger.add("robot0", "replayed_seq", "", t0), "") << "a known robot is still counted on its own";
  EXPECT_EQ(ledger.trackedClaimedIds(), 65u)
      << "64 invented ids and the known robot0 (the rest share 'other')";
  EXPECT_EQ(lines, 1) << "lines about unknown claimed ids: at most unknown_lines_per_s overall";
  const std::vector<msg::RejectCount> counts = ledger.counts();
  EXPECT_EQ(countOf(counts, "", "bad_signature") + countOf(counts, "", "unknown_sender"), 100000);
  EXPECT_EQ(countOf(counts, "robot0", "replayed_seq"), 1);
  EXPECT_EQ(counts.size(), 3u) << "unknown claimed ids share one bucket per reason";
  const std::string other = ledger.add("fake999999", "bad_signature", "", t0 + seconds(11));
  EXPECT_NE(other.find("beyond the first 64"), std::string::npos) << other;
}

TEST(RejectLedger, KnownRobotsWithOwnCountersAreBoundedToo) {
  RejectLedgerOptions options;
  options.max_known = 2;
  RejectLedger ledger(options, [](const std::string&) { return true; });
  for (const char* id : {"a", "b", "c", "d"}) ledger.add(id, "malformed");
  ledger.add("a", "malformed");
  const std::vector<msg::RejectCount> counts = ledger.counts();
  EXPECT_EQ(countOf(counts, "a", "malformed"), 2);
  EXPECT_EQ(countOf(counts, "b", "malformed"), 1);
  EXPECT_EQ(countOf(counts, "", "malformed"), 2) << "c and d";
  EXPECT_EQ(counts.front().count, 2) << "largest first";
  EXPECT_EQ(ledger.counts(1).size(), 1u);
}

}  // namespace
}  // namespace rgbdmap
