// The viewer's refinement at rest: where frame-by-frame accumulation hands over to adaptive
// levels, the levels' sizes and parts, the stop rule, and a film assembled from tile parts being
// the one adaptive render's film bit for bit (the oracle: the renderer's own one-go render).
#include "refinement.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "film_parts.h"
#include "tritrace/error.h"
#include "tritrace/job/render_job.h"
#include "tritrace/render/renderer.h"

namespace tritrace::view {
namespace {

// cornell-area (the path tracer) at width x height, on two threads, with adaptive sampling.
JobSettings adaptive_job(const std::string& width, const std::string& height,
                         const std::string& spp, const std::string& threshold) {
  JobSettings s;
  s.scene = "cornell-area";
  s.width = width;
  s.height = height;
  s.spp = spp;
  s.threads = "2";
  s.noise_threshold = threshold;
  return s;
}

TEST(Refinement, UniformAccumulationEndsWhereAPixelCanFirstStop) {
  // Every pixel takes the renderer's pilot of 64 samples before any stops.
  ASSERT_EQ(kAdaptivePilotSpp, 64u);
  EXPECT_EQ(uniform_end({.max_spp = 1000, .noise_threshold = 0.05f}), 64u);
  EXPECT_EQ(uniform_end({.max_spp = 40, .noise_threshold = 0.05f}), 40u);
  EXPECT_EQ(uniform_end({.max_spp = 1000}), 1000u) << "no threshold: uniform to the end";
}

TEST(Refinement, LevelsDoubleUpToTheMaximum) {
  std::vector<uint32_t> levels;
  for (uint32_t spp = 64; (spp = next_adaptive_level(spp, 600)) != 0;) levels.push_back(spp);
  EXPECT_EQ(levels, (std::vector<uint32_t>{128, 256, 512, 600}));
  EXPECT_EQ(next_adaptive_level(600, 600), 0u);
  EXPECT_EQ(next_adaptive_level(700, 600), 0u);
  EXPECT_EQ(next_adaptive_level(0, 600), 2u);
  EXPECT_EQ(next_adaptive_level(0x80000000u, 0xFFFFFFFFu), 0xFFFFFFFFu) << "no overflow";
}

TEST(Refinement, LevelPartsFitTheBudget) {
  // 2 ms a sample of the whole image: 128 samples are 256 ms, 5 parts of at most 60 ms.
  EXPECT_EQ(level_parts(2.0, 128, 60.0, 1000), 5);
  EXPECT_EQ(level_parts(2.0, 128, 60.0, 3), 3) << "never more parts than tiles";
  EXPECT_EQ(level_parts(0.01, 128, 60.0, 1000), 1);
  EXPECT_EQ(level_parts(0.0, 128, 60.0, 1000), 1) << "no measurement yet";
  EXPECT_EQ(level_parts(2.0, 128, 60.0, 0), 1);
}

TEST(Refinement, StopsAtTheSamplesThenConvergenceThenTheClock) {
  const RefinementLimits limits{.max_spp = 256, .noise_threshold = 0.05f, .time_limit_seconds = 2};
  EXPECT_EQ(stop_reason(limits, 128, false, 1.0), StopReason::kNone);
  EXPECT_EQ(stop_reason(limits, 128, false, 2.0), StopReason::kTimeLimit);
  EXPECT_EQ(stop_reason(limits, 128, true, 1.0), StopReason::kConverged);
  EXPECT_EQ(stop_reason(limits, 128, true, 5.0), StopReason::kConverged);
  EXPECT_EQ(stop_reason(limits, 256, false, 0.5), StopReason::kSpp);
  EXPECT_EQ(stop_reason(limits, 256, true, 5.0), StopReason::kSpp);
  const RefinementLimits no_clock{.max_spp = 256};
  EXPECT_EQ(stop_reason(no_clock, 100, false, 1e9), StopReason::kNone);
  EXPECT_EQ(stop_reason_text(StopReason::kTimeLimit), "time limit");
  EXPECT_EQ(stop_reason_text(StopReason::kConverged), "converged");
  EXPECT_EQ(stop_reason_text(StopReason::kSpp), "spp reached");
  EXPECT_EQ(stop_reason_text(StopReason::kNone), "");
}

TEST(FilmParts, TilesInterleaveAsTheRendererDealsThem) {
  // A 40 x 20 image has 3 x 2 tiles of 16; with 4 parts, tile t goes to part t % 4.
  EXPECT_TRUE(in_tile_part(0, 0, 40, 0, 4));
  EXPECT_TRUE(in_tile_part(16, 0, 40, 1, 4));
  EXPECT_TRUE(in_tile_part(39, 15, 40, 2, 4));
  EXPECT_TRUE(in_tile_part(0, 16, 40, 3, 4));
  EXPECT_TRUE(in_tile_part(20, 19, 40, 0, 4));
  EXPECT_FALSE(in_tile_part(20, 19, 40, 1, 4));
}

// An adaptive render split into tile parts and assembled is the one-go adaptive render's film:
// image, variance, albedo, normal, depth and spp, bit for bit.
TEST(FilmParts, AssembledAdaptivePartsAreTheOneGoRender) {
  const JobSettings s = adaptive_job("40", "36", "256", "0.1");
  RenderJob job(s, load_job_scene(s));
  job.prepare();
  const AovSet aovs{.albedo = true, .normal = true, .depth = true, .variance = true, .spp = true};
  RenderOptions options = job.options();
  ASSERT_GT(options.noise_threshold, 0.0f);
  Film one(job.width(), job.height(), aovs);
  RenderStats stats;
  job.render_to_film(one, options, &stats);
  // The threshold stopped some pixels early, so the parts' adaptive decisions are exercised.
  ASSERT_LT(stats.mean_spp(), 255.0);

  for (const int parts : {1, 3, 7}) {
    Film whole;
    for (int part = 0; part < parts; ++part) {
      Film part_film(job.width(), job.height(), aovs);
      RenderOptions o = options;
      o.tile_part = part;
      o.tile_parts = parts;
      job.render_to_film(part_film, o, nullptr);
      copy_tile_part(part_film, part, parts, whole);
    }
    ASSERT_EQ(whole.end_sample(), 256u);
    EXPECT_EQ(whole.resolve().pixels(), one.resolve().pixels()) << parts << " parts";
    const AovImages a = whole.resolve_aovs(), b = one.resolve_aovs();
    EXPECT_EQ(a.variance.pixels(), b.variance.pixels()) << parts << " parts";
    EXPECT_EQ(a.albedo.pixels(), b.albedo.pixels()) << parts << " parts";
    EXPECT_EQ(a.normal.pixels(), b.normal.pixels()) << parts << " parts";
    EXPECT_EQ(a.depth.pixels(), b.depth.pixels()) << parts << " parts";
    EXPECT_EQ(a.spp.pixels(), b.spp.pixels()) << parts << " parts";
  }
}

// Below the first possible stop an adaptive render takes every sample: the uniform film the
// viewer accumulates frame by frame is the adaptive render's.
TEST(FilmParts, UniformFramesUpToTheFirstStopAreTheAdaptiveRender) {
  // A large threshold: most pixels would stop at the first chance.
  const JobSettings s = adaptive_job("24", "16", "64", "0.5");
  RenderJob job(s, load_job_scene(s));
  job.prepare();
  const Image adaptive = job.render().image;
  Film film(job.width(), job.height());
  RenderOptions o = job.options();
  o.noise_threshold = 0.0f;
  for (const auto& [first, spp] :
       std::vector<std::pair<uint32_t, uint32_t>>{{0, 1}, {1, 4}, {5, 20}, {25, 39}}) {
    o.first_sample = first;
    o.spp = spp;
    job.render_to_film(film, o, nullptr);
  }
  EXPECT_EQ(film.resolve().pixels(), adaptive.pixels());
}

TEST(FilmParts, APartOfAnotherShapeIsRefused) {
  Film whole(8, 8);
  whole.set_layout(0, 8, {BlockNode{0, 0}});
  Film other(8, 4);
  other.set_layout(0, 8, {BlockNode{0, 0}});
  EXPECT_THROW(copy_tile_part(other, 0, 1, whole), Error);
}

}  // namespace
}  // namespace tritrace::view
