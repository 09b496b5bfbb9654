// How the viewer refines a resting view of the path tracer, and when it stops: up to --spp, until
// --time-limit seconds after the view came to rest, and with --noise-threshold until every pixel
// has converged. Plain arithmetic, unit-tested without SDL.
//
// With a noise threshold the renderer sets each pixel's budget from its neighbours' first
// kAdaptivePilotSpp samples (render/renderer.h), so an adaptive render cannot be continued frame by
// frame the way a uniform one can. The viewer therefore accumulates uniformly, frame by frame, up
// to the first count at which a pixel can stop (before it an adaptive render takes every sample, so
// the film is the adaptive one bit for bit), and then renders whole adaptive images of twice the
// samples each time (128, 256, ... up to --spp), each split into tile parts that fit a frame, so
// that keys still answer within a frame while a level renders. Each level is exactly the image
// `tritrace render --spp N --noise-threshold T` writes.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace tritrace::view {

// Why refinement of the view at rest has stopped (kNone: it goes on).
enum class StopReason { kNone, kSpp, kConverged, kTimeLimit };

// "spp reached", "converged", "time limit"; empty for kNone.
std::string_view stop_reason_text(StopReason reason);

struct RefinementLimits {
  uint32_t max_spp = 1;                        // --spp: the most samples a pixel takes at rest
  float noise_threshold = 0.0f;                // --noise-threshold; 0: uniform sampling
  std::optional<double> time_limit_seconds{};  // --time-limit, from the moment the view rests
  bool adaptive() const { return noise_threshold > 0.0f; }
};

// Where frame-by-frame accumulation ends: max_spp, or with a noise threshold the first count at
// which the renderer can stop a pixel (kAdaptivePilotSpp) when that is smaller.
uint32_t uniform_end(const RefinementLimits& limits);

// The adaptive level after an image of `spp` samples: twice as many, at most max_spp; 0 when spp
// already is max_spp (or more).
uint32_t next_adaptive_level(uint32_t spp, uint32_t max_spp);

// How many tile parts a level of `spp` samples is split into so that each part takes about
// `budget_ms`, from the measured cost of one sample of the whole image (an adaptive level costs at
// most spp times that): at least 1, at most `tiles` (the image's 16 x 16 tiles).
int level_parts(double ms_per_sample, uint32_t spp, double budget_ms, int tiles);

// The stop rule, checked after every frame at rest: `spp` the samples of the image shown,
// `converged` whether the last adaptive level stopped every pixel before its last sample (a
// larger level would then make the same image), `rest_seconds` the time since the view came to
// rest. The samples are checked first: an image at max_spp is complete whatever the clock says.
StopReason stop_reason(const RefinementLimits& limits, uint32_t spp, bool converged,
                       double rest_seconds);

}  // namespace tritrace::view
