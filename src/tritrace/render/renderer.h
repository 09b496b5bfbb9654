// Renderer: splits the image into tiles and shades them on all cores with TBB, one batch per tile
// and sample index. Every sample depends only on (seed, pixel, sample index), never on the thread
// or tile, so the image is the same bit for bit whatever the thread count and tile size.
#pragma once

#include <cstdint>
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
  // Adaptive sampling (--noise-threshold; 0: off): a pixel's samples are split by the parity of
  // their index into two halves, each of which decides for itself, from its own samples only,
  // when the other half's samples stop counting: half h stops at a check once the standard error
  // of the pixel's mean estimated from h's samples, over the square root of its luminance
  // (adaptive_error), is below this, confirmed by the check before (kAdaptiveConfirm). Checks
  // fall at kAdaptiveMinSpp, 2 kAdaptiveMinSpp, 4 kAdaptiveMinSpp, ... samples. A pixel takes
  // samples while either half goes on, and its image is the average of the two cross estimates
  // (AdaptivePixel), which no decision reads, so it is unbiased; spp is the most it takes. The
  // decisions read only the pixel's own samples, so the image is the same for any thread count,
  // tile size and tile part. Needs first_sample 0 (throws Error otherwise); ignored by an
  // integrator that takes one sample through the pixel corner (the lab's).
  float noise_threshold = 0.0f;
  // The sample count at which adaptive sampling ends (--spp across the passes of --time-limit):
  // there, a pixel still taking samples gets its image from the two cross estimates as a stopped
  // one does. 0: this call's first_sample + spp.
  uint32_t adaptive_spp = 0;
  AdaptiveState* adaptive_state = nullptr;
};

// The tile size of --tile parts.
inline constexpr int kPartTileSize = 16;

// Adaptive sampling's first check: 32 samples, the first count at which a pixel's sample
// variance is a usable estimate (its standard deviation within about 13% for Gaussian samples)
// and at which the Sobol points of every 2-D dimension are a whole, well-stratified power of two.
inline constexpr uint32_t kAdaptiveMinSpp = 32;
// A pixel stops at a check only when its error is below T there and was below kAdaptiveConfirm x T
// at the check before (where, with half the samples, it should be sqrt(2) times larger): two
// estimates must agree, since one from few samples of a skewed distribution often errs low. So the
// first stop is at 2 kAdaptiveMinSpp.
inline constexpr double kAdaptiveConfirm = 1.4142135623730951;
// Below this mean luminance, a pixel's error is divided by sqrt(this) instead of sqrt(mean) (as
// Cycles guards its denominator), so that a nearly black pixel's few bright samples do not keep
// it sampling to the end. 0.1 and 0.01 measured alike at equal time (docs/PERFORMANCE.md).
inline constexpr double kAdaptiveDarkFloor = 0.1;

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

// One half of a pixel's samples under adaptive sampling (the even or the odd sample indices).
struct AdaptiveHalf {
  PixelMoments moments;  // this half's luminance sums while it decides
  // The weighted radiance and weight of this half's samples that the image uses: those taken
  // while the other half still went on.
  glm::dvec4 kept{0.0};
  uint8_t on = 1;    // still deciding
  uint8_t near = 0;  // its error was below kAdaptiveConfirm x T at the last check
};

// A pixel under adaptive sampling. A stopping rule that reads the samples it averages is biased:
// a pixel that has not yet met a rare bright path (a caustic) has a small sample variance and
// stops, one that has met it goes on and dilutes it, so the image is dark on average (-0.6% of
// glass.json's mean, 46 standard errors, docs/PERFORMANCE.md). Here half A (even indices) stops
// at tau_A, read from A only, and half B at tau_B, from B only; the pixel's estimate is
// (mean of B over [0, tau_A) + mean of A over [0, tau_B)) / 2. Each term averages samples that
// the stop time it uses never read, so by optional stopping each is unbiased (for independent
// samples; "cross-fitting", as in Chernozhukov et al. 2018, "Double/debiased machine learning",
// applied to a stopping time), and so is their average with fixed weights. When both halves stop
// together (nearly always) it is the pixel's plain mean, no sample wasted; otherwise the samples
// of one half beyond the other's stop only decide.
struct AdaptivePixel {
  AdaptiveHalf half[2];
  bool active() const { return half[0].on != 0 || half[1].on != 0; }
};

// Adaptive sampling's state of every pixel of an image between passes. render_to_film fills it
// on a film's first pass and continues it on later ones.
struct AdaptiveState {
  uint32_t end_sample = 0;  // the samples [0, end_sample) the sums hold
  std::vector<AdaptivePixel> pixels;
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
// continued at its end_sample() only. Throws Error("film", ...) otherwise.
void render_to_film(const Scene& scene, const Accel& accel, const Integrator& integrator,
                    Film& film, const RenderOptions& options = {}, RenderStats* stats = nullptr);

}  // namespace tritrace
