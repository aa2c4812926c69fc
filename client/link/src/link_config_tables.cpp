#include "rgbdmap/link/link_config_tables.hpp"

#include "rgbdmap/proto/envelope.hpp"

namespace rgbdmap {

using R = ConfigRange;

const ConfigTable<transport::ReliableSenderOptions>& reliableSenderConfigTable() {
  using C = transport::ReliableSenderOptions;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("max_pending", &C::max_pending, R::closed(1, 100000),
               "keyframes in flight (unacknowledged); the send window")
          .add("adaptive", &C::adaptive,
               "true: the first retransmission after the timeout adapted to the measured ack latency "
               "(RFC 6298: smoothed latency + 4 x its deviation); false: after initial_backoff_ms")
          .add("initial_backoff_ms", &C::initial_backoff, R::closed(1, 600000),
               "first retransmission after this long until an ack was measured (always: adaptive false); "
               "dds://, which repairs losses itself: at least 1000 ...")
          .add("min_backoff_ms", &C::min_backoff, R::closed(1, 600000),
               "adaptive: the timeout never below this (<= initial_backoff_ms; dds://: at least 1000)")
          .add("max_backoff_ms", &C::max_backoff, R::closed(1, 600000),
               "... growing by backoff_factor per attempt up to this (>= initial_backoff_ms)")
          .add("backoff_factor", &C::backoff_factor, R::closed(1.0, 10.0), "")
          .add("jitter", &C::jitter, R::closed(0.0, 0.9),
               "each delay scaled by 1 + U(-jitter, +jitter); adaptive: 1 + U(0, jitter)")
          .add("max_attempts", &C::max_attempts, R::closed(0, 100000),
               "transmissions per keyframe (first included) before it is given up; 0 = until acknowledged "
               "(or the end of the run)");
  return table;
}

const ConfigTable<ImageCodecOptions>& imageCodecConfigTable() {
  using C = ImageCodecOptions;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .addChoice(
              "color", &C::color,
              {{ColorCodec::kJpeg, "jpeg"}, {ColorCodec::kLossless, "lossless"}, {ColorCodec::kNone, "none"}},
              "")
          .add("jpeg_quality", &C::jpeg_quality, R::closed(1, 100), "")
          .add("max_keyframe_bytes", &C::max_keyframe_bytes, R::closed(0, msg::kMaxEnvelopeBytes),
               "depth + JPEG above this: colour re-encoded at lower quality; 0 = no budget")
          .add("min_jpeg_quality", &C::min_jpeg_quality, R::closed(1, 100),
               "lowest quality the budget may step down to")
          .addChoice("depth_filter", &C::depth_filter,
                     {{DepthFilter::kRankCtx, "rank-ctx"},
                      {DepthFilter::kRankMed, "rank-med"},
                      {DepthFilter::kRowDelta, "row-delta"},
                      {DepthFilter::kNone, "none"}},
                     "(rank-ctx is the smallest, rank-med the fastest; depth is always lossless)")
          .add("zstd_level", &C::zstd_level, R::closed(1, 19), "zstd-coded depth and lossless colour");
  return table;
}

const ConfigTable<RobotLinkOptions>& robotLinkConfigTable() {
  using C = RobotLinkOptions;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("heartbeat_period_s", &C::heartbeat_period_s, R::closed(0.01, 3600.0),
               "Heartbeat (last keyframe, segment, tracking state, uptime) every this many seconds")
          .add("hello_period_s", &C::hello_period_s, R::closed(0.01, 3600.0),
               "Hello again every this many seconds (at most 0.2 s once the server was heard) until the "
               "server shows it registered the robot")
          .add("send_timeout_s", &C::send_timeout_s, R::closed(0.0, 3600.0),
               "a keyframe waits at most this long for room in the send window, then is skipped")
          .add("chunk_bytes", &C::chunk_bytes, R::closed(-1, msg::kMaxChunkBytes),
               "keyframes in acknowledged chunks of this size (256..60000); 0 = whole; -1 = by transport: "
               "1100 on udpm://, else 0")
          .add("pose_period_s", &C::pose_period_s, R::closed(0.0, 3600.0),
               "the live pose (RobotPose, for visualisers) at most every this many seconds; 0 = never")
          .add("send_features", &C::send_features,
               "keyframes carry the odometry's keypoints and descriptors; false: the server extracts them "
               "from "
               "the colour image (its features: section must match the odometry's orb: section)")
          .section("reliable", "keyframe delivery (resent until acknowledged)")
          .nest("reliable.", &C::reliable, reliableSenderConfigTable())
          .section("codec", "keyframe images (rgbdmap/codec/image_codec.hpp)")
          .nest("codec.", &C::codec, imageCodecConfigTable());
  return table;
}

}  // namespace rgbdmap
