#include "rgbdmap/backend/optimizer_batch.hpp"

#include <iterator>
#include <utility>

namespace rgbdmap {

void OptimizerBatch::append(OptimizerBatch&& other) {
  std::move(other.nodes.begin(), other.nodes.end(), std::back_inserter(nodes));
  std::move(other.edges.begin(), other.edges.end(), std::back_inserter(edges));
  std::move(other.keyframes.begin(), other.keyframes.end(), std::back_inserter(keyframes));
  std::move(other.w_priors.begin(), other.w_priors.end(), std::back_inserter(w_priors));
  for (auto& [id, m] : other.matches) matches.insert_or_assign(id, std::move(m));
  solve = solve || other.solve;
  must_solve = must_solve || other.must_solve;
  merge = merge || other.merge;
  global = global || other.global;
}

}  // namespace rgbdmap
