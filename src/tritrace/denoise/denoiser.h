// The feature-guided denoiser: a pure function from a noisy colour image, its per-pixel variance
// and the first hit's albedo, normal and depth to a denoised colour image. It knows nothing of
// scenes or rays, so it is tested on synthetic images with known answers (docs/DENOISING.md).
//
// The method is a joint non-local-means filter in the manner of Rousselle, Knaus and Zwicker,
// "Adaptive Rendering with Non-Local Means Filtering" (SIGGRAPH Asia 2012), for the colour term,
// and Rousselle, Manzi and Zwicker, "Robust Denoising using Feature and Color Information"
// (Pacific Graphics 2013), for combining it with feature weights: each pixel becomes a weighted
// mean of its neighbours, a neighbour's weight falling with the variance-normalised distance
// between their colour patches and with its distance in albedo, normal and depth. The colour is
// divided by the albedo before filtering and multiplied back after, so that texture is never
// blurred (as in Bako et al., "Kernel-Predicting Convolutional Networks", SIGGRAPH 2017).
#pragma once

#include "tritrace/denoise/bright_edges.h"
#include "tritrace/image/image.h"
#include "tritrace/math/random.h"

namespace tritrace {

// The filter's settings. The defaults are those docs/DENOISING.md measures.
struct DenoiseOptions {
  // Neighbours are the (2 r + 1)^2 pixels around a pixel.
  int search_radius = 7;
  // Colour is compared over (2 f + 1)^2 patches (non-local means), which tells a lighting edge
  // such as a shadow's from noise.
  int patch_radius = 3;
  // k of Rousselle et al. 2012: the colour distance is the squared difference in units of
  // k^2 (var_p + var_q); larger k smooths more. 0 leaves the colour term out (features only).
  // Tuned on cornell-area at 16 spp with the variance of the mean (docs/DENOISING.md).
  float colour_strength = 0.7f;
  // The feature distances: squared differences in units of these. A feature with scale 0 (or
  // less) is left out. Albedo is compared per channel, both in absolute terms and relative to
  // the larger of the two (albedo + kAlbedoEpsilon, so that black compares with black): among
  // dark albedos a small difference is a large ratio, and demodulated neighbours whose albedos
  // differ by a large ratio would be multiplied back by the wrong one (the pixels at the edge of
  // a light source, whose albedo is a small fraction of a lit surface's, then gain light).
  // Normals are compared as unit vectors (0.25 ~ 14 degrees), depth as the relative error of a
  // planar (first-order) prediction of inverse depth from the pixel's own depth gradient, so
  // that a slanted plane is one surface.
  float albedo_scale = 0.05f;
  float albedo_relative_scale = 0.25f;
  float normal_scale = 0.25f;
  float depth_scale = 0.02f;
  // Divide colour by (albedo + kAlbedoEpsilon) before filtering and multiply back after.
  bool demodulate_albedo = true;
  // A second pass whose colour distance compares the first pass's result instead of the noisy
  // colour, with this k, in units of the first result's variance (the input's times
  // sum(w^2) / (sum w)^2 of the first pass's weights); it averages the noisy colour again with
  // the new weights. The first result's errors are correlated between neighbours (they share
  // inputs), so its distances need a larger k than the noisy colour's (docs/DENOISING.md).
  bool guided_pass = true;
  float guided_colour_strength = 3.0f;
  // Blend the two passes per pixel, each weighted by the other's estimated error (Stein's
  // unbiased risk estimate, averaged over the (2 sure_radius + 1)^2 pixels around); negative:
  // the guided pass's result alone (docs/DENOISING.md).
  int sure_radius = 3;
  // The variance the filter uses is at least this times the variance estimated from the image
  // itself (estimate_variance_spatially, in the demodulated colour), but raised at most
  // spatial_variance_floor_limit times: the renderer's half-buffer variance has one degree of
  // freedom per pixel, and at a pixel that a very bright edge crosses (a light seen directly) it
  // misses the coverage noise (16 samples happen to hit the light once or not at all), so the
  // filter kept such a pixel as it was; the limit keeps the floor from smoothing detail that the
  // spatial estimate mistakes for noise (curvature, glossy reflections) where the half buffers
  // are right, and leaves a variance of 0 at 0 (an exact image is returned unchanged).
  // docs/DENOISING.md measures both. A floor of 0 turns it off.
  float spatial_variance_floor = 0.5f;
  float spatial_variance_floor_limit = 16.0f;
  // Scale each channel of the result so that its sum is the input's (where both are positive):
  // the weighted means do not keep the total exactly around fireflies.
  bool keep_mean = true;
  // The straight-edge model at very bright edges (bright_edges.h; contrast 0 turns it off).
  BrightEdgeOptions bright_edges;
};

// The amount added to the albedo when dividing colour by it, so that black and missing albedo (0
// where nothing was hit) divide safely; the same amount is multiplied back.
inline constexpr float kAlbedoEpsilon = 0.00316f;

// The first hit's features, each the colour's size: albedo (RGB), world-space normal (XYZ; zero
// where nothing was hit) and depth (the red channel; 0 where nothing was hit).
struct DenoiseFeatures {
  const Image& albedo;
  const Image& normal;
  const Image& depth;
};

// The denoised colour. `variance` is the per-pixel, per-channel variance of the colour's mean
// (0: exact; negative values count as 0). Deterministic: the same bits for any thread count
// (each pixel's sums run in one fixed order). Throws Error("denoise", reason) when a size differs
// from the colour's or an input value is not finite.
[[nodiscard]] Image denoise(const Image& colour, const Image& variance,
                            const DenoiseFeatures& features, const DenoiseOptions& options = {});

// The same from two half buffers, each the mean of half of a pixel's samples (split by sample
// index parity): the colour is their average, its variance variance_from_halves(a, b).
[[nodiscard]] Image denoise_halves(const Image& half_a, const Image& half_b,
                                   const DenoiseFeatures& features,
                                   const DenoiseOptions& options = {});

// (a + b) / 2 per pixel and channel: the colour of two equal halves.
[[nodiscard]] Image average_halves(const Image& half_a, const Image& half_b);

// The per-pixel variance of the mean (a + b) / 2 of two independent half buffers with the same
// expectation: E[(a - b)^2] / 4, estimated by (a - b)^2 / 4 averaged over the
// (2 radius + 1)^2 pixels around each (clamped at the border). With radius 0 each estimate has a
// single degree of freedom; the average makes it usable as a weight.
[[nodiscard]] Image variance_from_halves(const Image& half_a, const Image& half_b, int radius = 2);

// How much larger than the variance of a pixel's mean the renderer's half-buffer variance AOV
// is with its default Sobol sampler, measured on cornell-area against the sample variance of
// independent seeds (median per-pixel ratio 1.58, 1.95, 2.26 at 4, 16, 64 spp; far more at the
// light's edge; docs/DENOISING.md). The halves, split by sample index parity, each hold one point
// of every pair (2i, 2i + 1) of the shuffled Owen-scrambled Sobol sequence, and the two points of
// a pair lie in opposite halves of every dimension: the halves' errors are negatively
// correlated, so (a - b)^2 / 4 sees about the variance of independent samples, not the lower
// variance of the stratified whole (test
// HalfBufferVarianceOfTheSobolSamplerOverestimatesTheVariance). The factor depends on the scene; 2
// is the middle of what cornell-area measured.
inline constexpr float kSobolHalfBufferVarianceRatio = 2.0f;

// The overestimate of the half-buffer variance for the sampler that took the samples:
// kSobolHalfBufferVarianceRatio for Sobol, 1 for independent samples, whose halves are
// independent so that (a - b)^2 / 4 is unbiased (test
// HalfBufferVarianceOfTheSobolSamplerOverestimatesTheVariance).
constexpr float half_buffer_variance_ratio(SamplerKind sampler) {
  return sampler == SamplerKind::kSobol ? kSobolHalfBufferVarianceRatio : 1.0f;
}

// The renderer's per-pixel variance AOV (one degree of freedom per pixel) averaged over the
// (2 radius + 1)^2 pixels around each (clamped at the border), as variance_from_halves averages
// its estimates, and divided by `overestimate` (kSobolHalfBufferVarianceRatio for the Sobol
// sampler's halves, 1 for independent halves: half_buffer_variance_ratio) to give the variance of
// the mean that denoise() expects. `render --denoise` and `tritrace denoise` both call it with
// radius 2 and the ratio of the sampler the render used.
[[nodiscard]] Image smooth_variance(const Image& variance, int radius = 2,
                                    float overestimate = kSobolHalfBufferVarianceRatio);

// For images without a variance layer: the variance of each pixel's value estimated from its
// neighbourhood, (9/8) times the mean over 5 x 5 pixels of the squared residual from the 3 x 3
// mean, computed on the albedo-demodulated colour (so texture does not count as noise). Larger
// than the true variance wherever the image itself varies (edges, curvature).
[[nodiscard]] Image estimate_variance_spatially(const Image& colour, const Image& albedo);

}  // namespace tritrace
