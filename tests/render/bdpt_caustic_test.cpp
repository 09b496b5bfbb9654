// bdpt's caustic strategy (BdptSettings::caustic_paths, render/caustic_guide.h, docs/BDPT.md)
// against oracles that do not use it: the guide's directions checked by tracing them (they must
// lead into the glass), and images against the path tracer's and against bdpt's without the guide
// (the strategy only moves weight between estimators of the same paths), which must also keep the
// images bit-identical for any thread count, tile size and connection code.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "example_scene.h"
#include "mean_and_error.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/parallel.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/caustic_guide.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

using testing_mc::expect_same_mean;
using testing_mc::mean_of_renders;
using testing_mc::same_bits;

// scenes/caustics.json: a glass sphere on the floor of a box lit by a small area light high on
// its left wall, the caustic on the floor beside the sphere.
Scene caustics(int side) {
  return testing_scenes::example_scene("caustics.json", side);
}

// Where the guide has a cell on the floor, its directions lead back to the glass: a ray from the
// floor point along each of them meets the sphere first (nearly always: a cell is 1/128 of the
// box's diagonal wide, and its photons arrived at other points of it).
TEST(BdptCaustics, GuideDirectionsLeadIntoTheGlass) {
  const Scene scene = caustics(16);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene);
  const CausticGuide* guide = bdpt.caustic_guide(scene, accel);
  ASSERT_NE(guide, nullptr);
  EXPECT_GT(guide->cell_count(), 20u);
  uint32_t glass = 0;
  for (uint32_t m = 0; m < scene.materials.size(); ++m) {
    if (scene.materials[m].type == MaterialType::kDielectric) glass = m;
  }
  int axes = 0, into_glass = 0, guided_points = 0;
  // The floor is y = 1 (world y points down), x and z in [-1, 1].
  for (int i = 0; i < 100; ++i) {
    for (int j = 0; j < 100; ++j) {
      const glm::vec3 p(-0.99f + 0.0198f * static_cast<float>(i), 0.9999f,
                        -0.99f + 0.0198f * static_cast<float>(j));
      const CausticGuide::Cell cell = guide->cell(p);
      if (cell.count == 0) continue;
      ++guided_points;
      for (uint32_t a = 0; a < cell.count; ++a) {
        const Hit hit = accel.intersect(Ray{p, cell.axes[a], 1e-4f, kRayTMax});
        ++axes;
        if (hit.found() && scene.material_of(hit.prim) == glass) ++into_glass;
      }
    }
  }
  std::printf("  %d floor points guided, %d of %d directions into the glass\n", guided_points,
              into_glass, axes);
  EXPECT_GT(guided_points, 20);
  EXPECT_GE(into_glass, 0.95 * axes);
}

// Every cell of `guide`, by its cones, probed at the centre of every cell of the scene's bounds.
std::vector<float> guide_cells(const CausticGuide& guide, const Scene& scene) {
  const Bounds3 b = scene_bounds(scene);
  const float c = guide.cell_size();
  std::vector<float> out;
  const glm::ivec3 lo(glm::floor(b.lo / c)), hi(glm::floor(b.hi / c));
  for (int x = lo.x; x <= hi.x; ++x) {
    for (int y = lo.y; y <= hi.y; ++y) {
      for (int z = lo.z; z <= hi.z; ++z) {
        const glm::vec3 p = (glm::vec3(x, y, z) + 0.5f) * c;
        const CausticGuide::Cell cell = guide.cell(p);
        if (cell.count == 0) continue;
        out.insert(out.end(), {p.x, p.y, p.z, static_cast<float>(cell.count), cell.one_minus_cos});
        for (uint32_t a = 0; a < cell.count; ++a) {
          out.insert(out.end(), {cell.axes[a].x, cell.axes[a].y, cell.axes[a].z});
        }
      }
    }
  }
  return out;
}

// The pre-pass runs in parallel (fixed chunks of light paths, each with its own stream): the
// guide is the same for any number of threads.
TEST(BdptCaustics, GuideTheSameForAnyThreadCount) {
  const Scene scene = caustics(8);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  std::vector<float> want;
  size_t photons = 0;
  for (const int threads : {1, 2, 3, 5}) {
    const BdptIntegrator bdpt(scene);
    const CausticGuide* guide = nullptr;
    parallel::in_arena(threads, [&] { guide = bdpt.caustic_guide(scene, accel); });
    ASSERT_NE(guide, nullptr);
    const std::vector<float> cells = guide_cells(*guide, scene);
    if (threads == 1) {
      want = cells;
      photons = guide->photon_count();
      // Every kept photon was found by the probe (each cell's exactly once).
      size_t probed = 0;
      for (size_t i = 0; i < cells.size(); i += 5 + 3 * static_cast<size_t>(cells[i + 3])) {
        probed += static_cast<size_t>(cells[i + 3]);
      }
      EXPECT_EQ(probed, photons);
      EXPECT_GT(guide->cell_count(), 20u);
      continue;
    }
    EXPECT_EQ(guide->photon_count(), photons) << threads << " threads";
    EXPECT_TRUE(cells == want) << threads << " threads";
  }
}

// The render job's pilot and render share one guide (use_caustic_guide) where they would build
// the same one, and only there.
TEST(BdptCaustics, GuideSharedOnlyWithTheSameSettings) {
  const Scene scene = caustics(8);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator pilot(scene, {.light_paths = 1.0f, .camera_only_connect = false});
  const CausticGuide* built = pilot.caustic_guide(scene, accel);
  ASSERT_NE(built, nullptr);
  BdptIntegrator render_integrator(scene, {.light_paths = 0.25f});
  EXPECT_TRUE(render_integrator.use_caustic_guide(pilot.shared_caustic_guide()));
  EXPECT_EQ(render_integrator.caustic_guide(scene, accel), built);
  // Another depth or number of pre-pass paths builds another guide: not shared.
  BdptIntegrator deeper(scene, {.max_depth = 3});
  EXPECT_FALSE(deeper.use_caustic_guide(pilot.shared_caustic_guide()));
  BdptIntegrator fewer(scene, {.caustic_paths = 1 << 12});
  EXPECT_FALSE(fewer.use_caustic_guide(pilot.shared_caustic_guide()));
  BdptIntegrator off(scene, {.caustic_paths = 0});
  EXPECT_FALSE(off.use_caustic_guide(pilot.shared_caustic_guide()));
  EXPECT_EQ(off.caustic_guide(scene, accel), nullptr);
  // A shared guide gives the image of a guide built by the render itself, bit for bit.
  const BdptIntegrator own(scene, {.light_paths = 0.25f});
  EXPECT_TRUE(same_bits(render(scene, accel, own, {.threads = 2, .spp = 4}),
                        render(scene, accel, render_integrator, {.threads = 2, .spp = 4})));
}

TEST(BdptCaustics, NoGuideWithoutSpecularSurfacesOrWhenTurnedOff) {
  const Scene box = make_cornell_area({.width = 8, .height = 8});
  const BvhAccel box_accel(box.mesh, kDefaultKernel);
  EXPECT_EQ(BdptIntegrator(box).caustic_guide(box, box_accel), nullptr);
  const Scene scene = caustics(8);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  EXPECT_EQ(BdptIntegrator(scene, {.caustic_paths = 0}).caustic_guide(scene, accel), nullptr);
  // The tests of single strategies run without it (they cover the other strategies).
  EXPECT_EQ(BdptIntegrator(scene, {.unweighted = true}).caustic_guide(scene, accel), nullptr);
}

// The caustic strategy changes how a caustic path's contribution is split between estimators,
// never the total: the image mean equals the path tracer's and bdpt's without the guide.
TEST(BdptCaustics, AgreesWithThePathTracerAndWithoutTheGuide) {
  const Scene scene = caustics(20);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator guided(scene);
  ASSERT_NE(guided.caustic_guide(scene, accel), nullptr);
  const auto with = mean_of_renders(scene, accel, guided, 64, 10, 6);
  expect_same_mean(with, mean_of_renders(scene, accel, PathIntegrator(scene), 256, 20, 6), 0.01);
  expect_same_mean(
      with, mean_of_renders(scene, accel, BdptIntegrator(scene, {.caustic_paths = 0}), 64, 30, 6),
      0.01);
  // The strategy is there: the same samples give another image without it.
  EXPECT_FALSE(
      same_bits(render(scene, accel, guided, {.spp = 4}),
                render(scene, accel, BdptIntegrator(scene, {.caustic_paths = 0}), {.spp = 4})));
}

TEST(BdptCaustics, BitIdenticalForThreadsTilesAndConnectionCode) {
  const Scene scene = caustics(20);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  for (const float share : {1.0f, 0.25f}) {
    const BdptIntegrator bdpt(scene, {.light_paths = share});
    const Image want = render(scene, accel, bdpt, {.threads = 1, .tile_size = 16, .spp = 8});
    for (const int threads : {2, 3}) {
      for (const int tile : {1, 5}) {
        EXPECT_TRUE(same_bits(
            want, render(scene, accel, bdpt, {.threads = threads, .tile_size = tile, .spp = 8})))
            << "light_paths " << share << ", " << threads << " threads, tile " << tile;
      }
    }
    // Samples without a light subpath connect by their own code (connect_camera_only).
    const BdptIntegrator general(scene, {.light_paths = share, .camera_only_connect = false});
    EXPECT_TRUE(
        same_bits(want, render(scene, accel, general, {.threads = 1, .tile_size = 16, .spp = 8})))
        << "light_paths " << share;
  }
}

}  // namespace
}  // namespace tritrace
