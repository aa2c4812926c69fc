#include "rgbdmap/mcap/mcap_reader.hpp"

#include <cerrno>
#include <cstring>

#include <zlib.h>

#include "mcap_bytes.hpp"

namespace rgbdmap::mcap {
namespace {

using detail::ByteReader;
constexpr uint64_t kRecordHeader = 9;  // opcode + uint64 length

}  // namespace

Reader::~Reader() {
  if (file_) std::fclose(file_);
}

std::string Reader::where(uint64_t offset) const {
  return "mcap " + path_ + ": at byte " + std::to_string(offset) + ": ";
}

Result<std::unique_ptr<Reader>> Reader::open(const std::string& path) {
  using R = Result<std::unique_ptr<Reader>>;
  std::unique_ptr<Reader> r(new Reader());
  r->path_ = path;
  r->file_ = std::fopen(path.c_str(), "rb");
  if (!r->file_) return R::failure("mcap " + path + ": cannot open: " + std::strerror(errno));
  if (std::fseek(r->file_, 0, SEEK_END) != 0) return R::failure("mcap " + path + ": cannot seek");
  const long size = std::ftell(r->file_);
  std::rewind(r->file_);
  if (size < 0) return R::failure("mcap " + path + ": not a regular file");
  r->file_size_ = static_cast<uint64_t>(size);
  uint8_t magic[8] = {};
  if (r->file_size_ < sizeof(magic) || std::fread(magic, 1, sizeof(magic), r->file_) != sizeof(magic) ||
      std::memcmp(magic, kMagic, sizeof(magic)) != 0)
    return R::failure("mcap " + path + ": not an MCAP file (no MCAP magic at its start)");
  r->offset_ = sizeof(magic);
  uint8_t opcode = 0;
  std::vector<uint8_t> body;
  const uint64_t header_at = r->offset_;
  Result<bool> got = r->readRecord(&opcode, &body);
  if (!got) return R::failure(got.error());
  if (!*got || opcode != static_cast<uint8_t>(Opcode::kHeader))
    return R::failure(r->where(header_at) + "no Header record after the magic");
  ByteReader h(body.data(), body.size());
  r->profile_ = h.string();
  h.string();  // library
  if (h.failed()) return R::failure(r->where(header_at) + "a Header shorter than its fields");
  return R(std::move(r));
}

/// One top-level record: false where the file ends (cut off), the reason for an impossible length.
Result<bool> Reader::readRecord(uint8_t* opcode, std::vector<uint8_t>* body) {
  const uint64_t start = offset_;
  uint8_t head[kRecordHeader];
  if (file_size_ - offset_ < kRecordHeader || std::fread(head, 1, kRecordHeader, file_) != kRecordHeader) {
    cut_off_at_ = start;
    return false;
  }
  uint64_t length = 0;
  std::memcpy(&length, head + 1, sizeof(length));
  *opcode = head[0];
  if (length > file_size_ - offset_ - kRecordHeader) {
    cut_off_at_ = start;  // a partial record: where a recording was cut off mid-write
    return false;
  }
  if (length > kMaxChunkBytes)
    return Result<bool>::failure(where(start) + "a record of " + std::to_string(length) + " bytes (at most " +
                                 std::to_string(kMaxChunkBytes) + ")");
  body->resize(static_cast<size_t>(length));
  if (length > 0 && std::fread(body->data(), 1, body->size(), file_) != body->size()) {
    cut_off_at_ = start;
    return false;
  }
  offset_ += kRecordHeader + length;
  return true;
}

Status Reader::openChunk(const std::vector<uint8_t>& body, uint64_t offset) {
  ByteReader c(body.data(), body.size());
  c.pod<uint64_t>();  // message_start_time
  c.pod<uint64_t>();  // message_end_time
  const uint64_t uncompressed_size = c.pod<uint64_t>();
  const uint32_t crc = c.pod<uint32_t>();
  const std::string compression = c.string();
  const uint64_t records = c.pod<uint64_t>();
  if (c.failed() || records != c.remaining())
    return Status::failure(where(offset) + "a Chunk whose fields disagree with its length");
  auto data = detail::decompress(compression, c.at(), c.remaining(), uncompressed_size);
  if (!data) return Status::failure(where(offset) + "chunk: " + data.error());
  if (crc != 0 && static_cast<uint32_t>(crc32(0L, data->data(), static_cast<uInt>(data->size()))) != crc)
    return Status::failure(where(offset) + "chunk: CRC mismatch (corrupt)");
  chunk_ = std::move(*data);
  chunk_pos_ = 0;
  chunk_offset_ = offset;
  return Status::success();
}

Status Reader::takeRecord(uint8_t opcode, const std::vector<uint8_t>& body, uint64_t offset,
                          std::optional<Message>* message) {
  ByteReader b(body.data(), body.size());
  switch (static_cast<Opcode>(opcode)) {
    case Opcode::kSchema: {
      Schema s;
      s.id = b.pod<uint16_t>();
      s.name = b.string();
      s.encoding = b.string();
      s.data = b.bytes32();
      if (b.failed() || s.id == 0) return Status::failure(where(offset) + "a malformed Schema record");
      schemas_[s.id] = std::move(s);
      return Status::success();
    }
    case Opcode::kChannel: {
      Channel ch;
      ch.id = b.pod<uint16_t>();
      ch.schema_id = b.pod<uint16_t>();
      ch.topic = b.string();
      ch.message_encoding = b.string();
      ch.metadata = b.stringMap();
      if (b.failed()) return Status::failure(where(offset) + "a malformed Channel record");
      channels_[ch.id] = std::move(ch);
      return Status::success();
    }
    case Opcode::kMessage: {
      Message m;
      m.channel_id = b.pod<uint16_t>();
      m.sequence = b.pod<uint32_t>();
      m.log_time = b.pod<uint64_t>();
      m.publish_time = b.pod<uint64_t>();
      if (b.failed()) return Status::failure(where(offset) + "a Message record shorter than its fields");
      if (!channels_.count(m.channel_id))
        return Status::failure(where(offset) + "a Message on channel " + std::to_string(m.channel_id) +
                               ", which no Channel record declared before it");
      m.data.assign(b.at(), b.at() + b.remaining());
      *message = std::move(m);
      return Status::success();
    }
    case Opcode::kChunk:
      return openChunk(body, offset);
    case Opcode::kDataEnd:
    case Opcode::kFooter:
      data_ended_ = true;
      return Status::success();
    default:
      return Status::success();  // indexes, attachments, metadata, statistics, unknown: skipped
  }
}

Result<std::optional<Message>> Reader::next() {
  using R = Result<std::optional<Message>>;
  std::vector<uint8_t> body;
  while (!data_ended_) {
    std::optional<Message> message;
    if (chunk_pos_ < chunk_.size()) {  // the records inside the current chunk
      ByteReader c(chunk_.data() + chunk_pos_, chunk_.size() - chunk_pos_);
      const uint8_t opcode = c.pod<uint8_t>();
      const uint64_t length = c.pod<uint64_t>();
      if (c.failed() || length > c.remaining())
        return R::failure(where(chunk_offset_) + "chunk: a record longer than the chunk (corrupt)");
      if (opcode == static_cast<uint8_t>(Opcode::kChunk))
        return R::failure(where(chunk_offset_) + "chunk: a chunk inside a chunk");
      body.assign(c.at(), c.at() + length);
      chunk_pos_ += kRecordHeader + static_cast<size_t>(length);
      if (Status s = takeRecord(opcode, body, chunk_offset_, &message); !s) return R::failure(s.error());
      if (message) return R(std::move(message));
      continue;
    }
    chunk_.clear();
    chunk_pos_ = 0;
    const uint64_t offset = offset_;
    uint8_t opcode = 0;
    Result<bool> got = readRecord(&opcode, &body);
    if (!got) return R::failure(got.error());
    if (!*got) return R(std::optional<Message>());  // cut off: cutOffAt() says where
    if (Status s = takeRecord(opcode, body, offset, &message); !s) return R::failure(s.error());
    if (message) return R(std::move(message));
  }
  return R(std::optional<Message>());
}

const Channel* Reader::channel(uint16_t id) const {
  const auto it = channels_.find(id);
  return it == channels_.end() ? nullptr : &it->second;
}

const Schema* Reader::schemaOf(const Channel& channel) const {
  const auto it = schemas_.find(channel.schema_id);
  return it == schemas_.end() ? nullptr : &it->second;
}

}  // namespace rgbdmap::mcap
