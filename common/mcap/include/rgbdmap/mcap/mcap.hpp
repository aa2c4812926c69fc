#pragma once
// MCAP (https://mcap.dev/spec, version 0): the records the reader yields and the writer takes. A file is
// magic, a Header, a data section (Schema, Channel and Message records, plain or inside compressed Chunks),
// DataEnd, an optional summary section (repeated Schemas and Channels, Statistics), a Footer and magic.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace rgbdmap::mcap {

inline constexpr uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum class Opcode : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

/// Chunk compression: the spec's names "" (none), "zstd" and "lz4" (LZ4 frame format).
enum class Compression { kNone, kZstd, kLz4 };
const char* compressionName(Compression c);

struct Schema {
  uint16_t id = 0;
  std::string name;      ///< e.g. "sensor_msgs/msg/Image"
  std::string encoding;  ///< e.g. "ros2msg", "jsonschema"
  std::vector<uint8_t> data;
};

struct Channel {
  uint16_t id = 0;
  uint16_t schema_id = 0;  ///< 0: no schema
  std::string topic;
  std::string message_encoding;  ///< e.g. "cdr", "json"
  std::map<std::string, std::string> metadata;
};

struct Message {
  uint16_t channel_id = 0;
  uint32_t sequence = 0;
  uint64_t log_time = 0;  ///< ns
  uint64_t publish_time = 0;
  std::vector<uint8_t> data;
};

}  // namespace rgbdmap::mcap
