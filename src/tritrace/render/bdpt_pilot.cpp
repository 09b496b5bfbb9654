// `--light-paths auto`'s pilot (bdpt_pilot.h).
#include "tritrace/render/bdpt_pilot.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "tritrace/accel/accel.h"
#include "tritrace/parallel.h"
#include "tritrace/render/film.h"
#include "tritrace/render/sampler.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

LightPathsChoice choose_light_paths(const Scene& scene, const Accel& accel,
                                    const BdptSettings& settings, uint64_t seed,
                                    SamplerKind sampler_kind, uint32_t spp, uint64_t max_pixels) {
  spp = std::clamp<uint32_t>(spp, 2, static_cast<uint32_t>(kMaxBatch));
  BdptSettings pilot_settings = settings;
  pilot_settings.light_paths = 1.0f;
  pilot_settings.weight_check = nullptr;
  const BdptIntegrator integrator(scene, pilot_settings);
  // Its caustic guide first, with every thread of the arena (the batches below only read it).
  integrator.caustic_guide(scene, accel);

  const Camera& camera = scene.camera;
  const uint64_t width = static_cast<uint64_t>(camera.width());
  const uint64_t pixels = width * static_cast<uint64_t>(camera.height());
  const uint64_t count = std::min<uint64_t>(pixels, std::max<uint64_t>(1, max_pixels));
  // Its own sequence: the render's seed hashed with a constant, so the pilot's samples are not
  // the render's first samples (the choice would otherwise correlate with the image's noise).
  const uint64_t pilot_seed = hash_combine(hash_words(seed), 0x6c706175746fULL);
  const bool lens = camera.has_lens();
  const PixelFilter filter(FilterKind::kBox);

  // Batches of whole pixels' samples, at most kMaxBatch each, traced on the arena's threads. Each
  // sample's tally depends on that sample alone, and the tallies are kept in sample order, so the
  // choice is the same for any thread count.
  const uint64_t pixels_per_batch = kMaxBatch / spp;  // at least 1: spp <= kMaxBatch
  const uint64_t batches = (count + pixels_per_batch - 1) / pixels_per_batch;
  std::vector<LightPathsTally::Sample> all(count * spp);
  std::vector<uint64_t> batch_rays(batches, 0);
  parallel::for_range(
      tbb::blocked_range<uint64_t>(0, batches, 1), [&](const tbb::blocked_range<uint64_t>& range) {
        std::vector<Ray> rays;
        std::vector<Sampler> samplers;
        std::vector<uint32_t> batch_pixels;
        std::vector<glm::vec3> radiance;
        SplatBuffer no_splats(1, 1);  // the pilot adds none
        LightPathsTally tally;
        for (uint64_t b = range.begin(); b != range.end(); ++b) {
          const uint64_t first = b * pixels_per_batch;
          const uint64_t end = std::min<uint64_t>(count, first + pixels_per_batch);
          rays.clear();
          samplers.clear();
          batch_pixels.clear();
          for (uint64_t i = first; i < end; ++i) {
            // An even spread over the image's pixels in row-major order.
            const uint64_t pixel = (2 * i + 1) * pixels / (2 * count);
            const int x = static_cast<int>(pixel % width), y = static_cast<int>(pixel / width);
            for (uint32_t s = 0; s < spp; ++s) {
              Sampler sampler(pilot_seed, sampler_kind);
              sampler.start_pixel_sample(x, y, s);
              const glm::vec2 u = sampler.get_pixel_2d();
              const PixelFilter::Sample f = filter.sample(u.x, u.y);
              const float px = static_cast<float>(x) + f.x, py = static_cast<float>(y) + f.y;
              rays.push_back(lens ? camera.lens_ray(px, py, sampler.get_lens_2d())
                                  : camera.ray_through(px, py));
              samplers.push_back(sampler);
              batch_pixels.push_back(static_cast<uint32_t>(pixel));
            }
          }
          const size_t n = rays.size();
          radiance.assign(n, glm::vec3(0.0f));
          tally.samples.assign(n, LightPathsTally::Sample{});
          SampleOutput out;
          out.radiance = radiance;
          out.splats = &no_splats;
          batch_rays[b] = integrator.pilot_radiance(
              SampleBatch{rays, samplers, std::span<const uint32_t>(batch_pixels)}, out, scene,
              accel, tally);
          std::copy(tally.samples.begin(), tally.samples.end(), all.begin() + first * spp);
        }
      });

  LightPathsChoice choice;
  for (const uint64_t r : batch_rays) choice.rays += r;
  std::array<double, kPilotCandidates> moment{};
  std::array<double, kPilotCandidates> cost{};
  // The mean of a sample's estimate (F = 1's; every share's has the same mean).
  double mean = 0.0;
  for (const LightPathsTally::Sample& r : all) mean += r.always[0] + r.light[0];
  mean /= static_cast<double>(std::max<size_t>(1, all.size()));
  const double clamp = kPilotClamp * mean;
  const double m = spp;
  for (size_t k = 0; k < all.size(); k += spp) {
    // One pixel's samples. At share F a sample's estimate is X = a + (I / F) b (a: the
    // strategies every sample has, b: those of the light subpath past its first vertex, I:
    // whether the sample traces it, a share F of each pixel's samples spread evenly), so
    //   Var X_F = Var(a_F + b_F) + (1 / F - 1) Var b_F,
    // each Var from the spread of the pixel's samples (unbiased); the light-tracing splats
    // (landing on other pixels, each a small part of a pixel's mean) add their second moment
    // over F. Var(a_F + b_F) is taken with each sample clamped at kPilotClamp times the image's
    // mean, for every share alike. A rare bright path is met a handful of times in the pilot's
    // samples, so its square is noise that decides the choice by chance: with the shares'
    // differences from F = 1 unclamped, those on scenes/caustics.json came from a few samples
    // between 30 and 100 times the mean, and the choice wavered with the seed between 1/4 and 1
    // there, 1/8 and 1 on glass.json and 1/64 and 1 on sky.json (docs/BDPT.md, "Choosing F per
    // scene"). The thinning's Var b stays unclamped: it is the light subpaths' spread within a
    // pixel, not a rare path's square.
    for (size_t j = 0; j < kPilotCandidates; ++j) {
      const double f = kPilotShares[j];
      double sum = 0.0, sum2 = 0.0, light = 0.0, light2 = 0.0, thinned = 0.0;
      for (size_t i = k; i < k + spp; ++i) {
        const LightPathsTally::Sample& r = all[i];
        const double x = std::min(r.always[j] + r.light[j], clamp);
        sum += x;
        sum2 += x * x;
        light += r.light[j];
        light2 += r.light[j] * r.light[j];
        thinned += r.splat2[j] / f;
        cost[j] += static_cast<double>(r.camera_vertices) +
                   kPilotConnectionCost * static_cast<double>(r.always_rays) +
                   f * (static_cast<double>(r.light_vertices) +
                        kPilotConnectionCost * static_cast<double>(r.light_rays));
      }
      const double spread = (sum2 - sum * sum / m) / (m - 1.0) * m;
      // The thinning: (1 / F - 1) times b's variance, not its second moment as independent
      // choices would give: the samples that trace a light subpath are spread evenly over a
      // pixel's samples (traces_light_subpath: any n consecutive samples hold floor(n F) or
      // ceil(n F)), so b's mean over the pixel is carried by F m of them every time.
      thinned += (1.0 / f - 1.0) * (light2 - light * light / m) / (m - 1.0) * m;
      moment[j] += spread + thinned;
    }
  }
  choice.samples = count * spp;
  choice.guide = integrator.shared_caustic_guide();
  const double samples = static_cast<double>(std::max<uint64_t>(1, choice.samples));
  double best = 0.0;
  for (size_t j = 0; j < kPilotCandidates; ++j) {
    choice.variance[j] = std::max(0.0, moment[j]) / samples;
    choice.cost[j] = cost[j] / samples;
    const double efficiency = choice.variance[j] * choice.cost[j];
    if (j == 0 || efficiency < best) {
      best = efficiency;
      choice.light_paths = kPilotShares[j];
    }
  }
  return choice;
}

void add_pilot_contribution(LightPathsTally::Sample& sample, double value, bool splat,
                            std::span<const std::pair<float, bool>> strategies) {
  if (strategies.empty()) return;
  const bool own_light = strategies[0].second;
  for (size_t j = 0; j < kPilotCandidates; ++j) {
    const double f = kPilotShares[j];
    double denominator = 0.0;
    for (const auto& [r, light] : strategies) {
      denominator += (light ? f * f : 1.0) * static_cast<double>(r);
    }
    const double term = (own_light ? f * f : 1.0) / denominator * value;
    if (!std::isfinite(term)) continue;
    if (splat) {
      sample.splat2[j] += term * term;
    } else if (own_light) {
      sample.light[j] += term;
    } else {
      sample.always[j] += term;
    }
  }
}

}  // namespace tritrace
