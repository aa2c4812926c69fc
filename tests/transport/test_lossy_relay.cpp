// The lossy relay's LCM datagram parsing and drop decisions (rgbdmap/transport/lcm_datagram.hpp).
#include <gtest/gtest.h>

#include <vector>

#include "rgbdmap/transport/lcm_datagram.hpp"

namespace rgbdmap::relay {
namespace {

std::vector<uint8_t> fragment(uint32_t seq, uint16_t no, uint16_t count) {
  std::vector<uint8_t> d = {'L', 'C', '0', '3', 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 'x'};
  d[4] = static_cast<uint8_t>(seq >> 24);
  d[7] = static_cast<uint8_t>(seq & 0xff);
  d[16] = static_cast<uint8_t>(no >> 8);
  d[17] = static_cast<uint8_t>(no & 0xff);
  d[18] = static_cast<uint8_t>(count >> 8);
  d[19] = static_cast<uint8_t>(count & 0xff);
  return d;
}

TEST(LossyRelay, ParsesShortMessagesAndFragments) {
  const std::vector<uint8_t> short_msg = {'L', 'C', '0', '2', 0, 0, 1, 2, 'c', 0, 'p'};
  LcmDatagramHeader h;
  ASSERT_TRUE(parseLcmDatagram(short_msg.data(), short_msg.size(), &h));
  EXPECT_FALSE(h.fragment);
  EXPECT_EQ(h.sequence, 0x0102u);
  const auto f = fragment(0x01000005, 3, 7);
  ASSERT_TRUE(parseLcmDatagram(f.data(), f.size(), &h));
  EXPECT_TRUE(h.fragment);
  EXPECT_EQ(h.sequence, 0x01000005u);
  EXPECT_EQ(h.fragment_no, 3);
  EXPECT_EQ(h.fragment_count, 7);
}

TEST(LossyRelay, RejectsMalformedDatagrams) {
  LcmDatagramHeader h;
  const std::vector<uint8_t> junk = {'X', 'C', '0', '2', 0, 0, 0, 1, 0};
  EXPECT_FALSE(parseLcmDatagram(junk.data(), junk.size(), &h));
  EXPECT_FALSE(parseLcmDatagram(junk.data(), 3, &h));
  const auto out_of_range = fragment(1, 7, 7);
  EXPECT_FALSE(parseLcmDatagram(out_of_range.data(), out_of_range.size(), &h));
  const auto zero_count = fragment(1, 0, 0);
  EXPECT_FALSE(parseLcmDatagram(zero_count.data(), zero_count.size(), &h));
  const auto truncated = fragment(1, 0, 2);
  EXPECT_FALSE(parseLcmDatagram(truncated.data(), 12, &h));
}

TEST(LossyRelay, MessageDropIsPerMessageAndNearTheRate) {
  int dropped = 0;
  for (uint32_t seq = 0; seq < 20000; ++seq) {
    const bool d = dropMessage(7, 0x7f000001, 40000, seq, 0.3);
    EXPECT_EQ(d, dropMessage(7, 0x7f000001, 40000, seq, 0.3));  // same answer for every fragment
    dropped += d ? 1 : 0;
  }
  EXPECT_NEAR(dropped / 20000.0, 0.3, 0.02);
  EXPECT_FALSE(dropMessage(7, 1, 2, 3, 0.0));
  EXPECT_TRUE(dropMessage(7, 1, 2, 3, 1.0));
}

TEST(LossyRelay, DatagramLossFollowsIpFragments) {
  EXPECT_DOUBLE_EQ(datagramLoss(0.05, 65000, 0), 0.05);
  EXPECT_NEAR(datagramLoss(0.05, 1200, 1500), 0.05, 1e-12);             // one packet
  EXPECT_NEAR(datagramLoss(0.05, 1480, 1500), 1 - 0.95 * 0.95, 1e-12);  // + 8-byte UDP header: two
  EXPECT_NEAR(datagramLoss(0.05, 65000, 1500), 1 - std::pow(0.95, 44), 1e-12);
}

}  // namespace
}  // namespace rgbdmap::relay
