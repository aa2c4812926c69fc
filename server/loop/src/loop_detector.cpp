#include "rgbdmap/loop/loop_detector.hpp"

#include <algorithm>
#include <chrono>
#include <optional>
#include <utility>

#include "rgbdmap/loop/loop_config_tables.hpp"

namespace rgbdmap {
namespace {

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

bool consistent(const FrameFeatures& f) {
  const size_t n = f.keypoints.size();
  return static_cast<size_t>(f.descriptors.rows) == n && f.px.size() == n && f.depth_m.size() == n &&
         f.p_cam.size() == n && (n == 0 || (f.descriptors.type() == CV_8U && f.descriptors.cols == 32));
}

}  // namespace

std::string LoopDetectorConfig::validate() const {
  return joinProblems(loopDetectorConfigTable().problems(*this));
}

LoopDetector::LoopDetector(const CameraIntrinsics& default_camera, const LoopDetectorConfig& config)
    : config_(config),
      default_camera_(default_camera),
      hasher_(config.words),
      index_(config.words),
      rng_(config.candidates.seed) {}

void LoopDetector::setRobotCamera(int robot_id, const CameraIntrinsics& intrinsics) {
  robot_cameras_.insert_or_assign(robot_id, PinholeCamera(intrinsics));
}

const PinholeCamera& LoopDetector::cameraOf(int robot_id) const {
  const auto it = robot_cameras_.find(robot_id);
  return it == robot_cameras_.end() ? default_camera_ : it->second;
}

void LoopDetector::setFeatureCache(std::shared_ptr<FeatureCache> cache) { cache_ = std::move(cache); }

std::shared_ptr<const FrameFeatures> LoopDetector::featuresOf(const LoopKeyframe& kf) const {
  if (kf.features) return kf.features;
  return cache_ ? cache_->get(kf.id) : nullptr;
}

void LoopDetector::store(LoopKeyframe keyframe) {
  // With a cache that knows them, the cache decides whether they stay in RAM.
  if (cache_ && cache_->contains(keyframe.id)) keyframe.features.reset();
  slot_of_.emplace(keyframe.id, keyframes_.size());
  keyframes_.push_back(std::move(keyframe));
}

const LoopKeyframe* LoopDetector::find(int keyframe_id) const {
  const auto it = slot_of_.find(keyframe_id);
  return it == slot_of_.end() ? nullptr : &keyframes_[it->second];
}

bool LoopDetector::updatePose(int keyframe_id, int map_id, const SE3& T_map_kf) {
  const auto it = slot_of_.find(keyframe_id);
  if (it == slot_of_.end()) return false;
  keyframes_[it->second].map_id = summaries_[it->second].map_id = map_id;
  keyframes_[it->second].T_map_kf = summaries_[it->second].T_map_kf = T_map_kf;
  return true;
}

std::vector<RetrievalHit> LoopDetector::retrieve(const LoopKeyframe& kf, int robot_sequence,
                                                 const WordHistogram& words) const {
  RetrievalQuery q;
  q.robot_id = kf.robot_id;
  q.robot_sequence = robot_sequence;
  q.exclude_recent = config_.candidates.exclude_recent;
  q.top_n = config_.candidates.retrieval_top_n;
  q.min_score = config_.min_retrieval_score;
  return index_.query(words, q);
}

LoopThresholds LoopDetector::thresholdsFor(const LoopKeyframe& kf, const LoopCandidate& c,
                                           const LoopKeyframe& other, const MeasuredPoses* measured) const {
  std::optional<SE3> T_from_to_prior;
  if (measured)
    if (const auto it = measured->find(other.id); it != measured->end()) T_from_to_prior = it->second;
  if ((c.sources & kSourceRetrieval) != 0) {
    LoopThresholds t = retrievalThresholds(config_.verify);
    t.T_from_to_prior = T_from_to_prior;  // only a measured one: the estimates may be far off there
    return t;
  }
  if (!T_from_to_prior && kf.map_id == other.map_id) T_from_to_prior = kf.T_map_kf.inverse() * other.T_map_kf;
  return localThresholds(config_.verify, T_from_to_prior);
}

void LoopDetector::verifyCandidates(const LoopKeyframe& kf, const MeasuredPoses* measured,
                                    LoopDetection* out) const {
  const PinholeCamera& camera = cameraOf(kf.robot_id);
  const FeatureGrid grid(*kf.features, camera.intrinsics().width, camera.intrinsics().height);
  // With a fallback budget the candidates go best retrieval score first (then in their order), so the
  // budget goes to the likeliest revisits; the edges come out in the same order as without one.
  std::vector<size_t> order(out->candidates.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  const int budget = config_.max_fallbacks_per_keyframe;
  if (budget > 0)
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return out->candidates[a].retrieval_score > out->candidates[b].retrieval_score;
    });
  std::vector<std::optional<LoopEdge>> edges(order.size());
  int fallbacks = 0;
  for (size_t i : order) {
    const LoopCandidate& c = out->candidates[i];
    const LoopKeyframe& other = keyframes_[slot_of_.at(c.keyframe_id)];
    const std::shared_ptr<const FrameFeatures> other_features = featuresOf(other);
    if (!other_features) {  // paged out and not readable back (counted by the cache)
      ++out->stats.features_unavailable;
      continue;
    }
    LoopThresholds thresholds = thresholdsFor(kf, c, other, measured);
    thresholds.allow_fallback = budget <= 0 || fallbacks < budget;
    LoopVerification v =
        verifyLoop(kf.id, *kf.features, other.id, *other_features, camera, config_.verify, thresholds, &grid);
    ++out->stats.rejected_by_reason[static_cast<int>(v.rejection)];
    if (v.brute_force) ++(v.had_prior ? out->stats.brute_force_fallback : out->stats.brute_force_no_prior);
    if (v.brute_force && v.had_prior) ++fallbacks;
    if (v.brute_force && v.had_prior && v.edge) ++out->stats.brute_force_fallback_verified;
    if (v.fallback_refused) ++out->stats.fallbacks_skipped;
    edges[i] = std::move(v.edge);
  }
  for (std::optional<LoopEdge>& e : edges)
    if (e) out->edges.push_back(std::move(*e));
  dropInconsistent(out);
  out->stats.verified = static_cast<int>(out->edges.size());
  out->stats.rejected_by_reason[0] = 0;
}

void LoopDetector::dropInconsistent(LoopDetection* out) const {
  const std::vector<char> keep = checkEdgeConsistency(out->edges, accepted_, config_.consistency);
  std::vector<LoopEdge> kept;
  for (size_t i = 0; i < keep.size(); ++i) {
    if (keep[i])
      kept.push_back(out->edges[i]);
    else
      ++out->stats.rejected_by_reason[static_cast<int>(LoopRejection::kInconsistentPose)];
  }
  out->edges = std::move(kept);
}

Result<LoopDetection> LoopDetector::addKeyframe(LoopKeyframe keyframe, const MeasuredPoses* measured) {
  const auto t0 = std::chrono::steady_clock::now();
  if (slot_of_.count(keyframe.id) != 0)
    return Result<LoopDetection>::failure("duplicate keyframe id " + std::to_string(keyframe.id));
  if (!keyframe.features || !consistent(*keyframe.features))
    return Result<LoopDetection>::failure("keyframe " + std::to_string(keyframe.id) +
                                          ": missing or inconsistent features");
  LoopDetection out;
  const int robot_sequence = robot_count_[keyframe.robot_id]++;
  const WordHistogram words = hasher_.histogram(keyframe.features->descriptors);
  const std::vector<RetrievalHit> hits = retrieve(keyframe, robot_sequence, words);
  index_.insert(keyframe.id, keyframe.robot_id, robot_sequence, words);
  out.stats.retrieval_ms = msSince(t0);

  const KeyframeSummary summary{keyframe.id, keyframe.robot_id, keyframe.map_id, keyframe.T_map_kf};
  out.candidates = selectLoopCandidates(summary, summaries_, hits, config_.candidates, &rng_);
  out.stats.candidates = static_cast<int>(out.candidates.size());
  for (const LoopCandidate& c : out.candidates)
    for (int b = 0; b < kCandidateSourceCount; ++b) out.stats.candidates_by_source[b] += (c.sources >> b) & 1;

  const auto t1 = std::chrono::steady_clock::now();
  verifyCandidates(keyframe, measured, &out);
  out.stats.verify_ms = msSince(t1);

  summaries_.push_back(summary);
  store(std::move(keyframe));
  for (const LoopEdge& e : out.edges) accepted_.add(e);
  out.stats.total_ms = msSince(t0);
  accumulate(out.stats);
  return out;
}

Result<LoopDetection> LoopDetector::place(const LoopKeyframe& query) const {
  const auto t0 = std::chrono::steady_clock::now();
  if (slot_of_.count(query.id) != 0)
    return Result<LoopDetection>::failure("place: keyframe id " + std::to_string(query.id) + " is stored");
  if (!query.features || !consistent(*query.features))
    return Result<LoopDetection>::failure("place: missing or inconsistent features");
  LoopDetection out;
  const auto count = robot_count_.find(query.robot_id);
  const WordHistogram words = hasher_.histogram(query.features->descriptors);
  const std::vector<RetrievalHit> hits =
      retrieve(query, count == robot_count_.end() ? 0 : count->second, words);
  out.stats.retrieval_ms = msSince(t0);
  const KeyframeSummary summary{query.id, query.robot_id, query.map_id, query.T_map_kf};
  // Recent and random candidates are the robot's own: none are stored.
  out.candidates = selectLoopCandidates(summary, summaries_, hits, config_.candidates, nullptr);
  out.stats.candidates = static_cast<int>(out.candidates.size());
  for (const LoopCandidate& c : out.candidates)
    for (int b = 0; b < kCandidateSourceCount; ++b) out.stats.candidates_by_source[b] += (c.sources >> b) & 1;
  const auto t1 = std::chrono::steady_clock::now();
  verifyCandidates(query, nullptr, &out);
  out.stats.verify_ms = msSince(t1);
  out.stats.total_ms = msSince(t0);
  return out;
}

Status LoopDetector::restoreKeyframe(LoopKeyframe keyframe) {
  if (slot_of_.count(keyframe.id) != 0)
    return Status::failure("duplicate keyframe id " + std::to_string(keyframe.id));
  if (!keyframe.features || !consistent(*keyframe.features))
    return Status::failure("keyframe " + std::to_string(keyframe.id) + ": missing or inconsistent features");
  const int robot_sequence = robot_count_[keyframe.robot_id]++;
  index_.insert(keyframe.id, keyframe.robot_id, robot_sequence,
                hasher_.histogram(keyframe.features->descriptors));
  summaries_.push_back({keyframe.id, keyframe.robot_id, keyframe.map_id, keyframe.T_map_kf});
  store(std::move(keyframe));
  return Status::success();
}

void LoopDetector::restoreEdge(const LoopEdge& edge) { accepted_.add(edge); }

void LoopDetector::accumulate(const LoopStats& s) {
  for (int b = 0; b < kCandidateSourceCount; ++b)
    totals_.candidates_by_source[b] += s.candidates_by_source[b];
  for (int r = 0; r < kLoopRejectionCount; ++r) totals_.rejected_by_reason[r] += s.rejected_by_reason[r];
  totals_.candidates += s.candidates;
  totals_.verified += s.verified;
  totals_.brute_force_no_prior += s.brute_force_no_prior;
  totals_.brute_force_fallback += s.brute_force_fallback;
  totals_.brute_force_fallback_verified += s.brute_force_fallback_verified;
  totals_.fallbacks_skipped += s.fallbacks_skipped;
  totals_.features_unavailable += s.features_unavailable;
  totals_.retrieval_ms += s.retrieval_ms;
  totals_.verify_ms += s.verify_ms;
  totals_.total_ms += s.total_ms;
}

}  // namespace rgbdmap
