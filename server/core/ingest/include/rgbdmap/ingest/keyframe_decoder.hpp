#pragma once
// The decode side of the ingest: a keyframe's images decoded and its features read (or extracted when the
// robot sent none), and the set of keyframes seen before (stored or refused), so that a resend is not
// decoded again. prepare() runs on IngestQueue's decode thread without the ingest state lock;
// decodeOnWorker() on the ingest worker (under the state lock), each with a feature extractor of its own.
#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <set>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/ingest/keyframe_index.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/model/map_server_config.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/vision/features.hpp"

namespace rgbdmap {

/// A keyframe's decoded images and features.
struct DecodedKeyframe {
  DecodedImages images;
  FrameFeatures features;
};

/// A keyframe as the decode thread left it: decoded for `camera`, or not (`decoded` empty: no camera yet,
/// seen before, or refused before decoding) and then the ingest worker decodes it.
struct PreparedKeyframe {
  msg::Keyframe keyframe;
  std::optional<CameraIntrinsics> camera;  ///< what it was decoded for (a Hello may change it meanwhile)
  std::optional<Result<DecodedKeyframe>> decoded;
  double decode_ms = 0.0;      ///< wall
  double decode_cpu_ms = 0.0;  ///< the decode thread's CPU time
};

class KeyframeDecoder {
 public:
  /// References must outlive the decoder.
  KeyframeDecoder(const MapServerConfig& config, const RobotRegistry& registry);

  /// The decode thread: decodes the images and the features outside the state lock. Not decoded: a
  /// keyframe of a robot without a camera yet, one seen before (a resend), or one whose image headers the
  /// camera refuses.
  PreparedKeyframe prepare(msg::Keyframe keyframe);
  /// The ingest worker: the same with its own extractor (images, features as sent or extracted from the
  /// colour).
  Result<DecodedKeyframe> decodeOnWorker(const msg::Keyframe& kf, const CameraIntrinsics& camera);

  /// Keys stored or refused (any thread).
  void noteSeen(const KeyframeKey& key);
  bool seen(const KeyframeKey& key) const;
  /// Keyframes prepare() decoded.
  uint64_t decodedAhead() const { return decoded_ahead_.load(std::memory_order_relaxed); }

 private:
  static Result<DecodedKeyframe> decode(OrbExtractor& extractor, const msg::Keyframe& kf,
                                        const CameraIntrinsics& camera);

  const MapServerConfig& config_;
  const RobotRegistry& registry_;
  OrbExtractor worker_extractor_;  ///< config_.features, for the ingest worker
  OrbExtractor decode_extractor_;  ///< the same, for prepare() (the decode thread only)
  mutable std::mutex seen_mutex_;  ///< seen_ (not the state lock: prepare() must not wait for an ingest)
  std::set<KeyframeKey> seen_;     ///< stored or refused (a few bytes per keyframe)
  std::atomic<uint64_t> decoded_ahead_{0};
};

}  // namespace rgbdmap
