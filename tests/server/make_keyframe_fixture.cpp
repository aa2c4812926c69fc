// Build-time generator of the server tests' recorded keyframe stream (keyframe_fixture.hpp): renders the
// synthetic loop, runs the real odometry from each start frame and writes every keyframe as the real
// message (keyframeToMessage, encodeImages) into OUTPUT_DIR. The starts run in parallel threads.
// Usage: make_keyframe_fixture OUTPUT_DIR
#include <unistd.h>

#include <cstdio>
#include <future>

#include "rgbdmap/client/odometry.hpp"
#include "rgbdmap/synth/synth.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"
#include "server/keyframe_fixture.hpp"

namespace rgbdmap::testing {
namespace {

/// Odometry over frames [first, kLoopFrames) of the loop, every keyframe as its message of robot "robot0".
Result<std::vector<msg::Keyframe>> recordFrom(const SyntheticScene& scene, const CameraIntrinsics& camera,
                                              int first) {
  using Out = Result<std::vector<msg::Keyframe>>;
  std::vector<msg::Keyframe> out;
  VisualOdometry vo(camera, OdometryConfig{});
  for (int i = first; i < kLoopFrames; ++i) {
    const RgbdFrame frame = scene.renderFrame(i);
    const TrackingResult r = vo.track(frame);
    if (!r.new_keyframe) continue;
    Result<EncodedImages> images = encodeImages(frame);
    if (!images) return Out::failure("frame " + std::to_string(i) + ": " + images.error());
    Result<msg::Keyframe> m = keyframeToMessage(*r.new_keyframe, "robot0", std::move(*images));
    if (!m) return Out::failure("frame " + std::to_string(i) + ": " + m.error());
    m->header.sender = m->robot_id;  // valid as stored; the sending test robot seals it anew
    out.push_back(std::move(*m));
  }
  return out;
}

/// Writes to a temporary name, syncs and renames, so an interrupted build never leaves a partial fixture.
Status writeAtomically(const std::string& path, const msg::Bytes& bytes) {
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) return Status::failure(tmp + ": cannot create");
  const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size() && std::fflush(f) == 0 &&
                  ::fsync(::fileno(f)) == 0;
  if (std::fclose(f) != 0 || !ok || std::rename(tmp.c_str(), path.c_str()) != 0)
    return Status::failure(path + ": write failed");
  return Status();
}

int run(const std::string& dir) {
  SynthConfig cfg;
  cfg.scene = "loop";
  cfg.frames = kLoopFrames;
  Result<SyntheticScene> scene = SyntheticScene::build(cfg);
  if (!scene) {
    std::fprintf(stderr, "make_keyframe_fixture: %s\n", scene.error().c_str());
    return 1;
  }
  std::vector<std::future<Result<std::vector<msg::Keyframe>>>> runs;
  for (int first : kLoopStarts)
    runs.push_back(
        std::async(std::launch::async, [&, first] { return recordFrom(*scene, cfg.camera, first); }));
  int status = 0;
  for (size_t k = 0; k < runs.size(); ++k) {
    const std::string path = keyframeFixturePath(dir, kLoopStarts[k]);
    Result<std::vector<msg::Keyframe>> keyframes = runs[k].get();
    Result<msg::Bytes> bytes =
        keyframes ? encodeKeyframeFixture(*keyframes) : Result<msg::Bytes>::failure(keyframes.error());
    const Status written = bytes ? writeAtomically(path, *bytes) : Status::failure(bytes.error());
    if (!written) {
      std::fprintf(stderr, "make_keyframe_fixture: %s: %s\n", path.c_str(), written.error().c_str());
      status = 1;
      continue;
    }
    std::printf("%s: %zu keyframes, %zu bytes\n", path.c_str(), keyframes->size(), bytes->size());
  }
  return status;
}

}  // namespace
}  // namespace rgbdmap::testing

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_keyframe_fixture OUTPUT_DIR\n");
    return 2;
  }
  return rgbdmap::testing::run(argv[1]);
}
