// The ingest pipeline's path for robots that localise in the map: decoded, matched against the map's
// keyframes, judged by the placement rules, acknowledged and answered with corrections. Nothing is stored
// and the graph, the map worker's octree and the map files do not change.
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/ingest/ingest_pipeline.hpp"
#include "rgbdmap/intake/image_admission.hpp"

namespace rgbdmap {

void IngestPipeline::localizeLocked(Prepared prepared, const CameraIntrinsics& camera, int robot,
                                    Lock& lock) {
  const msg::Keyframe& kf = prepared.keyframe;
  const int64_t session = kf.header.session;
  // Refused keyframes of a localising robot are counted; none is remembered (nothing waits for them).
  const auto refuse = [&](const std::string& reason) {
    ++stats_.keyframes_refused;
    registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kRefused);
    lock.unlock();
    answer(kf, false, reason);
  };
  if (!config_.allow_localize && !config_.frozen_map)
    return refuse("this server does not allow localize mode (server.allow_localize)");
  if (localize_.seen(kf.robot_id, session, kf.keyframe_id)) {
    registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kDuplicate);
    lock.unlock();
    return answer(kf, true, "duplicate");
  }
  const auto received = LocalizeSessions::Clock::now();
  const ImageLimits limits{config_.max_image_pixels, config_.max_image_bytes};
  std::string why = imagesRefusedBeforeDecode(kf.images, camera, limits);
  const bool ahead = prepared.decoded && prepared.camera && sameIntrinsics(*prepared.camera, camera);
  Result<Decoded> decoded = !why.empty() ? Result<Decoded>::failure(why)
                            : ahead      ? std::move(*prepared.decoded)
                                         : decoder_.decodeOnWorker(kf, camera);
  if (!decoded) {
    log::warn("server: keyframe ", kf.keyframe_id, " of ", kf.robot_id,
              " (localising) refused: ", decoded.error());
    return refuse(decoded.error());
  }
  const SE3 mount = registry_.mount(kf.robot_id);
  const std::optional<PlacementEstimate> predicted = localize_.predict(kf.robot_id, session, kf);
  auto features = std::make_shared<const FrameFeatures>(std::move(decoded->features));
  const std::vector<PlacementVote> votes =
      graph_.placeVotes(features, MapGraph::kLocalizeRobotBase + robot, -(++localize_queries_), predicted,
                        se3::normalized(mount * kf.T_odom_cam), nullptr);
  LocalizeOutcome outcome = localize_.take(kf, session, mount, votes, received, ++localize_revision_);
  ++stats_.keyframes_localized;
  MapWorker* const map_worker = map_worker_;
  lock.unlock();
  answer(kf, true, "");
  publisher_.publish(kf.robot_id, outcome.corrections);
  if (!map_worker) return;
  // Placed: its slice from the map it is in, at its pose there. Unplaced: from a scratch tree of its own
  // keyframes in its provisional frame (never stored).
  if (outcome.newly_placed) map_worker->dropScratch(kf.robot_id);
  if (outcome.placed) return map_worker->sliceAt(kf.robot_id, outcome.map_id, outcome.T_map_kf);
  map_worker->addScratchKeyframe({-1, kf.robot_id, 0, outcome.T_map_kf, camera, decoded->images.depth,
                                  decoded->images.color, true, kf.keyframe_id, 0});
}

}  // namespace rgbdmap
