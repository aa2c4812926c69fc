#include "rgbdmap/link/keyframe_stream.hpp"

#include <cstring>
#include <filesystem>
#include <system_error>

#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/proto/codec.hpp"

namespace rgbdmap {
namespace {

constexpr size_t kMagicBytes = sizeof(kKeyframeStreamMagic) - 1;
constexpr uintmax_t kMaxStreamFileBytes = uintmax_t{8} << 30;

void putSize(std::string* out, size_t n) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((n >> (8 * i)) & 0xff));
}

}  // namespace

KeyframeStreamWriter::KeyframeStreamWriter(std::string path, const msg::Hello& hello, size_t max_bytes)
    : path_(std::move(path)), max_bytes_(max_bytes) {
  bytes_.assign(kKeyframeStreamMagic, kMagicBytes);
  Result<msg::Bytes> payload = msg::encodePayload(hello);
  if (!payload)
    hello_status_ = Status::failure(path_ + ": the robot's Hello does not encode: " + payload.error());
  else
    appendRecord(*payload);
}

void KeyframeStreamWriter::appendRecord(const msg::Bytes& payload) {
  putSize(&bytes_, payload.size());
  bytes_.append(reinterpret_cast<const char*>(payload.data()), payload.size());
}

void KeyframeStreamWriter::append(const msg::Bytes& keyframe_payload) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (keyframe_payload.size() > kMaxKeyframeRecordBytes ||
      bytes_.size() + keyframe_payload.size() + 4 > max_bytes_) {
    ++dropped_;
    return;
  }
  appendRecord(keyframe_payload);
  ++keyframes_;
}

Status KeyframeStreamWriter::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!hello_status_) return hello_status_;
  if (keyframes_ == 0) return Status::failure(path_ + ": no keyframe was sent, nothing recorded");
  return writeFileAtomic(path_, bytes_);
}

size_t KeyframeStreamWriter::keyframes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return keyframes_;
}

size_t KeyframeStreamWriter::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

Result<KeyframeStream> parseKeyframeStream(const std::string& bytes) {
  using R = Result<KeyframeStream>;
  if (bytes.size() < kMagicBytes || std::memcmp(bytes.data(), kKeyframeStreamMagic, kMagicBytes) != 0)
    return R::failure("not a keyframe stream (no RGBDKFS1 magic)");
  KeyframeStream stream;
  size_t at = kMagicBytes;
  for (size_t record = 0; at < bytes.size(); ++record) {
    const std::string where = "record " + std::to_string(record) + " at byte " + std::to_string(at);
    if (bytes.size() - at < 4) return R::failure(where + ": truncated size");
    size_t size = 0;
    for (int i = 0; i < 4; ++i) size |= size_t{static_cast<uint8_t>(bytes[at + i])} << (8 * i);
    at += 4;
    if (size > kMaxKeyframeRecordBytes)
      return R::failure(where + ": " + std::to_string(size) + " bytes is too large");
    if (bytes.size() - at < size)
      return R::failure(where + ": truncated (" + std::to_string(bytes.size() - at) + " of " +
                        std::to_string(size) + " bytes)");
    const auto* data = reinterpret_cast<const uint8_t*>(bytes.data() + at);
    at += size;
    if (record == 0) {
      Result<msg::Hello> hello = msg::decodePayload<msg::Hello>(data, size);
      if (!hello) return R::failure(where + ": not the robot's Hello: " + hello.error());
      stream.hello = std::move(*hello);
      continue;
    }
    Result<msg::Keyframe> keyframe = msg::decodePayload<msg::Keyframe>(data, size);
    if (!keyframe) return R::failure(where + ": not a keyframe: " + keyframe.error());
    if (keyframe->robot_id != stream.hello.robot_id)
      return R::failure(where + ": keyframe of robot '" + keyframe->robot_id + "' in the stream of '" +
                        stream.hello.robot_id + "'");
    if (!stream.keyframes.empty() && keyframe->keyframe_id <= stream.keyframes.back().keyframe_id)
      return R::failure(where + ": keyframe id " + std::to_string(keyframe->keyframe_id) + " after " +
                        std::to_string(stream.keyframes.back().keyframe_id));
    stream.keyframes.push_back(std::move(*keyframe));
  }
  if (stream.keyframes.empty()) return R::failure("the stream holds no keyframe");
  return stream;
}

Result<KeyframeStream> readKeyframeStream(const std::string& path) {
  std::error_code ec;
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return Result<KeyframeStream>::failure(path + ": " + ec.message());
  if (size > kMaxStreamFileBytes) return Result<KeyframeStream>::failure(path + ": larger than 8 GiB");
  Result<std::string> bytes = readTextFile(path);
  if (!bytes) return Result<KeyframeStream>::failure(bytes.error());
  Result<KeyframeStream> stream = parseKeyframeStream(*bytes);
  if (!stream) return Result<KeyframeStream>::failure(path + ": " + stream.error());
  return stream;
}

}  // namespace rgbdmap
