// Text and JSON renderings of ATE / RPE results (the same fields, one list each).
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "rgbdmap/dataset/evaluation.hpp"
#include "rgbdmap/dataset/evaluation_json.hpp"

namespace rgbdmap {
namespace {

using Fields = std::vector<std::pair<std::string, double>>;

/// Shortest form that round-trips to 9 significant digits; JSON has no NaN/Inf, so those become null.
std::string number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string lines(const std::string& prefix, const Fields& fields) {
  std::string out;
  for (const auto& [key, value] : fields) out += prefix + key + " " + number(value) + "\n";
  return out;
}

/// The fields as JSON members, 9 significant digits (as the text lines), non-finite values as null.
Json jsonObject(const Fields& fields) {
  Json out = Json::object();
  for (const auto& [key, value] : fields) out[key] = jsonNumber(value, 9);
  return out;
}

Fields ateFields(const AteResult& a) {
  return {{"matched", static_cast<double>(a.matched)},
          {"rmse_m", a.rmse},
          {"mean_m", a.mean},
          {"median_m", a.median},
          {"std_m", a.std},
          {"min_m", a.min},
          {"max_m", a.max},
          {"scale", a.scale}};
}

Fields rpeFields(const RpeResult& r) {
  return {{"pairs", static_cast<double>(r.pairs)},
          {"delta_s", r.delta_s},
          {"trans_rmse_m", r.trans_rmse},
          {"trans_mean_m", r.trans_mean},
          {"trans_median_m", r.trans_median},
          {"trans_std_m", r.trans_std},
          {"trans_min_m", r.trans_min},
          {"trans_max_m", r.trans_max},
          {"rot_rmse_deg", r.rot_rmse_deg},
          {"rot_mean_deg", r.rot_mean_deg},
          {"rot_median_deg", r.rot_median_deg},
          {"rot_std_deg", r.rot_std_deg},
          {"rot_min_deg", r.rot_min_deg},
          {"rot_max_deg", r.rot_max_deg}};
}

Json jsonArray(std::initializer_list<double> values) {
  Json out = Json::array();
  for (double v : values) out.push_back(jsonNumber(v, 9));
  return out;
}

}  // namespace

std::string formatAte(const AteResult& ate) {
  std::string out = lines("ate_", ateFields(ate));
  const Vec3 t = ate.T_gt_est.translation();
  const Eigen::Quaterniond q = se3::quat(ate.T_gt_est);
  char buf[256];
  std::snprintf(buf, sizeof buf, "ate_T_gt_est %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n", t.x(), t.y(), t.z(),
                q.x(), q.y(), q.z(), q.w());
  out += buf;
  if (!ate.alignment_unique) out += "ate_alignment_unique 0\n";
  return out;
}

std::string formatRpe(const RpeResult& rpe) { return lines("rpe_", rpeFields(rpe)); }

Json ateJson(const AteResult& ate) {
  const Vec3 t = ate.T_gt_est.translation();
  const Eigen::Quaterniond q = se3::quat(ate.T_gt_est);
  Json out = jsonObject(ateFields(ate));
  out["alignment_unique"] = ate.alignment_unique;
  out["T_gt_est"] = {{"t", jsonArray({t.x(), t.y(), t.z()})},
                     {"q_xyzw", jsonArray({q.x(), q.y(), q.z(), q.w()})}};
  return out;
}

Json rpeJson(const RpeResult& rpe) { return jsonObject(rpeFields(rpe)); }

}  // namespace rgbdmap
