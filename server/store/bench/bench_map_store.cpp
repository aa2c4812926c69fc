// bench_map_store: cost of making a keyframe durable, and of opening (verifying, recovering) a map of 1,000
// keyframes. Keyframes carry the images of a rendered synthetic 640x480 frame (encodeImages: ~120 KB) and
// 300 keypoints with descriptors; the record is reported as record_kb. Files go to $RGBDMAP_BENCH_DIR or
// the system temporary folder (use a folder on the disk the server would use: fdatasync cost is the disk's).
//   build/bin/bench_map_store
//   RGBDMAP_BENCH_DIR=/path/on/target/disk build/bin/bench_map_store --benchmark_filter=Append
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>

#include <benchmark/benchmark.h>
#include <unistd.h>

#include "rgbdmap/codec/image_codec.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/synth/synth.hpp"

namespace {

namespace fs = std::filesystem;
using rgbdmap::StoredKeyframe;

std::string benchDir(const std::string& name) {
  const char* env = std::getenv("RGBDMAP_BENCH_DIR");
  const fs::path base = env ? fs::path(env) : fs::temp_directory_path();
  const fs::path dir = base / ("rgbdmap_bench_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir.string();
}

const rgbdmap::EncodedImages& images() {
  static const rgbdmap::EncodedImages encoded = [] {
    rgbdmap::SynthConfig config;
    config.frames = 40;
    return rgbdmap::encodeImages(rgbdmap::SyntheticScene::build(config).value().renderFrame(10)).value();
  }();
  return encoded;
}

StoredKeyframe keyframe(int64_t node_id) {
  std::mt19937 rng(static_cast<uint32_t>(node_id));
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  StoredKeyframe s;
  s.node_id = node_id;
  s.session = 7;
  rgbdmap::msg::Keyframe& k = s.keyframe;
  k.robot_id = k.header.sender = "robot_1";
  k.header.session = 7;
  k.keyframe_id = static_cast<int>(node_id);
  k.previous_keyframe_id = static_cast<int>(node_id) - 1;
  k.timestamp = 1000.0 + 0.5 * static_cast<double>(node_id);
  k.information = rgbdmap::Mat6::Identity() * 100.0;
  k.images = images();
  for (int i = 0; i < 300; ++i)
    k.keypoints.push_back({u(rng) * 639.0f, u(rng) * 479.0f, i % 8, u(rng) * 360.0f, u(rng), 1.0f + u(rng)});
  k.descriptors.resize(300 * rgbdmap::msg::kDescriptorBytes);
  for (uint8_t& b : k.descriptors) b = static_cast<uint8_t>(rng());
  return s;
}

void appendKeyframes(benchmark::State& state, bool sync) {
  rgbdmap::log::setLevel(rgbdmap::log::Level::kWarn);
  const std::string dir = benchDir(sync ? "sync" : "nosync");
  auto store = rgbdmap::MapStore::open(dir, rgbdmap::MapStoreOptions{sync});
  if (!store) {
    state.SkipWithError(store.error().c_str());
    return;
  }
  StoredKeyframe k = keyframe(0);
  int64_t node_id = 0;
  for (auto _ : state) {
    k.node_id = node_id++;
    if (rgbdmap::Status s = (*store)->appendKeyframe(k); !s) {
      state.SkipWithError(s.error().c_str());
      break;
    }
  }
  state.counters["record_kb"] = static_cast<double>((*store)->bytesOnDisk()) / node_id / 1000.0;
  state.SetBytesProcessed((*store)->bytesOnDisk());
  store->reset();
  fs::remove_all(dir);
}

void BM_AppendKeyframeSync(benchmark::State& state) { appendKeyframes(state, true); }
void BM_AppendKeyframeNoSync(benchmark::State& state) { appendKeyframes(state, false); }

/// open() of a map with 1,000 keyframes and 200 loops (files in the page cache: the CPU cost of verifying
/// and decoding; a cold start adds reading ~135 MB from the disk).
void BM_OpenRecover1000Keyframes(benchmark::State& state) {
  rgbdmap::log::setLevel(rgbdmap::log::Level::kWarn);
  const std::string dir = benchDir("open");
  {
    auto store = rgbdmap::MapStore::open(dir, rgbdmap::MapStoreOptions{false});
    for (int64_t id = 0; id < 1000 && store; ++id) {
      if (!(*store)->appendKeyframe(keyframe(id))) return state.SkipWithError("append failed");
      if (id % 5 == 4) {
        rgbdmap::StoredLoop loop;
        loop.from_node = id - 4;
        loop.to_node = id;
        if (!(*store)->appendLoop(loop)) return state.SkipWithError("append loop failed");
      }
    }
  }
  int64_t bytes = 0;
  for (auto _ : state) {
    auto store = rgbdmap::MapStore::open(dir);
    if (!store || store.value()->recovery().keyframes != 1000 || store.value()->recovery().loops != 200) {
      state.SkipWithError("open failed or content differs");
      break;
    }
    bytes = store.value()->bytesOnDisk();
  }
  state.counters["map_mb"] = static_cast<double>(bytes) / 1e6;
  fs::remove_all(dir);
}

}  // namespace

BENCHMARK(BM_AppendKeyframeSync)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_AppendKeyframeNoSync)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_OpenRecover1000Keyframes)->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK_MAIN();
