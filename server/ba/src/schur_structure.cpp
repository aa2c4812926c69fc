#include "schur_structure.hpp"

#include <algorithm>

namespace rgbdmap::ba_detail {
namespace {

/// The observations taking part, the frames they reach and which of those are unknowns.
void selectFrames(const BaProblem& p, const BaSolveConfig& c, const std::vector<char>& active, bool estimate_w,
                  SchurStructure* s, std::vector<int>* point_count) {
  s->in_problem.assign(s->nf, 0);
  point_count->assign(s->np, 0);
  for (size_t i = 0; i < p.observations.size(); ++i) {
    if (!active[i]) continue;
    s->obs.push_back(static_cast<int>(i));
    s->in_problem[p.observations[i].frame] = 1;
    ++(*point_count)[p.observations[i].point];
  }
  s->frame_var.assign(s->nf, -1);
  s->pose_free.assign(s->nf, 0);
  s->w_var.assign(s->nf, 0);
  s->has_prior.assign(s->nf, 0);
  for (int f = 0; f < s->nf; ++f) {
    if (!s->in_problem[f]) continue;
    const BaFrame& fr = p.frames[f];
    s->has_prior[f] = c.rolling_shutter && !fr.fixed_w;
    s->pose_free[f] = !fr.fixed;
    s->w_var[f] = estimate_w && s->has_prior[f];
    if (s->pose_free[f] || s->w_var[f]) s->frame_var[f] = s->nv++;
    s->free_poses += s->pose_free[f];
  }
  s->var_frame.resize(s->nv);
  for (int f = 0; f < s->nf; ++f)
    if (s->frame_var[f] >= 0) s->var_frame[s->frame_var[f]] = f;
}

/// The point unknowns, and per point its observations by a frame unknown.
void groupByPoint(const BaProblem& p, const std::vector<int>& point_count, SchurStructure* s) {
  s->point_var.assign(s->np, -1);
  for (int j = 0; j < s->np; ++j)
    if (point_count[j] > 0) {
      s->point_var[j] = static_cast<int>(s->var_point.size());
      s->var_point.push_back(j);
    }
  s->npv = static_cast<int>(s->var_point.size());
  const int npv = s->npv;
  // Observations grouped by point (positions in `obs`).
  std::vector<int> point_start(npv + 1, 0), by_point(s->obs.size());
  for (int i : s->obs) ++point_start[s->point_var[p.observations[i].point] + 1];
  for (int j = 0; j < npv; ++j) point_start[j + 1] += point_start[j];
  {
    std::vector<int> fill(point_start.begin(), point_start.end() - 1);
    for (size_t q = 0; q < s->obs.size(); ++q)
      by_point[fill[s->point_var[p.observations[s->obs[q]].point]]++] = static_cast<int>(q);
  }
  s->var_start.assign(npv + 1, 0);
  for (int j = 0; j < npv; ++j) {
    for (int x = point_start[j]; x < point_start[j + 1]; ++x) {
      const int a = s->frame_var[p.observations[s->obs[by_point[x]]].frame];
      if (a < 0) continue;
      s->var_obs.push_back(by_point[x]);
      s->var_of.push_back(a);
    }
    s->var_start[j + 1] = static_cast<int>(s->var_obs.size());
  }
  for (int j = 0; j < npv; ++j)
    s->max_track = std::max(s->max_track, static_cast<size_t>(s->var_start[j + 1] - s->var_start[j]));
}

}  // namespace

SchurStructure buildSchurStructure(const BaProblem& p, const BaSolveConfig& c, const std::vector<char>& active,
                                   bool estimate_w) {
  SchurStructure s;
  s.nf = static_cast<int>(p.frames.size());
  s.np = static_cast<int>(p.points.size());
  std::vector<int> point_count;
  selectFrames(p, c, active, estimate_w, &s, &point_count);
  if (s.free_poses == 0) return s;
  groupByPoint(p, point_count, &s);
  for (const BaPosePrior& q : p.priors) {
    if (!s.in_problem[q.frame_a] || !s.in_problem[q.frame_b]) continue;
    s.priors.push_back(PriorTerm{&q, s.pose_free[q.frame_a] ? s.frame_var[q.frame_a] : -1,
                                 s.pose_free[q.frame_b] ? s.frame_var[q.frame_b] : -1});
  }
  return s;
}

}  // namespace rgbdmap::ba_detail
