#pragma once
// Config tables (rgbdmap/common/config_table.hpp) of loop closure: keys (the server's `loop:` section),
// ranges and meanings. LoopDetectorConfig::validate() checks against them.
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/loop/loop_detector.hpp"

namespace rgbdmap {

const ConfigTable<LoopCandidateConfig>& loopCandidateConfigTable();
const ConfigTable<LoopVerifyConfig>& loopVerifyConfigTable();
const ConfigTable<BinaryWordsConfig>& binaryWordsConfigTable();
const ConfigTable<LoopConsistencyConfig>& loopConsistencyConfigTable();
/// Candidates, verification and min_retrieval_score under flat keys (recent_k, min_inliers, ...); words.*
/// and consistency.* are set by code only.
const ConfigTable<LoopDetectorConfig>& loopDetectorConfigTable();

}  // namespace rgbdmap
