// The viewer's refinement plan and stop rule (refinement.h).
#include "refinement.h"

#include <algorithm>
#include <cmath>

#include "tritrace/render/renderer.h"

namespace tritrace::view {

std::string_view stop_reason_text(StopReason reason) {
  switch (reason) {
    case StopReason::kSpp:
      return "spp reached";
    case StopReason::kConverged:
      return "converged";
    case StopReason::kTimeLimit:
      return "time limit";
    case StopReason::kNone:
      break;
  }
  return "";
}

uint32_t uniform_end(const RefinementLimits& limits) {
  // With the renderer's rule every pixel takes kAdaptivePilotSpp samples before any stops.
  return limits.adaptive() ? std::min(limits.max_spp, kAdaptivePilotSpp) : limits.max_spp;
}

uint32_t next_adaptive_level(uint32_t spp, uint32_t max_spp) {
  if (spp >= max_spp) return 0;
  const uint64_t doubled = 2 * static_cast<uint64_t>(std::max<uint32_t>(spp, 1));
  return static_cast<uint32_t>(std::min<uint64_t>(doubled, max_spp));
}

int level_parts(double ms_per_sample, uint32_t spp, double budget_ms, int tiles) {
  const int most = std::max(tiles, 1);
  if (!(ms_per_sample > 0.0) || !(budget_ms > 0.0)) return 1;
  const double parts = std::ceil(ms_per_sample * spp / budget_ms);
  return static_cast<int>(std::clamp(parts, 1.0, static_cast<double>(most)));
}

StopReason stop_reason(const RefinementLimits& limits, uint32_t spp, bool converged,
                       double rest_seconds) {
  if (spp >= limits.max_spp) return StopReason::kSpp;
  if (converged) return StopReason::kConverged;
  if (limits.time_limit_seconds && rest_seconds >= *limits.time_limit_seconds) {
    return StopReason::kTimeLimit;
  }
  return StopReason::kNone;
}

}  // namespace tritrace::view
