#pragma once
// Writes an MCAP file: Header, a data section of chunks (zstd, lz4 or uncompressed), DataEnd, a summary
// section (every Schema and Channel, Statistics) and the Footer. The file grows under a temporary name
// beside the target and appears at its name, synced, only on close(): a reader never sees a partial file
// (destroyed without close(), the temporary file is removed). Chunked files are indexed: a MessageIndex per
// channel after each chunk and a ChunkIndex per chunk in the summary, so that readers (Foxglove,
// @mcap/core's indexed reader) seek by time instead of reading the whole file.
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/mcap/mcap.hpp"

namespace rgbdmap::mcap {

struct WriterOptions {
  std::string profile = "ros2";  ///< the Header's profile ("ros2", "" for none)
  std::string library = "rgbdmap";
  Compression compression = Compression::kZstd;
  size_t chunk_bytes = size_t{4} << 20;  ///< a chunk is closed once its records reach this size
};

class Writer {
 public:
  static Result<std::unique_ptr<Writer>> create(const std::string& path, const WriterOptions& options = {});
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  /// Declares a schema (ids from 1) or a channel (ids from 0) in the data section.
  uint16_t addSchema(const std::string& name, const std::string& encoding, const std::vector<uint8_t>& data);
  uint16_t addChannel(uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                      const std::map<std::string, std::string>& metadata = {});
  /// The reason when the channel was not declared or the file cannot be written.
  Status write(const Message& message);
  /// Finishes the file (last chunk, DataEnd, summary, Footer, magic), syncs it and renames it into place.
  Status close();
  const std::string& path() const { return path_; }

 private:
  Writer() = default;
  void record(Opcode opcode, const std::vector<uint8_t>& body, std::vector<uint8_t>* out) const;
  Status put(const std::vector<uint8_t>& bytes);
  Status flushChunk();
  void writeMessageIndexes(std::vector<uint8_t>* out, std::map<uint16_t, uint64_t>* offsets) const;

  /// What the summary's ChunkIndex says of one written chunk.
  struct ChunkEntry {
    uint64_t start_time = 0, end_time = 0, offset = 0, length = 0;
    std::map<uint16_t, uint64_t> message_index_offsets;
    uint64_t message_index_length = 0, compressed_size = 0, uncompressed_size = 0;
  };

  std::string path_, temp_path_;
  WriterOptions options_;
  std::FILE* file_ = nullptr;
  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  std::vector<uint8_t> chunk_;  ///< the records of the open chunk
  uint64_t chunk_start_ = 0, chunk_end_ = 0, offset_ = 0;
  uint64_t message_count_ = 0, message_start_ = 0, message_end_ = 0;
  uint32_t chunk_count_ = 0;
  std::map<uint16_t, uint64_t> per_channel_;
  std::map<uint16_t, std::vector<std::pair<uint64_t, uint64_t>>> chunk_messages_;  ///< (log time, offset)
  std::vector<ChunkEntry> chunk_index_;
  Status error_ = Status::success();
};

}  // namespace rgbdmap::mcap
