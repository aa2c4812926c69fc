// LandmarkMap: covisibility, the windows of local and global bundle adjustment, and their results applied.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <tuple>
#include <unordered_set>

#include <Eigen/SVD>

#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/common/union_find.hpp"

namespace rgbdmap {

/// The keyframes a BA moves (`free`), those it holds (`fixed`: pose and rolling-shutter rotation) and the
/// landmarks it refines. A global BA's anchor holds its rolling-shutter rotation too: a rotation common to
/// every readout is nearly a gauge freedom (a stretch of the world along one image axis), and left free it
/// drifts (measured on fr1_rpy: keyframe ATE 0.016-0.018 m with it free, 0.015 m held).
struct LandmarkMap::Window {
  std::vector<int64_t> free, fixed, points;
  int max_track = 0;                  ///< observations taken per landmark, spread over its observers (0: all)
  std::vector<int64_t> selected_for;  ///< with max_track: per point, the keyframe whose observation stays
  std::vector<BundlePrior> priors;
};

namespace {

/// The observations of a landmark a window takes: those by its keyframes, at most `max_track` of them
/// (0: all) spread evenly over the observers in keyframe order, always with keyframe `keep`'s (when it
/// observes the landmark: the keyframe the landmark was selected for).
template <typename Observation, typename InWindow>
std::vector<Observation> observationsTaken(const std::vector<Observation>& obs, int max_track,
                                           const InWindow& in_window, int64_t keep) {
  std::vector<Observation> in;
  for (const auto& o : obs)
    if (in_window(o.first)) in.push_back(o);
  if (max_track <= 0 || in.size() <= static_cast<size_t>(max_track)) return in;
  std::sort(in.begin(), in.end());
  std::vector<size_t> picks;
  const double step = static_cast<double>(in.size() - 1) / static_cast<double>(max_track - 1);
  for (int i = 0; i < max_track; ++i) picks.push_back(static_cast<size_t>(std::lround(i * step)));
  const auto own = std::find_if(in.begin(), in.end(), [keep](const auto& o) { return o.first == keep; });
  if (own != in.end()) {
    const size_t k = static_cast<size_t>(own - in.begin());
    size_t* nearest = &picks[0];
    for (size_t& p : picks)
      if ((p > k ? p - k : k - p) < (*nearest > k ? *nearest - k : k - *nearest)) nearest = &p;
    *nearest = k;  // the picks stay distinct: k lies between its neighbours' picks
  }
  std::vector<Observation> out;
  for (size_t p : picks) out.push_back(in[p]);
  return out;
}

BundleResult failed(std::string why) {
  BundleResult r;
  r.error = std::move(why);
  return r;
}

/// A rigid correction A (T_map_kf <- A * T_map_kf) that puts a set of keyframes back where they were as a
/// whole: the chordal mean of their rotation changes, and the mean of their camera centres kept.
SE3 placementKept(const std::vector<SE3>& before, const std::vector<SE3>& after) {
  Mat3 M = Mat3::Zero();
  Vec3 c_before = Vec3::Zero(), c_after = Vec3::Zero();
  for (size_t i = 0; i < before.size(); ++i) {
    M += before[i].linear() * after[i].linear().transpose();
    c_before += before[i].translation();
    c_after += after[i].translation();
  }
  const Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  SE3 A = SE3::Identity();
  A.linear() = svd.matrixU() * D * svd.matrixV().transpose();
  const double n = static_cast<double>(before.size());
  A.translation() = c_before / n - A.linear() * (c_after / n);
  return A;
}

}  // namespace

/// A bundle adjustment fixes the gauge of its window through the keyframes it holds. A part of the window
/// whose landmarks no held keyframe observes (in a global BA: a room joined to the rest by odometry steps
/// alone, which share no landmark) has none: the solve refines its shape, and where it leaves it as a whole
/// is drift of the solver, not information. Measured in a 6,000-keyframe map: such parts moved, a pose-graph
/// solve pulled them back along their odometry steps, and every round trip re-integrated their clouds. Such
/// a part is put back where it was as a whole (placementKept), with its landmarks.
void LandmarkMap::keepUnheldParts(const BaProblem& p, BaSolution* s, BundleResult* out) const {
  if (config_.part_link_landmarks <= 0) return;
  const size_t nf = p.frames.size();
  std::vector<char> outlier(p.observations.size(), 0);
  for (int o : s->outliers) outlier[o] = 1;
  std::vector<std::vector<int>> observers(p.points.size());
  std::vector<int> seen(nf, 0);
  for (size_t i = 0; i < p.observations.size(); ++i) {
    if (outlier[i]) continue;
    observers[p.observations[i].point].push_back(p.observations[i].frame);
    ++seen[p.observations[i].frame];
  }
  UnionFind parts(nf);
  std::unordered_map<uint64_t, int> shared;  // frame pair -> landmarks both observe
  for (const std::vector<int>& obs : observers)
    for (size_t x = 0; x < obs.size(); ++x)
      for (size_t y = x + 1; y < obs.size(); ++y) {
        const auto [a, b] = std::minmax(obs[x], obs[y]);
        const uint64_t key = (static_cast<uint64_t>(a) << 32) | static_cast<uint32_t>(b);
        if (++shared[key] == config_.part_link_landmarks) parts.join(a, b);
      }
  for (const BaPosePrior& q : p.priors) parts.join(q.frame_a, q.frame_b);
  std::vector<char> held(nf, 0);
  for (size_t f = 0; f < nf; ++f)
    if (p.frames[f].fixed && seen[f] > 0) held[parts.find(f)] = 1;
  std::unordered_map<size_t, std::vector<int>> unheld;  // part root -> its free frames
  for (size_t f = 0; f < nf; ++f)
    if (!p.frames[f].fixed && !held[parts.find(f)]) unheld[parts.find(f)].push_back(static_cast<int>(f));
  std::vector<int> point_part(p.points.size(), -1);
  for (size_t j = 0; j < p.points.size(); ++j)
    if (!observers[j].empty()) point_part[j] = static_cast<int>(parts.find(observers[j].front()));
  for (const auto& [root, frames] : unheld) {
    std::vector<SE3> before, after;
    for (int f : frames) {
      before.push_back(p.frames[f].T_kf_map.inverse());
      after.push_back(s->T_kf_map[f].inverse());
    }
    const SE3 A = placementKept(before, after);
    for (int f : frames) s->T_kf_map[f] = s->T_kf_map[f] * A.inverse();
    for (size_t j = 0; j < p.points.size(); ++j)
      if (point_part[j] == static_cast<int>(root)) s->p_map[j] = A * s->p_map[j];
    ++out->parts_kept;
    out->part_shift_m = std::max(out->part_shift_m, A.translation().norm());
    out->part_shift_deg = std::max(out->part_shift_deg, se3::rotationAngle(A) * 180.0 / M_PI);
  }
}

std::vector<std::pair<int64_t, int>> LandmarkMap::covisible(int64_t id) const {
  std::vector<std::pair<int64_t, int>> out;
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) return out;
  std::unordered_map<int64_t, int> shared;
  for (int64_t l : it->second.landmark)
    if (l >= 0)
      for (const auto& o : landmarks_.at(l).obs)
        if (o.first != id) ++shared[o.first];
  for (const auto& [kf, n] : shared)
    if (n >= config_.min_covisibility) out.emplace_back(kf, n);
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  return out;
}

int LandmarkMap::sharedLandmarks(int64_t a, int64_t b) const {
  const auto ka = keyframes_.find(a);
  if (ka == keyframes_.end() || !keyframes_.count(b)) return 0;
  int n = 0;
  for (int64_t l : ka->second.landmark)
    if (l >= 0 && observes(landmarks_.at(l), b)) ++n;
  return n;
}

std::vector<int64_t> LandmarkMap::keyframesOfMap(int map_id) const {
  std::vector<int64_t> out;
  for (const auto& [id, k] : keyframes_)
    if (k.kf.map_id == map_id) out.push_back(id);
  std::sort(out.begin(), out.end());
  return out;
}

LandmarkMap::Window LandmarkMap::localWindow(int64_t id, int64_t anchor) const {
  Window w;
  w.free.push_back(id);
  const auto cov = covisible(id);
  for (size_t i = 0; i < cov.size() && static_cast<int>(w.free.size()) < config_.local_window; ++i)
    w.free.push_back(cov[i].first);
  const std::unordered_set<int64_t> in_window(w.free.begin(), w.free.end());
  if (in_window.count(anchor)) {  // the map's anchor never moves
    w.free.erase(std::find(w.free.begin(), w.free.end(), anchor));
    w.fixed.push_back(anchor);
  }
  std::unordered_set<int64_t> points;
  std::unordered_map<int64_t, int> outside;  // observers outside the window: how many window points they see
  for (int64_t kf : w.free)
    for (int64_t l : keyframes_.at(kf).landmark)
      if (l >= 0 && points.insert(l).second)
        for (const auto& o : landmarks_.at(l).obs)
          if (!in_window.count(o.first)) ++outside[o.first];
  w.points.assign(points.begin(), points.end());
  std::sort(w.points.begin(), w.points.end());
  std::vector<std::pair<int64_t, int>> fixed(outside.begin(), outside.end());
  std::sort(fixed.begin(), fixed.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  for (size_t i = 0; i < fixed.size() && static_cast<int>(i) < config_.local_fixed_max; ++i)
    w.fixed.push_back(fixed[i].first);
  if (w.fixed.empty() && !w.free.empty()) {
    // Nothing outside holds the gauge: the oldest keyframe of the window does.
    const auto oldest = std::min_element(w.free.begin(), w.free.end());
    w.fixed.push_back(*oldest);
    w.free.erase(oldest);
  }
  return w;
}

LandmarkMap::Window LandmarkMap::globalWindow(int map_id, int64_t anchor) const {
  Window w;
  for (int64_t id : keyframesOfMap(map_id)) (id == anchor ? w.fixed : w.free).push_back(id);
  if (w.fixed.empty() && !w.free.empty()) {
    w.fixed.push_back(w.free.front());
    w.free.erase(w.free.begin());
  }
  // Every keyframe gets its longest tracks (most constraint per observation) until it has its share of
  // global_max_observations; a landmark taken for one keyframe brings all its observations.
  const size_t frames = w.free.size() + w.fixed.size();
  const size_t share = config_.global_max_observations > 0
                           ? std::max<size_t>(static_cast<size_t>(config_.min_frame_observations),
                                              static_cast<size_t>(config_.global_max_observations) / frames)
                           : SIZE_MAX;
  w.max_track = std::max(config_.global_max_track > 0 ? 2 : 0, config_.global_max_track);
  const auto any = [](int64_t) { return true; };
  std::unordered_map<int64_t, size_t> taken;  // keyframe -> its observations selected so far
  std::unordered_set<int64_t> selected;
  for (const auto* group : {&w.fixed, &w.free})
    for (int64_t kf : *group) {
      std::vector<std::pair<size_t, int64_t>> tracks;
      for (int64_t l : keyframes_.at(kf).landmark)
        if (l >= 0 && static_cast<int>(landmarks_.at(l).obs.size()) >= config_.global_min_observations)
          tracks.emplace_back(landmarks_.at(l).obs.size(), l);
      std::sort(tracks.begin(), tracks.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first > b.first : a.second < b.second;
      });
      for (const auto& [n, l] : tracks) {
        if (taken[kf] >= share) break;
        if (!selected.insert(l).second) continue;
        for (const auto& o : observationsTaken(landmarks_.at(l).obs, w.max_track, any, kf)) ++taken[o.first];
        w.points.push_back(l);
        w.selected_for.push_back(kf);
      }
    }
  std::vector<std::pair<int64_t, int64_t>> order;  // sorted by landmark, with their keyframes
  for (size_t i = 0; i < w.points.size(); ++i) order.emplace_back(w.points[i], w.selected_for[i]);
  std::sort(order.begin(), order.end());
  for (size_t i = 0; i < order.size(); ++i) std::tie(w.points[i], w.selected_for[i]) = order[i];
  return w;
}

BaProblem LandmarkMap::problemOf(const Window& w) const {
  BaProblem p;
  std::unordered_map<int64_t, int> frame_index;
  for (const auto* group : {&w.free, &w.fixed})
    for (int64_t id : *group) {
      const Keyframe& k = keyframes_.at(id);
      frame_index[id] = static_cast<int>(p.frames.size());
      const bool fixed = group == &w.fixed;
      p.frames.push_back({id, k.kf.camera, k.kf.T_map_kf.inverse(), fixed, k.w, fixed, k.kf.w_prior});
    }
  for (size_t i = 0; i < w.points.size(); ++i) {
    const int64_t l_id = w.points[i];
    const Landmark& l = landmarks_.at(l_id);
    const int64_t keep = i < w.selected_for.size() ? w.selected_for[i] : -1;
    const int point = static_cast<int>(p.points.size());
    int used = 0;
    const auto in_window = [&](int64_t kf) { return frame_index.count(kf) > 0; };
    for (const auto& [kf, feature] : observationsTaken(l.obs, w.max_track, in_window, keep)) {
      const auto fi = frame_index.find(kf);
      const Keyframe& kk = keyframes_.at(kf);
      const LandmarkKeyframe& k = kk.kf;
      const std::shared_ptr<const FrameFeatures> features = featuresOf(kk);
      if (!features) continue;  // paged out and not readable back: its observations stay out
      const FrameFeatures& f = *features;
      const double row = (f.keypoints[feature].pt.y - 0.5 * k.height) / k.height;
      p.observations.push_back(
          {fi->second, point, f.px[feature], f.keypoints[feature].octave, f.depth_m[feature], row});
      ++used;
    }
    if (used == 0) continue;
    p.points.push_back({l_id, l.p_map});
  }
  for (const BundlePrior& q : w.priors) {
    const auto a = frame_index.find(q.from), b = frame_index.find(q.to);
    if (a == frame_index.end() || b == frame_index.end() || a->second == b->second) continue;
    p.priors.push_back({a->second, b->second, q.T_from_to, q.sqrt_information});
  }
  // Too few observations to move a keyframe reliably: it holds still (and its rolling-shutter rotation).
  std::vector<int> seen(p.frames.size(), 0);
  for (const BaObservation& o : p.observations) ++seen[o.frame];
  for (size_t i = 0; i < p.frames.size(); ++i)
    if (seen[i] < config_.min_frame_observations) p.frames[i].fixed = p.frames[i].fixed_w = true;
  return p;
}

BundleResult LandmarkMap::solveAndApply(const Window& w, int second_iterations, double max_time_s,
                                        bool rolling_shutter, const std::atomic<bool>* cancel,
                                        const BundleCheck& check) {
  BundleResult out;
  const BaProblem problem = problemOf(w);
  BaSolveConfig solve = config_.solve;
  solve.second_iterations = second_iterations;
  solve.rolling_shutter = solve.rolling_shutter && rolling_shutter;
  solve.max_time_s = max_time_s;
  Result<BaSolution> s = solveBundle(problem, solve, cancel);
  if (!s) {
    out.error = s.error();
    return out;
  }
  out.report = s->report;
  if (s->report.cancelled) {
    out.error = "cancelled";
    return out;
  }
  keepUnheldParts(problem, &*s, &out);
  if (check) {
    std::vector<std::pair<int64_t, SE3>> proposed;
    for (size_t i = 0; i < problem.frames.size(); ++i)
      if (!problem.frames[i].fixed)
        proposed.emplace_back(problem.frames[i].id, se3::normalized(s->T_kf_map[i].inverse()));
    if (std::string why = check(proposed); !why.empty()) {
      out.error = std::move(why);
      out.refused = true;
      return out;
    }
  }
  std::vector<int> seen(problem.frames.size(), 0);
  for (const BaObservation& o : problem.observations) ++seen[o.frame];
  for (size_t i = 0; i < problem.frames.size(); ++i) {
    Keyframe& k = keyframes_.at(problem.frames[i].id);
    k.w = s->w[i];
    if (problem.frames[i].fixed) {
      (seen[i] < config_.min_frame_observations ? out.weak : out.fixed).push_back(problem.frames[i].id);
      continue;
    }
    k.kf.T_map_kf = se3::normalized(s->T_kf_map[i].inverse());
    out.moved.push_back(problem.frames[i].id);
  }
  for (size_t i = 0; i < problem.points.size(); ++i) landmarks_.at(problem.points[i].id).p_map = s->p_map[i];
  std::vector<int64_t> touched;
  for (int o : s->outliers) {
    const BaObservation& ob = problem.observations[o];
    const int64_t l = problem.points[ob.point].id;
    detach(l, problem.frames[ob.frame].id);
    touched.push_back(l);
  }
  for (int64_t l : touched) eraseIfShort(l);
  out.outliers_removed = static_cast<int>(s->outliers.size());
  stats_.observations_rejected += out.outliers_removed;
  out.ok = true;
  return out;
}

BundleResult LandmarkMap::localAdjust(int64_t id, int64_t anchor, const std::atomic<bool>* cancel,
                                      const BundleCheck& check) {
  if (!keyframes_.count(id)) return failed("unknown keyframe " + std::to_string(id));
  const Window w = localWindow(id, anchor);
  if (w.free.empty() || w.points.empty()) return failed("nothing to adjust");
  return solveAndApply(w, config_.solve.second_iterations, config_.solve.max_time_s, true, cancel, check);
}

BundleResult LandmarkMap::globalAdjust(int map_id, int64_t anchor, const std::atomic<bool>* cancel,
                                       const BundleCheck& check, const std::vector<BundlePrior>& priors) {
  Window w = globalWindow(map_id, anchor);
  w.priors = priors;
  if (w.free.empty() || w.points.empty()) return failed("nothing to adjust");
  return solveAndApply(w, config_.global_max_iterations, config_.global_max_time_s,
                       config_.global_rolling_shutter, cancel, check);
}

LandmarkStats LandmarkMap::stats() const {
  LandmarkStats s = stats_;
  s.memory_bytes = static_cast<int64_t>(landmarks_.memoryBytes(static_cast<size_t>(stats_.observations)) +
                                        keyframes_.size() * sizeof(Keyframe)) +
                   feature_slots_ * static_cast<int64_t>(sizeof(int32_t));
  return s;
}

int64_t LandmarkMap::landmarkOf(int64_t keyframe, int feature) const {
  const auto it = keyframes_.find(keyframe);
  if (it == keyframes_.end() || feature < 0 || feature >= static_cast<int>(it->second.landmark.size()))
    return -1;
  return it->second.landmark[feature];
}

std::vector<std::pair<int64_t, int>> LandmarkMap::observationsOf(int64_t landmark) const {
  const Landmark* l = landmarks_.find(landmark);
  if (!l) return {};
  return {l->obs.begin(), l->obs.end()};
}

std::optional<Vec3> LandmarkMap::positionOf(int64_t landmark) const {
  const Landmark* l = landmarks_.find(landmark);
  if (!l) return std::nullopt;
  return l->p_map;
}

}  // namespace rgbdmap
