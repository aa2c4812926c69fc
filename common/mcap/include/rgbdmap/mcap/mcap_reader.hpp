#pragma once
// Reads an MCAP file's messages in file order, one record at a time (a file of any size; at most one
// decompressed chunk in memory). The file is untrusted: every length is checked against the bytes there
// are, a chunk's declared size against kMaxChunkBytes and its CRC when it has one, and decompression stops
// at the declared size. A file that ends early (a recording cut off mid-write: no DataEnd, summary or
// footer, possibly a partial record or chunk) reads up to its last complete record and says where it was
// cut; a corrupt record is an error naming its offset.
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/mcap/mcap.hpp"

namespace rgbdmap::mcap {

/// Largest record or decompressed chunk read (rosbag2 writes ~4 MB chunks; one 4K 32FC1 image is 33 MB).
inline constexpr uint64_t kMaxChunkBytes = uint64_t{512} << 20;

class Reader {
 public:
  static Result<std::unique_ptr<Reader>> open(const std::string& path);
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  /// The next message in file order; nullopt at the end of the data section or where the file was cut
  /// off (cutOffAt() then tells where); the reason when a record is corrupt.
  Result<std::optional<Message>> next();

  /// Schemas and channels seen so far (the data section declares each before its first message).
  const std::map<uint16_t, Schema>& schemas() const { return schemas_; }
  const std::map<uint16_t, Channel>& channels() const { return channels_; }
  const Channel* channel(uint16_t id) const;
  const Schema* schemaOf(const Channel& channel) const;
  const std::string& profile() const { return profile_; }
  /// The byte offset where the file ends early, once next() reached it.
  std::optional<uint64_t> cutOffAt() const { return cut_off_at_; }
  const std::string& path() const { return path_; }
  uint64_t fileSize() const { return file_size_; }

 private:
  Reader() = default;
  Result<bool> readRecord(uint8_t* opcode, std::vector<uint8_t>* body);
  Status takeRecord(uint8_t opcode, const std::vector<uint8_t>& body, uint64_t offset,
                    std::optional<Message>* message);
  Status openChunk(const std::vector<uint8_t>& body, uint64_t offset);
  std::string where(uint64_t offset) const;

  std::string path_, profile_;
  std::FILE* file_ = nullptr;
  uint64_t file_size_ = 0, offset_ = 0;
  std::map<uint16_t, Schema> schemas_;
  std::map<uint16_t, Channel> channels_;
  std::vector<uint8_t> chunk_;  ///< the records of the chunk being read
  size_t chunk_pos_ = 0;
  uint64_t chunk_offset_ = 0;
  bool data_ended_ = false;
  std::optional<uint64_t> cut_off_at_;
};

}  // namespace rgbdmap::mcap
