#pragma once
// ATE / RPE results as JSON objects (the fields of formatAte / formatRpe without their prefix, 9 significant
// digits, non-finite values as null), e.g. for `rgbdmap eval --json`.
#include "rgbdmap/common/json_output.hpp"
#include "rgbdmap/dataset/evaluation.hpp"

namespace rgbdmap {

/// {"matched":250,"rmse_m":0.0123,...,"alignment_unique":true,"T_gt_est":{"t":[...],"q_xyzw":[...]}}
Json ateJson(const AteResult& ate);
/// {"pairs":220,"delta_s":1,"trans_rmse_m":...,"rot_max_deg":...}
Json rpeJson(const RpeResult& rpe);

}  // namespace rgbdmap
