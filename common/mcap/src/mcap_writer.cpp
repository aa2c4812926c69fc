#include "rgbdmap/mcap/mcap_writer.hpp"

#include <unistd.h>
#include <zlib.h>
#include <cerrno>
#include <cstring>

#include "mcap_bytes.hpp"
#include "rgbdmap/common/atomic_file.hpp"

namespace rgbdmap::mcap {
namespace {

using detail::ByteWriter;

std::vector<uint8_t> schemaBody(const Schema& s) {
  ByteWriter w;
  w.pod(s.id);
  w.string(s.name);
  w.string(s.encoding);
  w.bytes32(s.data);
  return std::move(w.out());
}

std::vector<uint8_t> channelBody(const Channel& c) {
  ByteWriter w;
  w.pod(c.id);
  w.pod(c.schema_id);
  w.string(c.topic);
  w.string(c.message_encoding);
  w.stringMap(c.metadata);
  return std::move(w.out());
}

}  // namespace

Result<std::unique_ptr<Writer>> Writer::create(const std::string& path, const WriterOptions& options) {
  using R = Result<std::unique_ptr<Writer>>;
  std::unique_ptr<Writer> w(new Writer());
  w->path_ = path;
  w->temp_path_ = path + ".part." + std::to_string(::getpid());
  w->options_ = options;
  w->file_ = std::fopen(w->temp_path_.c_str(), "wb");
  if (!w->file_)
    return R::failure("mcap " + path + ": cannot create " + w->temp_path_ + ": " + std::strerror(errno));
  std::vector<uint8_t> head(kMagic, kMagic + sizeof(kMagic));
  ByteWriter h;
  h.string(options.profile);
  h.string(options.library);
  w->record(Opcode::kHeader, h.out(), &head);
  if (Status s = w->put(head); !s) return R::failure(s.error());
  return R(std::move(w));
}

Writer::~Writer() {
  if (file_) {
    std::fclose(file_);
    std::remove(temp_path_.c_str());
  }
}

void Writer::record(Opcode opcode, const std::vector<uint8_t>& body, std::vector<uint8_t>* out) const {
  out->push_back(static_cast<uint8_t>(opcode));
  const uint64_t n = body.size();
  const auto* p = reinterpret_cast<const uint8_t*>(&n);
  out->insert(out->end(), p, p + sizeof(n));
  out->insert(out->end(), body.begin(), body.end());
}

Status Writer::put(const std::vector<uint8_t>& bytes) {
  if (!error_) return error_;
  if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size())
    error_ = Status::failure("mcap " + path_ + ": cannot write: " + std::strerror(errno));
  offset_ += bytes.size();
  return error_;
}

uint16_t Writer::addSchema(const std::string& name, const std::string& encoding,
                           const std::vector<uint8_t>& data) {
  Schema s{static_cast<uint16_t>(schemas_.size() + 1), name, encoding, data};
  record(Opcode::kSchema, schemaBody(s), &chunk_);
  schemas_.push_back(std::move(s));
  return schemas_.back().id;
}

uint16_t Writer::addChannel(uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                            const std::map<std::string, std::string>& metadata) {
  Channel c{static_cast<uint16_t>(channels_.size()), schema_id, topic, message_encoding, metadata};
  record(Opcode::kChannel, channelBody(c), &chunk_);
  channels_.push_back(std::move(c));
  return channels_.back().id;
}

Status Writer::write(const Message& m) {
  if (!error_) return error_;
  if (m.channel_id >= channels_.size())
    return Status::failure("mcap " + path_ + ": channel " + std::to_string(m.channel_id) +
                           " was not declared");
  ByteWriter w;
  w.pod(m.channel_id);
  w.pod(m.sequence);
  w.pod(m.log_time);
  w.pod(m.publish_time);
  w.raw(m.data.data(), m.data.size());
  const bool first_in_chunk = chunk_start_ == 0 && chunk_end_ == 0;
  chunk_start_ = first_in_chunk ? m.log_time : std::min(chunk_start_, m.log_time);
  chunk_end_ = std::max(chunk_end_, m.log_time);
  message_start_ = message_count_ == 0 ? m.log_time : std::min(message_start_, m.log_time);
  message_end_ = std::max(message_end_, m.log_time);
  ++message_count_;
  ++per_channel_[m.channel_id];
  chunk_messages_[m.channel_id].emplace_back(m.log_time, chunk_.size());
  record(Opcode::kMessage, w.out(), &chunk_);
  return chunk_.size() >= options_.chunk_bytes ? flushChunk() : Status::success();
}

void Writer::writeMessageIndexes(std::vector<uint8_t>* out, std::map<uint16_t, uint64_t>* offsets) const {
  for (const auto& [channel, entries] : chunk_messages_) {
    (*offsets)[channel] = offset_ + out->size();  // `out` is written at offset_
    ByteWriter mi;
    mi.pod(channel);
    ByteWriter list;
    for (const auto& [time, at] : entries) list.pod(time), list.pod(at);
    mi.bytes32(list.out());
    record(Opcode::kMessageIndex, mi.out(), out);
  }
}

Status Writer::flushChunk() {
  if (chunk_.empty()) return error_;
  std::vector<uint8_t> out;
  if (options_.compression == Compression::kNone && options_.chunk_bytes == 0) {
    out = std::move(chunk_);  // unchunked: the records as they are, no indexes
  } else {
    const std::vector<uint8_t> packed = detail::compress(options_.compression, chunk_);
    if (packed.empty() && !chunk_.empty())
      return error_ = Status::failure("mcap " + path_ + ": compression failed");
    ByteWriter c;
    c.pod(chunk_start_);
    c.pod(chunk_end_);
    c.pod(static_cast<uint64_t>(chunk_.size()));
    c.pod(static_cast<uint32_t>(crc32(0L, chunk_.data(), static_cast<uInt>(chunk_.size()))));
    c.string(compressionName(options_.compression));
    c.pod(static_cast<uint64_t>(packed.size()));
    c.raw(packed.data(), packed.size());
    record(Opcode::kChunk, c.out(), &out);
    ChunkEntry e{chunk_start_, chunk_end_, offset_, out.size(), {}, 0, packed.size(), chunk_.size()};
    writeMessageIndexes(&out, &e.message_index_offsets);  // right after the chunk, in the same write
    e.message_index_length = out.size() - e.length;
    chunk_index_.push_back(std::move(e));
    ++chunk_count_;
  }
  chunk_.clear();
  chunk_messages_.clear();
  chunk_start_ = chunk_end_ = 0;
  return put(out);
}

Status Writer::close() {
  if (!file_) return Status::failure("mcap " + path_ + ": already closed");
  flushChunk();
  std::vector<uint8_t> tail;
  ByteWriter data_end;
  data_end.pod(uint32_t{0});  // no data section CRC
  record(Opcode::kDataEnd, data_end.out(), &tail);
  const uint64_t summary_start = offset_ + tail.size();
  for (const Schema& s : schemas_) record(Opcode::kSchema, schemaBody(s), &tail);
  for (const Channel& c : channels_) record(Opcode::kChannel, channelBody(c), &tail);
  ByteWriter st;
  st.pod(message_count_);
  st.pod(static_cast<uint16_t>(schemas_.size()));
  st.pod(static_cast<uint32_t>(channels_.size()));
  st.pod(uint32_t{0});  // attachments
  st.pod(uint32_t{0});  // metadata
  st.pod(chunk_count_);
  st.pod(message_start_);
  st.pod(message_end_);
  ByteWriter counts;
  for (const auto& [id, n] : per_channel_) counts.pod(id), counts.pod(n);
  st.bytes32(counts.out());
  record(Opcode::kStatistics, st.out(), &tail);
  for (const ChunkEntry& e : chunk_index_) {
    ByteWriter ci;
    ci.pod(e.start_time);
    ci.pod(e.end_time);
    ci.pod(e.offset);
    ci.pod(e.length);
    ByteWriter offsets;
    for (const auto& [channel, at] : e.message_index_offsets) offsets.pod(channel), offsets.pod(at);
    ci.bytes32(offsets.out());
    ci.pod(e.message_index_length);
    ci.string(compressionName(options_.compression));
    ci.pod(e.compressed_size);
    ci.pod(e.uncompressed_size);
    record(Opcode::kChunkIndex, ci.out(), &tail);
  }
  ByteWriter footer;
  footer.pod(summary_start);
  footer.pod(uint64_t{0});  // no summary offsets
  footer.pod(uint32_t{0});  // no summary CRC
  record(Opcode::kFooter, footer.out(), &tail);
  tail.insert(tail.end(), kMagic, kMagic + sizeof(kMagic));
  Status s = put(tail);
  if (s && (std::fflush(file_) != 0 || ::fsync(fileno(file_)) != 0))
    s = Status::failure("mcap " + path_ + ": cannot sync: " + std::strerror(errno));
  std::fclose(file_);
  file_ = nullptr;
  if (s && std::rename(temp_path_.c_str(), path_.c_str()) != 0)
    s = Status::failure("mcap " + path_ + ": cannot rename into place: " + std::strerror(errno));
  if (s) s = syncFolder(folderOf(path_));
  if (!s) std::remove(temp_path_.c_str());
  return s;
}

}  // namespace rgbdmap::mcap
