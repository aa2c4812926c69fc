// RobotLink over memq:// against a minimal acknowledging server, one process:
//  - BM_SendKeyframe: sendKeyframe of a 640x480 synthetic keyframe (~1000 ORB features): image encoding,
//    message, seal, publish; the server opens, decodes, acknowledges. Counters: keyframes/s, bytes/keyframe.
//  - BM_ApplyCorrections/N: the server seals PoseCorrections for N keyframes; time until the link has
//    applied it (decode + per-segment anchors), i.e. the robot-side cost of one optimisation round.
// Usage: bench_robot_link [google-benchmark flags]. Pin to one core for the per-core figure (taskset -c 1).
#include <atomic>
#include <thread>

#include <benchmark/benchmark.h>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/link/robot_link.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/synth/synth.hpp"
#include "rgbdmap/vision/features.hpp"

namespace {
using namespace rgbdmap;

const msg::Bytes kKey(32, 7);

/// Opens each keyframe (signature, replay, full decode) and acknowledges it.
struct AckingServer {
  transport::Transport& transport;
  msg::KeyStore keys;
  msg::ReplayGuard guard;
  msg::Signer signer{msg::kServerId, kKey};
  std::mutex mutex;
  explicit AckingServer(transport::Transport& t) : transport(t) {
    (void)keys.add("robot0", kKey);
    (void)transport.subscribe("rgbdmap/robot0/keyframe",
                              [this](const std::string&, const uint8_t* d, size_t n) {
                                auto env = msg::openEnvelope(d, n, keys, &guard);
                                if (!env) return;
                                auto kf = msg::decodeMessage<msg::Keyframe>(*env);
                                if (!kf) return;
                                msg::KeyframeAck ack;
                                ack.robot_id = "robot0";
                                ack.keyframe_id = kf->keyframe_id;
                                send(ack);
                              });
  }
  template <typename T>
  void send(const T& m) {
    std::lock_guard<std::mutex> lock(mutex);
    if (Result<msg::Bytes> bytes = signer.seal(m, 1))
      (void)transport.publish(*msg::channelFor(T::kType, "robot0"), *bytes);
  }
};

struct Setup {
  std::unique_ptr<transport::Transport> transport = std::move(transport::makeTransport("memq://").value());
  AckingServer server{*transport};
  RobotLink link;
  explicit Setup(const CameraIntrinsics& camera)
      : link(*transport, [&] {
          RobotLinkOptions o;
          o.robot_id = "robot0";
          o.key = kKey;
          o.camera = camera;
          o.reliable.max_pending = 64;
          return o;
        }()) {
    (void)link.start();
  }
};

void BM_SendKeyframe(benchmark::State& state) {
  SynthConfig config;
  auto scene = SyntheticScene::build(config);
  std::vector<RgbdFrame> frames;
  std::vector<Keyframe> keyframes;
  const OrbExtractor extractor(OrbConfig{});
  for (int i = 0; i < 8; ++i) {
    frames.push_back(scene->renderFrame(i * 30));
    Keyframe kf;
    kf.features = extractor.extract(frames.back(), PinholeCamera(config.camera));
    kf.T_odom_cam = scene->trajectory()[i * 30].T_world_cam;
    keyframes.push_back(std::move(kf));
  }
  Setup s(config.camera);
  int id = 0;
  for (auto _ : state) {
    Keyframe& kf = keyframes[id % keyframes.size()];
    kf.id = id++;
    if (!s.link.sendKeyframe(kf, frames[kf.id % frames.size()])) state.SkipWithError("sendKeyframe failed");
  }
  const bool acked = s.link.waitAllAcked(30.0);  // after the timed loop
  const RobotLinkStats st = s.link.stats();
  state.counters["keyframes/s"] = benchmark::Counter(double(st.keyframes_sent), benchmark::Counter::kIsRate);
  state.counters["bytes/keyframe"] = double(st.bytes_sent) / std::max<uint64_t>(1, st.keyframes_sent);
  state.counters["all_acked"] = acked;
}

void BM_ApplyCorrections(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  CameraIntrinsics camera{525, 525, 31.5, 23.5, 64, 48, {0, 0, 0, 0, 0}, 5000, 0.0};
  Setup s(camera);
  RgbdFrame tiny;
  tiny.color = cv::Mat(48, 64, CV_8UC3, cv::Scalar(90, 120, 200));
  tiny.depth = cv::Mat(48, 64, CV_16UC1, cv::Scalar(7000));
  msg::PoseCorrections c;
  c.robot_id = "robot0";
  for (int i = 0; i < n; ++i) {
    Keyframe kf;
    kf.id = i;
    kf.segment = i / 1000;
    kf.T_odom_cam.translation() = Vec3(0.01 * i, 0, 0);
    (void)s.link.sendKeyframe(kf, tiny);
    c.keyframes.push_back({i, kf.T_odom_cam});
  }
  s.link.waitAllAcked(60.0);
  for (auto _ : state) {
    ++c.graph_revision;
    s.server.send(c);
    while (s.link.stats().graph_revision != c.graph_revision) std::this_thread::yield();  // bench only
  }
  state.counters["keyframes"] = n;
}

BENCHMARK(BM_SendKeyframe)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_ApplyCorrections)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  rgbdmap::log::setLevel(rgbdmap::log::Level::kWarn);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
