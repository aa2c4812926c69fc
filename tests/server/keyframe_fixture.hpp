#pragma once
// The recorded keyframe stream the server tests replay: the synthetic "loop" scene (kLoopFrames frames)
// through the real odometry and the real image codec, one file per odometry start frame, written at build
// time by make_keyframe_fixture (tests/CMakeLists.txt) so each test process only reads it. File format: the
// magic line, then per keyframe a little-endian uint32 length and msg::encodePayload<msg::Keyframe> bytes.
#include <cstdio>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/codec.hpp"

namespace rgbdmap::testing {

constexpr int kLoopFrames = 300;  ///< the default synthetic loop of `rgbdmap run`
/// Odometry start frames recorded: 0 (the whole loop; any [0, end) is a prefix of it) and the later starts
/// of the second robot / restarted robot of the server tests.
constexpr int kLoopStarts[] = {0, 80, 130};
constexpr char kFixtureMagic[] = "rgbdmap keyframe fixture 1\n";

inline std::string keyframeFixturePath(const std::string& dir, int first_frame) {
  return dir + "/loop" + std::to_string(kLoopFrames) + "_from" + std::to_string(first_frame) + ".kfs";
}

/// Encodes the keyframes into the fixture format.
inline Result<msg::Bytes> encodeKeyframeFixture(const std::vector<msg::Keyframe>& keyframes) {
  msg::Bytes out(kFixtureMagic, kFixtureMagic + sizeof(kFixtureMagic) - 1);
  for (const msg::Keyframe& kf : keyframes) {
    Result<msg::Bytes> payload = msg::encodePayload(kf);
    if (!payload)
      return Result<msg::Bytes>::failure("keyframe " + std::to_string(kf.keyframe_id) + ": " +
                                         payload.error());
    const uint32_t n = static_cast<uint32_t>(payload->size());
    for (int b = 0; b < 4; ++b) out.push_back(static_cast<uint8_t>(n >> (8 * b)));
    out.insert(out.end(), payload->begin(), payload->end());
  }
  return out;
}

/// Reads a fixture file; fails with the reason (missing file: build the target keyframe_fixture).
inline Result<std::vector<msg::Keyframe>> readKeyframeFixture(const std::string& path) {
  using Out = Result<std::vector<msg::Keyframe>>;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return Out::failure(path + ": cannot open (built by the target keyframe_fixture)");
  msg::Bytes bytes;
  uint8_t buffer[1 << 16];
  for (size_t n; (n = std::fread(buffer, 1, sizeof(buffer), f)) > 0;)
    bytes.insert(bytes.end(), buffer, buffer + n);
  std::fclose(f);
  const size_t magic = sizeof(kFixtureMagic) - 1;
  if (bytes.size() < magic || !std::equal(kFixtureMagic, kFixtureMagic + magic, bytes.begin()))
    return Out::failure(path + ": not a keyframe fixture");
  std::vector<msg::Keyframe> keyframes;
  for (size_t at = magic; at < bytes.size();) {
    if (bytes.size() - at < 4) return Out::failure(path + ": truncated");
    uint32_t n = 0;
    for (int b = 0; b < 4; ++b) n |= uint32_t(bytes[at + b]) << (8 * b);
    at += 4;
    if (bytes.size() - at < n) return Out::failure(path + ": truncated");
    Result<msg::Keyframe> kf = msg::decodePayload<msg::Keyframe>(bytes.data() + at, n);
    if (!kf) return Out::failure(path + ": " + kf.error());
    keyframes.push_back(std::move(*kf));
    at += n;
  }
  return keyframes;
}

}  // namespace rgbdmap::testing
