// MCAP reader and writer: round trips in every chunk compression, cut-off files read up to the cut, corrupt
// and forged files refused with a reason and never a crash.
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include <unistd.h>

#include <gtest/gtest.h>

#include "rgbdmap/mcap/mcap_reader.hpp"
#include "rgbdmap/mcap/mcap_writer.hpp"

namespace rgbdmap::mcap {
namespace {

namespace fs = std::filesystem;

class McapTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rgbdmap_mcap_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  /// `n` messages of varied sizes on two channels.
  static std::vector<Message> messages(int n) {
    std::mt19937 rng(7);
    std::vector<Message> out;
    for (int i = 0; i < n; ++i) {
      Message m;
      m.channel_id = static_cast<uint16_t>(i % 2);
      m.sequence = static_cast<uint32_t>(i);
      m.log_time = 1000000000ull + 33000000ull * i;
      m.publish_time = m.log_time + 5;
      m.data.resize(std::uniform_int_distribution<size_t>(0, 3000)(rng));
      for (size_t k = 0; k < m.data.size(); ++k) m.data[k] = static_cast<uint8_t>(k % 7 == 0 ? rng() : i);
      out.push_back(std::move(m));
    }
    return out;
  }

  std::string write(const std::string& name, const WriterOptions& options, const std::vector<Message>& ms) {
    auto w = Writer::create(path(name), options);
    EXPECT_TRUE(w) << w.error();
    if (!w) return {};
    const uint16_t s = (*w)->addSchema("pkg/msg/A", "ros2msg", {'i', 'n', 't', '3', '2', ' ', 'x'});
    EXPECT_EQ((*w)->addChannel(s, "/a", "cdr", {{"offered_qos_profiles", "- history: 3"}}), 0);
    EXPECT_EQ((*w)->addChannel(0, "/b", "json"), 1);
    for (const Message& m : ms) EXPECT_TRUE((*w)->write(m));
    const Status closed = (*w)->close();
    EXPECT_TRUE(closed) << closed.error();
    return path(name);
  }

  /// Every message of the file until the end, a cut or an error (then `*error` says which).
  static std::vector<Message> readAll(const std::string& file, std::string* error, bool* cut) {
    std::vector<Message> out;
    *cut = false;
    auto r = Reader::open(file);
    if (!r) return *error = r.error(), out;
    for (int guard = 0; guard < 100000; ++guard) {
      auto m = (*r)->next();
      if (!m) return *error = m.error(), out;
      if (!*m) break;
      out.push_back(std::move(**m));
    }
    *cut = (*r)->cutOffAt().has_value();
    return out;
  }

  static bool same(const Message& a, const Message& b) {
    return a.channel_id == b.channel_id && a.sequence == b.sequence && a.log_time == b.log_time &&
           a.publish_time == b.publish_time && a.data == b.data;
  }

  static std::vector<uint8_t> bytesOf(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
  }
  void put(const std::string& file, const std::vector<uint8_t>& bytes, size_t n) const {
    std::ofstream(file, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(n));
  }

  fs::path dir_;
};

TEST_F(McapTest, EveryCompressionRoundTrips) {
  const auto ms = messages(60);
  struct Case {
    const char* name;
    Compression compression;
    size_t chunk_bytes;
  };
  for (const Case& c : {Case{"zstd", Compression::kZstd, 16384}, Case{"lz4", Compression::kLz4, 16384},
                        Case{"none", Compression::kNone, 16384}, Case{"unchunked", Compression::kNone, 0}}) {
    WriterOptions o;
    o.compression = c.compression;
    o.chunk_bytes = c.chunk_bytes;
    const std::string file = write(std::string(c.name) + ".mcap", o, ms);
    std::string error;
    bool cut = true;
    const auto back = readAll(file, &error, &cut);
    EXPECT_EQ(error, "") << c.name;
    EXPECT_FALSE(cut) << c.name;
    ASSERT_EQ(back.size(), ms.size()) << c.name;
    for (size_t i = 0; i < ms.size(); ++i) EXPECT_TRUE(same(back[i], ms[i])) << c.name << " " << i;
    auto r = Reader::open(file);
    ASSERT_TRUE(r);
    ASSERT_TRUE((*r)->next());
    EXPECT_EQ((*r)->profile(), "ros2");
    ASSERT_NE((*r)->channel(0), nullptr);
    EXPECT_EQ((*r)->channel(0)->topic, "/a");
    EXPECT_EQ((*r)->channel(0)->metadata.at("offered_qos_profiles"), "- history: 3");
    ASSERT_NE((*r)->schemaOf(*(*r)->channel(0)), nullptr);
    EXPECT_EQ((*r)->schemaOf(*(*r)->channel(0))->name, "pkg/msg/A");
  }
  EXPECT_LT(fs::file_size(path("zstd.mcap")), fs::file_size(path("none.mcap")));
  EXPECT_LT(fs::file_size(path("lz4.mcap")), fs::file_size(path("none.mcap")));
}

TEST_F(McapTest, EveryCutOffPrefixReadsItsCompleteMessagesAndSaysWhere) {
  const auto ms = messages(12);
  for (Compression c : {Compression::kZstd, Compression::kNone}) {
    WriterOptions o;
    o.compression = c;
    o.chunk_bytes = c == Compression::kNone ? 0 : 8000;  // several chunks; plain records
    const std::string file = write("whole.mcap", o, ms);
    const std::vector<uint8_t> bytes = bytesOf(file);
    uint64_t header_length = 0;
    std::memcpy(&header_length, bytes.data() + 8 + 1, 8);
    const size_t header_end = 8 + 9 + static_cast<size_t>(header_length);
    size_t last = 0;
    for (size_t n = 0; n < bytes.size(); n += (n < 64 ? 1 : 7)) {
      put(path("cut.mcap"), bytes, n);
      std::string error;
      bool cut = false;
      const auto back = readAll(path("cut.mcap"), &error, &cut);
      if (n < header_end) {  // magic and Header incomplete: not an MCAP file yet
        EXPECT_NE(error, "") << n;
        continue;
      }
      EXPECT_EQ(error, "") << n;
      ASSERT_LE(back.size(), ms.size());
      for (size_t i = 0; i < back.size(); ++i) EXPECT_TRUE(same(back[i], ms[i])) << n << " " << i;
      EXPECT_GE(back.size(), last) << "a longer prefix read fewer messages, at " << n;
      last = back.size();
      EXPECT_TRUE(cut || back.size() == ms.size()) << n;
    }
    EXPECT_EQ(last, ms.size());
  }
}

TEST_F(McapTest, RandomCorruptionIsRefusedOrReadButNeverCrashes) {
  WriterOptions o;
  o.chunk_bytes = 6000;
  for (Compression c : {Compression::kZstd, Compression::kLz4, Compression::kNone}) {
    o.compression = c;
    const std::vector<uint8_t> bytes = bytesOf(write("whole.mcap", o, messages(10)));
    std::mt19937 rng(11);
    int refused = 0;
    for (int trial = 0; trial < 300; ++trial) {
      std::vector<uint8_t> bad = bytes;
      const int flips = 1 + static_cast<int>(rng() % 8);
      for (int f = 0; f < flips; ++f) bad[rng() % bad.size()] = static_cast<uint8_t>(rng());
      put(path("bad.mcap"), bad, bad.size());
      std::string error;
      bool cut = false;
      const auto back = readAll(path("bad.mcap"), &error, &cut);
      EXPECT_LE(back.size(), 10u);
      refused += !error.empty();
    }
    if (c != Compression::kNone) {
      EXPECT_GT(refused, 100) << compressionName(c) << ": CRC and decoders catch most";
    }
  }
}

TEST_F(McapTest, ForgedSizesAreRefusedWithoutAllocatingThem) {
  WriterOptions o;
  o.chunk_bytes = 1 << 20;
  const std::vector<uint8_t> bytes = bytesOf(write("whole.mcap", o, messages(3)));
  // The first chunk record follows magic (8) and the Header record (9 + 4 + 4 + 4 + 7 = 28 bytes).
  const size_t chunk_at = 8 + 9 + 4 + 4 + 4 + 7;
  ASSERT_EQ(bytes[chunk_at], static_cast<uint8_t>(Opcode::kChunk));
  std::vector<uint8_t> bad = bytes;
  const uint64_t huge = uint64_t{1} << 40;
  std::memcpy(bad.data() + chunk_at + 9 + 16, &huge, 8);  // uncompressed_size
  put(path("bad.mcap"), bad, bad.size());
  std::string error;
  bool cut = false;
  readAll(path("bad.mcap"), &error, &cut);
  EXPECT_NE(error.find("a chunk of 1099511627776 bytes"), std::string::npos) << error;
  bad = bytes;
  std::memcpy(bad.data() + chunk_at + 1, &huge, 8);  // record length beyond the file: a cut
  put(path("bad.mcap"), bad, bad.size());
  error.clear();
  const auto back = readAll(path("bad.mcap"), &error, &cut);
  EXPECT_TRUE(cut);
  EXPECT_TRUE(back.empty());
}

TEST_F(McapTest, MissingEmptyAndForeignFilesAreNamed) {
  std::string error;
  bool cut = false;
  readAll(path("nope.mcap"), &error, &cut);
  EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
  put(path("empty.mcap"), {}, 0);
  readAll(path("empty.mcap"), &error, &cut);
  EXPECT_NE(error.find("not an MCAP file"), std::string::npos) << error;
  const std::vector<uint8_t> text = {'#', 'r', 'o', 's', 'b', 'a', 'g', ' ', 'V', '2', '.', '0', '\n'};
  put(path("bag.mcap"), text, text.size());
  readAll(path("bag.mcap"), &error, &cut);
  EXPECT_NE(error.find("not an MCAP file"), std::string::npos) << error;
}

TEST_F(McapTest, AWriterNotClosedLeavesNoFile) {
  {
    auto w = Writer::create(path("open.mcap"));
    ASSERT_TRUE(w);
    (*w)->addChannel(0, "/a", "json");
    ASSERT_TRUE((*w)->write({0, 0, 1, 1, {1, 2, 3}}));
  }
  EXPECT_TRUE(fs::is_empty(dir_));
  EXPECT_FALSE((*Writer::create(path("x.mcap")))->write({3, 0, 1, 1, {}}));  // undeclared channel
}

}  // namespace
}  // namespace rgbdmap::mcap
