// Merge planning: before anything is combined, the parts must be of one render and cover every
// tile part's samples [0, spp) exactly once.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "tritrace/distributed/part.h"

namespace tritrace {

// Checks `parts` (with their names, e.g. paths, in the order given); throws Error naming the
// foreign part (and what differs: build, settings, scene or AOVs), the overlap or what is missing.
// Returns the parts' indices in merge order (tile, then first sample).
std::vector<size_t> plan_merge(const std::vector<std::string>& names,
                               const std::vector<PartInfo>& parts);

}  // namespace tritrace
