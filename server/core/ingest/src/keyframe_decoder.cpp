#include "rgbdmap/ingest/keyframe_decoder.hpp"

#include <chrono>
#include <string>
#include <utility>

#include "rgbdmap/intake/image_admission.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"
#include "rgbdmap/workers/thread_time.hpp"

namespace rgbdmap {

KeyframeDecoder::KeyframeDecoder(const MapServerConfig& config, const RobotRegistry& registry)
    : config_(config),
      registry_(registry),
      worker_extractor_(config.features),
      decode_extractor_(config.features) {}

PreparedKeyframe KeyframeDecoder::prepare(msg::Keyframe kf) {
  PreparedKeyframe prepared{std::move(kf), {}, {}, 0.0, 0.0};
  const msg::Keyframe& k = prepared.keyframe;
  const int robot = registry_.index(k.robot_id);  // the registry is thread-safe
  prepared.camera = registry_.camera(k.robot_id);
  if (robot < 0 || !prepared.camera || seen({robot, k.header.session, k.segment_id, k.keyframe_id}))
    return prepared;
  const ImageLimits limits{config_.max_image_pixels, config_.max_image_bytes};
  if (!imagesRefusedBeforeDecode(k.images, *prepared.camera, limits).empty()) return prepared;
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = threadCpuMs();
  prepared.decoded = decode(decode_extractor_, k, *prepared.camera);
  decoded_ahead_.fetch_add(1, std::memory_order_relaxed);
  prepared.decode_ms = msSince(t0);
  prepared.decode_cpu_ms = threadCpuMs() - cpu0;
  return prepared;
}

Result<DecodedKeyframe> KeyframeDecoder::decodeOnWorker(const msg::Keyframe& kf,
                                                        const CameraIntrinsics& camera) {
  return decode(worker_extractor_, kf, camera);
}

Result<DecodedKeyframe> KeyframeDecoder::decode(OrbExtractor& extractor, const msg::Keyframe& kf,
                                                const CameraIntrinsics& camera) {
  using R = Result<DecodedKeyframe>;
  auto images = msg::decodeKeyframeImages(kf);
  if (!images) return R::failure("images: " + images.error());
  if (needsServerFeatures(kf)) {
    // Used as they are stored (float keypoints and depths): a restart, or the feature cache reading them
    // back, gets exactly these.
    msg::Keyframe as_stored;
    as_stored.keyframe_id = kf.keyframe_id;
    if (const Status s = putFeatures(extractServerFeatures(extractor, *images, camera), &as_stored); !s)
      return R::failure("extracted features: " + s.error());
    auto features = featuresFromMessage(as_stored, PinholeCamera(camera));
    if (!features) return R::failure(features.error());
    return DecodedKeyframe{std::move(*images), std::move(*features)};
  }
  auto features = featuresFromMessage(kf, PinholeCamera(camera));
  if (!features) return R::failure(features.error());
  return DecodedKeyframe{std::move(*images), std::move(*features)};
}

void KeyframeDecoder::noteSeen(const KeyframeKey& key) {
  std::lock_guard<std::mutex> lock(seen_mutex_);
  seen_.insert(key);
}

bool KeyframeDecoder::seen(const KeyframeKey& key) const {
  std::lock_guard<std::mutex> lock(seen_mutex_);
  return seen_.count(key) != 0;
}

}  // namespace rgbdmap
