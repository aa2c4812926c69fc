// LandmarkMap: keyframes, tracks from verified matches and from matching by projection, fusion, poses.
#include <algorithm>
#include <climits>
#include <cmath>
#include <stdexcept>
#include <string>

#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/vision/guided_matcher.hpp"
#include "rgbdmap/vision/matcher.hpp"

namespace rgbdmap {

LandmarkMap::LandmarkMap(LandmarkMapConfig config) : config_(std::move(config)) {}

PackedMatches PackedMatches::pack(EdgeMatches m) {
  PackedMatches k;
  k.from = m.from;
  k.to = m.to;
  const bool narrow = std::all_of(m.pairs.begin(), m.pairs.end(), [](const std::pair<int, int>& p) {
    return p.first >= 0 && p.first <= 0xffff && p.second >= 0 && p.second <= 0xffff;
  });
  if (!narrow) {
    k.wide = std::move(m.pairs);
    return k;
  }
  k.packed.reserve(m.pairs.size());
  for (const auto& [a, b] : m.pairs)
    k.packed.push_back(static_cast<uint32_t>(a) << 16 | static_cast<uint32_t>(b));
  return k;
}

EdgeMatches PackedMatches::unpack() const {
  EdgeMatches m;
  m.from = from;
  m.to = to;
  m.pairs = wide;
  for (uint32_t p : packed) m.pairs.emplace_back(static_cast<int>(p >> 16), static_cast<int>(p & 0xffff));
  return m;
}

LandmarkMap::Landmark& LandmarkMap::LandmarkTable::at(int64_t id) {
  Landmark* l = find(id);
  if (!l) throw std::out_of_range("landmark " + std::to_string(id));
  return *l;
}

void LandmarkMap::LandmarkTable::add(int64_t id, Landmark l) {
  if (id != static_cast<int64_t>(slots_.size())) throw std::logic_error("landmark ids out of order");
  slots_.push_back(std::move(l));
}

void LandmarkMap::LandmarkTable::erase(int64_t id) {
  Landmark& l = at(id);
  l.reference = -1;
  std::vector<Observation>().swap(l.obs);
}

size_t LandmarkMap::LandmarkTable::memoryBytes(size_t observations) const {
  return slots_.size() * sizeof(Landmark) + observations * sizeof(Observation);
}

Vec3 predictedRollingShutter(const SE3& T_prev_cur, double dt_s, double readout_s) {
  if (!(dt_s > 0.0 && dt_s <= 1.0) || !(readout_s > 0.0)) return Vec3::Zero();
  const Vec3 w = (readout_s / dt_s) * se3::logSO3(T_prev_cur.linear());
  return w.allFinite() ? w : Vec3::Zero();
}

Status LandmarkMap::addKeyframe(LandmarkKeyframe keyframe) {
  if (keyframes_.count(keyframe.id))
    return Status::failure("duplicate keyframe " + std::to_string(keyframe.id));
  if (keyframe.id < 0 || keyframe.id > INT32_MAX)  // observations hold keyframe ids in 32 bits
    return Status::failure("keyframe id " + std::to_string(keyframe.id) + " out of range");
  const FrameFeatures* f = keyframe.features.get();
  if (!f) return Status::failure("keyframe " + std::to_string(keyframe.id) + ": no features");
  const size_t n = f->size();
  if (f->px.size() != n || f->depth_m.size() != n || f->p_cam.size() != n ||
      static_cast<size_t>(f->descriptors.rows) != n || (n > 0 && f->descriptors.cols != 32))
    return Status::failure("keyframe " + std::to_string(keyframe.id) + ": inconsistent features");
  if (!se3::isValid(keyframe.T_map_kf, 1e-4))
    return Status::failure("keyframe " + std::to_string(keyframe.id) + ": invalid pose");
  Keyframe k;
  k.landmark.assign(n, -1);
  k.w = keyframe.w_prior.allFinite() ? keyframe.w_prior : Vec3::Zero();
  k.kf = std::move(keyframe);
  if (cache_ && cache_->contains(k.kf.id)) k.kf.features.reset();  // the cache holds them
  feature_slots_ += static_cast<int64_t>(n);
  keyframes_.emplace(k.kf.id, std::move(k));
  ++stats_.keyframes;
  return Status::success();
}

bool LandmarkMap::setRollingShutterPrior(int64_t id, const Vec3& w_prior) {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end() || !w_prior.allFinite()) return false;
  Keyframe& k = it->second;
  if (k.w == k.kf.w_prior) k.w = w_prior;  // still where it started (e.g. a map's anchor holds it)
  k.kf.w_prior = w_prior;
  return true;
}

std::shared_ptr<const FrameFeatures> LandmarkMap::featuresOf(const Keyframe& k) const {
  if (k.kf.features) return k.kf.features;
  return cache_ ? cache_->get(k.kf.id) : nullptr;
}

Vec3 LandmarkMap::pointOf(const Keyframe& k, const FrameFeatures& f, int feature) const {
  return k.kf.T_map_kf * f.p_cam[feature];
}

bool LandmarkMap::observes(const Landmark& l, int64_t keyframe) const {
  return std::any_of(l.obs.begin(), l.obs.end(), [&](const auto& o) { return o.first == keyframe; });
}

int64_t LandmarkMap::createLandmark(Keyframe& a, const FrameFeatures& a_f, int fa, Keyframe& b,
                                    const FrameFeatures& b_f, int fb) {
  const bool da = a_f.hasDepth(fa), db = b_f.hasDepth(fb);
  if (!da && !db) return -1;
  if (next_landmark_ >= INT32_MAX) return -1;  // keyframes hold landmark ids in 32 bits
  Landmark l;
  l.reference = da ? a.kf.id : b.kf.id;
  l.p_map = da ? pointOf(a, a_f, fa) : pointOf(b, b_f, fb);
  l.obs = {{static_cast<int32_t>(a.kf.id), fa}, {static_cast<int32_t>(b.kf.id), fb}};
  const int64_t id = next_landmark_++;
  a.landmark[fa] = static_cast<int32_t>(id);
  b.landmark[fb] = static_cast<int32_t>(id);
  landmarks_.add(id, std::move(l));
  ++stats_.landmarks;
  stats_.observations += 2;
  return id;
}

bool LandmarkMap::attach(int64_t landmark, Keyframe& k, int feature) {
  Landmark& l = landmarks_.at(landmark);
  if (k.landmark[feature] >= 0 || observes(l, k.kf.id)) return false;
  l.obs.emplace_back(static_cast<int32_t>(k.kf.id), feature);
  k.landmark[feature] = static_cast<int32_t>(landmark);
  ++stats_.observations;
  return true;
}

void LandmarkMap::detach(int64_t landmark, int64_t keyframe) {
  Landmark& l = landmarks_.at(landmark);
  const auto it =
      std::find_if(l.obs.begin(), l.obs.end(), [&](const auto& o) { return o.first == keyframe; });
  if (it == l.obs.end()) return;
  keyframes_.at(keyframe).landmark[it->second] = -1;
  l.obs.erase(it);
  --stats_.observations;
  if (l.reference == keyframe && !l.obs.empty()) l.reference = l.obs.front().first;
}

void LandmarkMap::eraseIfShort(int64_t landmark) {
  const Landmark* l = landmarks_.find(landmark);
  if (!l || l->obs.size() >= 2) return;
  for (const auto& [kf, feature] : l->obs) keyframes_.at(kf).landmark[feature] = -1;
  stats_.observations -= static_cast<int64_t>(l->obs.size());
  landmarks_.erase(landmark);
  --stats_.landmarks;
  ++stats_.landmarks_culled;
}

bool LandmarkMap::fuse(int64_t into, int64_t from) {
  if (into == from) return false;
  Landmark& a = landmarks_.at(into);
  Landmark& b = landmarks_.at(from);
  for (const auto& o : b.obs)
    if (observes(a, o.first)) return false;
  if (b.obs.size() > a.obs.size()) std::swap(into, from);  // keep the longer track (and its position)
  Landmark& keep = landmarks_.at(into);
  Landmark& gone = landmarks_.at(from);
  for (const auto& o : gone.obs) {
    keep.obs.push_back(o);
    keyframes_.at(o.first).landmark[o.second] = static_cast<int32_t>(into);
  }
  landmarks_.erase(from);
  --stats_.landmarks;
  ++stats_.fusions;
  return true;
}

int LandmarkMap::link(Keyframe& a, const FrameFeatures& a_f, int fa, Keyframe& b, const FrameFeatures& b_f,
                      int fb) {
  const int64_t la = a.landmark[fa], lb = b.landmark[fb];
  if (la < 0 && lb < 0) return createLandmark(a, a_f, fa, b, b_f, fb) >= 0 ? 2 : 0;
  if (la >= 0 && lb < 0) return attach(la, b, fb) ? 1 : 0;
  if (lb >= 0 && la < 0) return attach(lb, a, fa) ? 1 : 0;
  return fuse(la, lb) ? 1 : 0;
}

int LandmarkMap::addMatches(const EdgeMatches& m) {
  const auto ia = keyframes_.find(m.from), ib = keyframes_.find(m.to);
  if (ia == keyframes_.end() || ib == keyframes_.end() || m.from == m.to) return 0;
  Keyframe& a = ia->second;
  Keyframe& b = ib->second;
  if (a.kf.map_id != b.kf.map_id) return 0;
  const std::shared_ptr<const FrameFeatures> a_f = featuresOf(a), b_f = featuresOf(b);
  if (!a_f || !b_f) return 0;  // paged out and not readable back (counted by the cache)
  const int na = static_cast<int>(a.landmark.size()), nb = static_cast<int>(b.landmark.size());
  int added = 0;
  for (const auto& [fa, fb] : m.pairs)
    if (fa >= 0 && fa < na && fb >= 0 && fb < nb) added += link(a, *a_f, fa, b, *b_f, fb);
  stats_.links_from_matches += added;
  return added;
}

int LandmarkMap::removeMatches(const EdgeMatches& m) {
  const auto ia = keyframes_.find(m.from), ib = keyframes_.find(m.to);
  if (ia == keyframes_.end() || ib == keyframes_.end()) return 0;
  const int64_t newer = std::max(m.from, m.to);
  int removed = 0;
  for (const auto& [fa, fb] : m.pairs) {
    if (fa < 0 || fb < 0 || fa >= static_cast<int>(ia->second.landmark.size()) ||
        fb >= static_cast<int>(ib->second.landmark.size()))
      continue;
    const int64_t l = ia->second.landmark[fa];
    if (l < 0 || l != ib->second.landmark[fb]) continue;
    detach(l, newer);
    eraseIfShort(l);
    ++removed;
  }
  stats_.observations_rejected += removed;
  return removed;
}

int LandmarkMap::descriptorDistance(const Landmark& l, const uint8_t* descriptor) const {
  // The newest few observations look most like the next view; the first one anchors the track.
  int best = INT_MAX;
  const size_t n = l.obs.size();
  for (size_t j = 0; j < n; ++j) {
    if (j != 0 && j + 3 < n) continue;
    const auto& [kf, feature] = l.obs[j];
    const std::shared_ptr<const FrameFeatures> f = featuresOf(keyframes_.at(kf));
    if (f) best = std::min(best, hammingDistance(f->descriptors.ptr<uint8_t>(feature), descriptor));
  }
  return best;
}

int LandmarkMap::extendByProjection(int64_t id, const std::vector<int64_t>& seeds) {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) return 0;
  Keyframe& k = it->second;
  const std::shared_ptr<const FrameFeatures> features = featuresOf(k);
  if (!features) return 0;  // paged out and not readable back (counted by the cache)
  const FrameFeatures& f = *features;
  const FeatureGrid grid(f, k.kf.width, k.kf.height);
  const SE3 T_kf_map = k.kf.T_map_kf.inverse();
  const BaIntrinsics& cam = k.kf.camera;
  std::vector<int64_t> sources;  // keyframes whose landmarks are projected
  const auto addCovisible = [&](int64_t of, int n) {
    const auto cov = covisible(of);
    for (size_t c = 0; c < cov.size() && static_cast<int>(c) < n; ++c) sources.push_back(cov[c].first);
  };
  addCovisible(id, config_.projection_keyframes);
  for (int64_t seed : seeds) {
    if (seed == id || !keyframes_.count(seed) || keyframes_.at(seed).kf.map_id != k.kf.map_id) continue;
    sources.push_back(seed);
    addCovisible(seed, config_.projection_keyframes / 2);
  }
  std::vector<int64_t> candidates;  // their landmarks that `id` does not see yet
  for (int64_t source : sources)
    if (source != id)
      for (int64_t l : keyframes_.at(source).landmark)
        if (l >= 0) candidates.push_back(l);
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  std::vector<int> nearby;
  int added = 0;
  for (int64_t l_id : candidates) {
    const Landmark* lit = landmarks_.find(l_id);
    if (!lit || observes(*lit, id)) continue;
    const Landmark& l = *lit;
    const Vec3 p = T_kf_map * l.p_map;
    if (p.z() <= 0.05) continue;
    const double u = cam.fx * p.x() / p.z() + cam.cx, v = cam.fy * p.y() / p.z() + cam.cy;
    const auto& ref = l.obs.front();
    const std::shared_ptr<const FrameFeatures> ref_f = featuresOf(keyframes_.at(ref.first));
    if (!ref_f) continue;
    const int octave = ref_f->keypoints[ref.second].octave;
    grid.query(u, v, config_.projection_radius_px * std::pow(config_.solve.scale_factor, octave), &nearby);
    int best = INT_MAX, second = INT_MAX, best_i = -1;
    for (int i : nearby) {
      if (f.hasDepth(i)) {
        const double r = (1.0 / p.z() - 1.0 / f.depth_m[i]) / config_.solve.inverse_depth_sigma;
        if (r * r > config_.projection_depth_chi2) continue;
      }
      const int d = descriptorDistance(l, f.descriptors.ptr<uint8_t>(i));
      if (d < best) {
        second = best;
        best = d;
        best_i = i;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_i < 0 || best > config_.projection_max_distance ||
        (second != INT_MAX && best > config_.projection_ratio * second))
      continue;
    const int64_t owner = k.landmark[best_i];
    const int n = owner < 0 ? (attach(l_id, k, best_i) ? 1 : 0) : (fuse(owner, l_id) ? 1 : 0);
    added += n;
  }
  stats_.links_from_projection += added;
  return added;
}

void LandmarkMap::setPose(int64_t id, int map_id, const SE3& T_map_kf) {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) return;
  LandmarkKeyframe& kf = it->second.kf;
  const SE3 T_new_old = T_map_kf * kf.T_map_kf.inverse();
  const bool moved = !T_new_old.isApprox(SE3::Identity(), 1e-12) || kf.map_id != map_id;
  kf.T_map_kf = T_map_kf;
  kf.map_id = map_id;
  if (!moved) return;
  for (int64_t l : it->second.landmark) {
    if (l < 0) continue;
    Landmark& lm = landmarks_.at(l);
    if (lm.reference == id) lm.p_map = T_new_old * lm.p_map;
  }
}

std::optional<Vec3> LandmarkMap::rollingShutter(int64_t id) const {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) return std::nullopt;
  return it->second.w;
}

std::optional<SE3> LandmarkMap::pose(int64_t id) const {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) return std::nullopt;
  return it->second.kf.T_map_kf;
}

}  // namespace rgbdmap
