// `--light-paths auto`: a short pilot that chooses bdpt's share F of samples that trace a light
// subpath (BdptSettings::light_paths) for a scene, among kPilotShares {1, 1/2, ..., 1/64}, by
// the smallest estimated variance x cost (Grittmann, Yazici, Georgiev and Slusallek 2022,
// "Efficiency-aware multiple importance sampling for bidirectional rendering algorithms", choose
// the light path count per scene with one pilot, each candidate's MIS weights evaluated on its
// paths and the cost a linear model of counted work; this pilot follows that plan with a cruder
// variance estimate, from each pixel's samples: docs/BDPT.md).
//
// Deterministic: the pilot's pixels, samples and seed depend only on the image size, the render's
// seed and sampler kind and the scene; its samples are traced in parallel, each sample's tally
// depending on that sample alone, and summed in a fixed order, and its cost is counted work
// (vertices and connections), never time. So every part of a split render
// (--spp-range, MPI), every thread count and every pass choose the same F.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>

#include "tritrace/math/random.h"
#include "tritrace/render/bdpt_integrator.h"

namespace tritrace {

class Accel;
struct Scene;

// The pilot's samples: this many pixels (all of a smaller image, else an even spread), kPilotSpp
// samples each (16384 in all, whatever the image's size and the render's spp; fewer made the
// choice on scenes/caustics.json depend on the seed: docs/PERFORMANCE.md).
inline constexpr uint32_t kPilotPixels = 2048;
inline constexpr uint32_t kPilotSpp = 8;
// Every share's variance is estimated with each sample clamped at this many times the mean
// (choose_light_paths says why). Too low a clamp cuts variance that every share has, so the
// differences between shares look larger than they are and small shares lose; too high lets one
// rare path decide (docs/BDPT.md, "Choosing F per scene").
inline constexpr double kPilotClamp = 30.0;

// Counted work per sample in the pilot's cost model: a subpath vertex (an extension ray, the
// hit's shading and the next direction's sampling) costs 1, a connection (two BSDF evaluations,
// its MIS weight and a shadow ray) kPilotConnectionCost. Fitted to bdpt's CPU time at F = 1 and
// 1/8 on cornell-area and caustics.json (docs/PERFORMANCE.md, 2026-11-28): 1.29 and 1.37.
inline constexpr double kPilotConnectionCost = 1.3;

// One connection of the pilot's F = 1 render into `sample`'s sums: its path x was sampled by
// strategy i with unweighted contribution `value` (luminance; a light-tracing splat when
// `splat`); `strategies` lists every strategy k that can sample x, i first, as (r_k, light_k):
// r_k = (p_k / p_i)^2 (the power heuristic's remapped ratio, counts left out) and whether k uses
// the light subpath past its first vertex. At share F those count n_k = F times and the others
// once (Veach 1997, sec. 9.2), so the connection's weight is w_i(F) = n_i^2 / sum_k n_k^2 r_k.
void add_pilot_contribution(LightPathsTally::Sample& sample, double value, bool splat,
                            std::span<const std::pair<float, bool>> strategies);

struct LightPathsChoice {
  float light_paths = 1.0f;  // the chosen share
  // Per candidate (kPilotShares): the estimated variance of one sample's estimate and its
  // expected counted work.
  std::array<double, kPilotCandidates> variance{};
  std::array<double, kPilotCandidates> cost{};
  uint64_t samples = 0;  // the pilot's samples
  uint64_t rays = 0;     // the pilot's rays (camera, extension and shadow rays)
  // The pilot's caustic guide, built: the render of the same scene and accel uses it too
  // (BdptIntegrator::use_caustic_guide) instead of tracing its pre-pass again.
  std::shared_ptr<BdptIntegrator::GuideSlot> guide;
};

// Runs the pilot over `scene` with `accel` (bdpt at F = 1 with `settings`' other fields), on the
// threads of the calling task arena, and returns the share with the smallest variance x cost
// (ties: the larger share): `spp` (clamped to [2, kMaxBatch]) samples in each of at most
// `max_pixels` pixels. Throws Error as BdptIntegrator's constructor does.
LightPathsChoice choose_light_paths(const Scene& scene, const Accel& accel,
                                    const BdptSettings& settings, uint64_t seed,
                                    SamplerKind sampler, uint32_t spp = kPilotSpp,
                                    uint64_t max_pixels = kPilotPixels);

}  // namespace tritrace
