// bench_proto: encode+sign and open+decode of a keyframe message of about 110 KB (the codec's measured mean
// on TUM fr1 keyframes), one core.
#include <benchmark/benchmark.h>

#include <random>

#include "rgbdmap/proto/envelope.hpp"

namespace {

using namespace rgbdmap;

msg::Keyframe makeKeyframe() {
  msg::Keyframe k;
  k.robot_id = "robot_1";
  k.keyframe_id = 1;
  k.previous_keyframe_id = 0;
  k.information = Mat6::Identity() * 100.0;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 1000; ++i)
    k.keypoints.push_back({u(rng) * 639, u(rng) * 479, i % 8, 90.0f, 50.0f, 2.0f});
  k.descriptors.resize(1000 * msg::kDescriptorBytes);
  for (auto& b : k.descriptors) b = static_cast<uint8_t>(rng());
  // Blobs with valid headers and random payload: the envelope does not decode images (decodeImages does).
  auto blob = [&](const char* magic, size_t payload) {
    msg::Bytes b(kImageBlobHeaderSize + payload);
    for (auto& x : b) x = static_cast<uint8_t>(rng());
    std::copy(magic, magic + 4, b.begin());
    b[6] = 640 & 255, b[7] = 640 >> 8, b[8] = 480 & 255, b[9] = 480 >> 8;
    return b;
  };
  k.images.width = 640;
  k.images.height = 480;
  k.images.color_codec = ColorCodec::kJpeg;
  k.images.depth = blob("RDMD", 26000);
  k.images.color = blob("RDMC", 31000);
  return k;
}

msg::Bytes testKey() { return msg::Bytes(32, 0x5a); }

void BM_EncodeSignKeyframe(benchmark::State& state) {
  const msg::Keyframe k = makeKeyframe();
  msg::Signer signer("robot_1", testKey());
  size_t bytes = 0;
  for (auto _ : state) {
    Result<msg::Bytes> out = signer.seal(k, 1700000000000000);
    bytes = out->size();
    benchmark::DoNotOptimize(out);
  }
  state.counters["message_KB"] = bytes / 1000.0;
}
BENCHMARK(BM_EncodeSignKeyframe)->Unit(benchmark::kMicrosecond);

void BM_OpenDecodeKeyframe(benchmark::State& state) {
  msg::Signer signer("robot_1", testKey());
  const msg::Bytes bytes = signer.seal(makeKeyframe(), 1700000000000000).value();
  msg::KeyStore keys;
  (void)keys.add("robot_1", testKey());
  for (auto _ : state) {
    msg::ReplayGuard guard;  // fresh, so the same message is not a replay
    Result<msg::OpenedEnvelope> e = msg::openEnvelope(bytes, keys, &guard);
    Result<msg::Keyframe> k = msg::decodeMessage<msg::Keyframe>(*e);
    if (!k) state.SkipWithError(k.error().c_str());
    benchmark::DoNotOptimize(k);
  }
  state.counters["message_KB"] = bytes.size() / 1000.0;
}
BENCHMARK(BM_OpenDecodeKeyframe)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
