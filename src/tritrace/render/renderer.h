// Renderer: splits the image into tiles and shades them on all cores with TBB, one batch per tile
// and sample index. Every sample depends only on (seed, pixel, sample index), never on the thread
// or tile, so the image is the same bit for bit whatever the thread count and tile size. Splats of
// an integrator that adds to other pixels (Integrator::splats, bdpt's light tracing) go into the
// film's light image, integer sums that no order of addition changes.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "tritrace/accel/accel.h"
#include "tritrace/image/image.h"
#include "tritrace/render/film.h"
#include "tritrace/render/integrator.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// Told after every finished tile, from the worker thread that finished it: an implementation must
// be thread-safe, must not throw, and should return quickly (a clock read and a compare), since it
// runs once per tile inside the render loop.
class RenderProgress {
 public:
  virtual ~RenderProgress() = default;
  virtual void tiles_done(int done, int total) noexcept = 0;
};

struct AdaptiveState;

struct RenderOptions {
  int threads = 0;                     // 0: all cores
  int tile_size = 16;                  // tile_size^2 must not exceed kMaxBatch
  RenderProgress* progress = nullptr;  // optional, not owned
  // Samples [first_sample, first_sample + spp) of every pixel. An integrator that takes one sample
  // through the pixel corner (the lab's) renders exactly one whatever these say.
  uint32_t spp = 1;
  uint32_t first_sample = 0;
  uint64_t seed = 0;                          // the Sampler's seed
  SamplerKind sampler = SamplerKind::kSobol;  // and its kind
  FilterKind filter = FilterKind::kBox;       // where in the pixel samples land, and their weights
  // Part tile_part of tile_parts (`--tile I/N`): only the 16 x 16 tiles t (row-major) with
  // t % tile_parts == tile_part are rendered (tile_size is then 16); the other pixels get no
  // samples. Interleaved tiles balance the parts' work, since neighbouring tiles cost about the
  // same.
  int tile_part = 0;
  int tile_parts = 1;
  // Adaptive sampling (--noise-threshold; 0: off): every pixel takes kAdaptivePilotSpp samples,
  // and then more, up to spp, in proportion to its neighbours' error (adaptive_error, pooled by
  // neighbourhood_error over the 5 x 5 pixels around it within its 16 x 16 tile, itself left
  // out) over this (adaptive_budget). The decision never reads
  // the pixel's own samples, so the image is unbiased (AdaptiveState says why); it reads only
  // pixels of the same 16 x 16 tile (adaptive sampling always renders tiles of kPartTileSize,
  // whatever tile_size says), so the image is the same for any thread count, tile size and tile
  // part. Needs first_sample 0 (throws Error otherwise); ignored by an integrator that takes one
  // sample through the pixel corner (the lab's).
  float noise_threshold = 0.0f;
  // Adaptive sampling over several calls (--noise-threshold with --time-limit): each pixel's
  // running sums and stopping state, read at the start and written at the end, so that a film
  // continued pass after pass at its end_sample() makes every decision a single call of the same
  // total spp makes, bit for bit. Not owned; nullptr: one call renders samples [0, spp).
  AdaptiveState* adaptive_state = nullptr;
};

// The tile size of --tile parts.
inline constexpr int kPartTileSize = 16;

// Adaptive sampling's pilot: the samples every pixel takes before its budget is set, enough for
// a neighbour's sample variance to be a usable estimate (its standard deviation within about 9%
// for Gaussian samples) and a whole, well-stratified power of two of Sobol points.
inline constexpr uint32_t kAdaptivePilotSpp = 64;
// Below this mean luminance, a pixel's error is divided by sqrt(this) instead of sqrt(mean) (as
// Cycles guards its denominator), so that a nearly black pixel's few bright samples do not keep
// it sampling to the end. 0.1 and 0.01 measured alike at equal time (docs/PERFORMANCE.md).
inline constexpr double kAdaptiveDarkFloor = 0.1;
// A pixel's neighbours for adaptive sampling: the (2 r + 1)^2 - 1 pixels around it (within its
// 16 x 16 tile). 5 x 5 measured better than 3 x 3 on glass.json (RMSE at equal time 0.93 against
// 0.98 of uniform's, both with the budget rounded as the old checks did): more pilot samples see
// more of a rare caustic; 7 x 7 and 11 x 11 were no better (docs/PERFORMANCE.md).
inline constexpr int kAdaptiveRadius = 2;

// A pixel's running sums for adaptive sampling, over its samples' luminance x_i = w_i Y(L_i) and
// filter weights w_i, in double.
struct PixelMoments {
  double w = 0.0, x = 0.0, xx = 0.0, xw = 0.0, ww = 0.0;
  void add(double weight, double luminance) {
    const double xi = weight * luminance;
    w += weight;
    x += xi;
    xx += xi * xi;
    xw += xi * weight;
    ww += weight * weight;
  }
};
// The pixel's error after n samples: the estimated standard error of its mean luminance m = x / w
// (the ratio estimator's variance sum_i (x_i - m w_i)^2 / w^2 times n / (n - 1), square-rooted)
// divided by sqrt(max(m, kAdaptiveDarkFloor)), so T is a relative error at luminance 1, T /
// sqrt(m) at m. The square root, not m itself, as in Dammertz et al. 2010 ("A hierarchical
// automatic stopping condition for Monte Carlo global illumination"), whose |I - A| / sqrt(I)
// Cycles' noise threshold follows: spending a budget of samples to least total squared error
// gives each pixel samples in proportion to its standard deviation s (minimise sum s^2 / n
// subject to sum n fixed), so it stops at a standard error proportional to sqrt(s), which is
// sqrt(m) where noise is proportional to brightness. Dividing by m instead stopped bright pixels
// (a light's edge) too early and kept dark ones too long: cornell-area's RMSE at equal time went
// from 0.83-1.29 of uniform's to 0.67-0.94 (docs/PERFORMANCE.md). Infinity when it cannot say
// (n < 2, no weight).
double adaptive_error(const PixelMoments& m, uint32_t n);

// The error a pixel's neighbours show after kAdaptivePilotSpp samples each, from their moments:
// the root mean square of their adaptive_error values (infinity for none).
double neighbourhood_error(std::span<const PixelMoments* const> neighbours);

// The samples a pixel takes in all (spp, the render's end, bounds it), from its neighbourhood's
// error e after the pilot and the threshold T: kAdaptivePilotSpp e / T rounded up to the pilot
// times a power of two (the pilot alone when e < T), at most kAdaptiveMostBudget. Samples in
// proportion to the neighbours' error, so to their standard deviation s over sqrt(L): spending a
// total of samples for the least total squared error gives each pixel samples in proportion to s
// (minimise sum s^2 / n subject to sum n fixed). Rounding e / T up to a count at which the error
// itself is below T (n proportional to e^2, the rule the checks used) gave the noisiest pixels
// far more: on glass.json at T = 0.02 that was 1.18 of uniform sampling's RMSE at equal time
// against 0.96 (docs/PERFORMANCE.md). Powers of two keep counts to few values, as the spp AOV
// shows. It does not depend on spp, so passes of any length (--time-limit) set the budgets one
// call sets.
inline constexpr uint32_t kAdaptiveMostBudget = uint32_t{1} << 30;
uint32_t adaptive_budget(double error, double threshold);

// Adaptive sampling's state of every pixel of an image between passes: the pixel's sums over its
// pilot and its budget (0 until the pilot is complete). render_to_film fills it on a film's first
// pass and continues it on later ones.
//
// Why neighbours and not the pixel itself: a rule that stops a pixel on its own samples is biased
// (Cycles' and this renderer's rule before: a pixel that has not yet met a rare bright path, a
// caustic through glass, has a small sample variance and stops; one that has met it goes on and
// dilutes it, so the image comes out dark, -0.6% of glass.json's mean, 46 standard errors). A
// budget that is a function of other pixels' samples only is independent of the pixel's own
// (each pixel's random numbers are scrambled by its own hash), so the mean of the samples it
// takes is an unbiased estimate whatever the budget (the pixel's own estimate is then a mean of a
// fixed-for-it number of samples, Wald's identity not even needed). The pilot keeps it so: the
// neighbours' moments it reads are over their first kAdaptivePilotSpp samples, which every pixel
// takes whatever any decision says. Noise in a caustic or on an edge is spatially coherent, so
// the neighbours see what the pixel would (as Cycles' and Dammertz et al. 2010's rules already
// look beyond the pixel to catch what a pixel's own few samples miss).
struct AdaptiveState {
  uint32_t end_sample = 0;  // the samples [0, end_sample) the sums hold
  std::vector<PixelMoments> moments;
  std::vector<uint32_t> budget;
  // Pixels still taking samples (of the pixels rendered: a tile part's others stay active).
  size_t active_pixels() const;
};

struct RenderStats {
  double milliseconds = 0.0;
  uint64_t rays = 0;     // primary and secondary rays traced
  uint64_t samples = 0;  // camera samples (paths) taken: pixels x spp, fewer when adaptive
  uint64_t pixels = 0;   // pixels rendered
  uint32_t spp = 0;      // samples per pixel rendered (adaptive: the most a pixel took)
  // Threads that rendered at least one tile: RenderOptions::threads for an image with enough
  // tiles, fewer for a tiny one (or, rarely, when a thread started after the last tile was taken).
  int threads = 0;

  double mrays_per_second() const {
    return milliseconds > 0.0 ? static_cast<double>(rays) / (milliseconds * 1e3) : 0.0;
  }
  // The samples a pixel took on average (spp unless adaptive sampling stopped some early).
  double mean_spp() const {
    return pixels > 0 ? static_cast<double>(samples) / static_cast<double>(pixels) : 0.0;
  }
  double samples_per_second() const {
    return milliseconds > 0.0 ? static_cast<double>(samples) / (milliseconds * 1e-3) : 0.0;
  }
};

// The number of threads "all cores" means on this machine.
int default_thread_count();

// The image of `scene`: the film of options' samples, resolved (bit for bit, without the film's
// memory). options.first_sample must be a multiple of 8 (throws Error otherwise).
Image render(const Scene& scene, const Accel& accel, const Integrator& integrator,
             const RenderOptions& options = {}, RenderStats* stats = nullptr);

// Adds options' samples of every pixel to `film` (the camera's size), with the film's AOVs: how the
// viewer accumulates frame after frame, and how sample ranges are rendered apart. An empty film
// starts at options.first_sample, which must be a multiple of 8; a film that holds samples is
// continued at its end_sample() only. Throws Error("film", ...) otherwise. With an integrator
// that splats, the film keeps a light image (Film::splats); tile parts, adaptive sampling and
// filters other than the box are then refused (Error("render", ...)), here and in render().
void render_to_film(const Scene& scene, const Accel& accel, const Integrator& integrator,
                    Film& film, const RenderOptions& options = {}, RenderStats* stats = nullptr);

}  // namespace tritrace
