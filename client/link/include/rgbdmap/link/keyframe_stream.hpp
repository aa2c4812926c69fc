#pragma once
// A recorded keyframe stream: the keyframes one robot sent, as it sent them (rgbdmap-client
// --record-keyframes), for rgbdmap-replay to send again as any number of light robots without running
// their odometry (16 robots on 2 cores).
//
// File: the 8 bytes "RGBDKFS1", then records of [uint32 little-endian size][payload]. The first payload is
// the robot's msg::Hello (camera, mount), every other one a msg::Keyframe, each as msg::encodePayload wrote
// it (unsealed: a replayer signs with its own key). Written whole at close (writeFileAtomic).
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

inline constexpr char kKeyframeStreamMagic[] = "RGBDKFS1";  ///< 8 bytes, no terminator in the file
inline constexpr size_t kMaxKeyframeRecordBytes = 64u << 20;

class KeyframeStreamWriter {
 public:
  /// Keyframes kept beyond `max_bytes` are dropped and counted (a recording must not exhaust the robot).
  KeyframeStreamWriter(std::string path, const msg::Hello& hello, size_t max_bytes = size_t{1} << 30);
  /// Thread-safe. The encoded msg::Keyframe payload.
  void append(const msg::Bytes& keyframe_payload);
  /// Writes the file (temporary name, synced, renamed). The reason on failure.
  Status close();
  size_t keyframes() const;
  size_t dropped() const;
  const std::string& path() const { return path_; }

 private:
  void appendRecord(const msg::Bytes& payload);
  std::string path_;
  size_t max_bytes_;
  mutable std::mutex mutex_;
  std::string bytes_;
  size_t keyframes_ = 0, dropped_ = 0;
  Status hello_status_;
};

struct KeyframeStream {
  msg::Hello hello;
  std::vector<msg::Keyframe> keyframes;  ///< in the order sent; ids strictly increasing
};

/// Reads and checks a whole stream: the magic, every record's size, every payload (decodePayload and its
/// validation), one robot, strictly increasing keyframe ids, at least one keyframe. The reason on failure
/// names the record.
Result<KeyframeStream> readKeyframeStream(const std::string& path);
/// The same from bytes (tests, fuzzing).
Result<KeyframeStream> parseKeyframeStream(const std::string& bytes);

}  // namespace rgbdmap
