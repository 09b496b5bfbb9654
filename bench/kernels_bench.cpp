// Micro benchmarks for the lab's question, inverse versus Cramer (and Möller–Trumbore, watertight):
// the cost of one ray/triangle test, and of a whole lab frame per kernel, single-threaded and on
// all cores.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/block_kernels.h"
#include "tritrace/geometry/intersect.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

struct TestCase {
  Ray ray;
  glm::vec3 v0, e1, e2;
};

// 4096 random triangles in [-1, 1]^3, each with a ray aimed at a point of its plane near it, so
// about half of the tests hit and the branch predictor cannot learn the answer.
std::vector<TestCase> random_cases() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(-1.0f, 1.0f), bary(-0.3f, 1.0f);
  std::vector<TestCase> cases(4096);
  for (TestCase& c : cases) {
    c.v0 = {coord(rng), coord(rng), coord(rng)};
    c.e1 = glm::vec3(coord(rng), coord(rng), coord(rng)) - c.v0;
    c.e2 = glm::vec3(coord(rng), coord(rng), coord(rng)) - c.v0;
    c.ray.origin = {coord(rng) * 3.0f, coord(rng) * 3.0f, -4.0f};
    c.ray.dir = glm::normalize(c.v0 + bary(rng) * c.e1 + bary(rng) * c.e2 - c.ray.origin);
  }
  return cases;
}

template <Kernel K>
void BM_RayTriangle(benchmark::State& state) {
  const std::vector<TestCase> cases = random_cases();
  int64_t hits = 0;
  for (auto _ : state) {
    for (const TestCase& c : cases) {
      TriangleHit h;
      const bool hit = intersect_triangle<K>(c.ray, c.v0, c.e1, c.e2, h);
      hits += hit;
      benchmark::DoNotOptimize(h);
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cases.size()));
  state.counters["hit_rate"] =
      static_cast<double>(hits) / (static_cast<double>(state.iterations()) * cases.size());
}
BENCHMARK(BM_RayTriangle<Kernel::kInverse>)->Name("RayTriangle/inverse");
BENCHMARK(BM_RayTriangle<Kernel::kCramer>)->Name("RayTriangle/cramer");
BENCHMARK(BM_RayTriangle<Kernel::kMollerTrumbore>)->Name("RayTriangle/moller-trumbore");
// The watertight kernel's per-ray set-up (axis choice, shear, one division) is inside this loop.
BENCHMARK(BM_RayTriangle<Kernel::kWatertight>)->Name("RayTriangle/watertight");

// The same tests as a mesh loop runs them: each ray's per-ray work (PreparedRay) done beforehand,
// as it is once per ray and amortised over many triangles, and triangles read from the mesh's
// arrays (vertices; the kernels other than the watertight one take their edges as differences).
template <Kernel K>
void BM_RayTrianglePrepared(benchmark::State& state) {
  const std::vector<TestCase> cases = random_cases();
  std::vector<glm::vec3> v0, v1, v2;
  std::vector<PreparedRay<K>> rays;
  for (const TestCase& c : cases) {
    v0.push_back(c.v0);
    v1.push_back(c.v0 + c.e1);
    v2.push_back(c.v0 + c.e2);
    rays.emplace_back(c.ray);
  }
  const TriangleArrays tris{v0.data(), v1.data(), v2.data()};
  int64_t hits = 0;
  for (auto _ : state) {
    for (size_t i = 0; i < cases.size(); ++i) {
      TriangleHit h;
      const bool hit = rays[i].intersect(tris, i, h);
      hits += hit;
      benchmark::DoNotOptimize(h);
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cases.size()));
  state.counters["hit_rate"] =
      static_cast<double>(hits) / (static_cast<double>(state.iterations()) * cases.size());
}
BENCHMARK(BM_RayTrianglePrepared<Kernel::kInverse>)->Name("RayTrianglePrepared/inverse");
BENCHMARK(BM_RayTrianglePrepared<Kernel::kCramer>)->Name("RayTrianglePrepared/cramer");
BENCHMARK(BM_RayTrianglePrepared<Kernel::kMollerTrumbore>)
    ->Name("RayTrianglePrepared/moller-trumbore");
BENCHMARK(BM_RayTrianglePrepared<Kernel::kWatertight>)->Name("RayTrianglePrepared/watertight");

#if defined(__AVX2__)
// The BVH's leaf kernels: one ray against a block of 8 triangles in one AVX2 step, the blocks of a
// BVH over the random triangles above (512 blocks), each ray prepared once as the traversal does.
template <Kernel K>
void BM_LeafBlock(benchmark::State& state) {
  const std::vector<TestCase> cases = random_cases();
  TriangleMesh mesh;
  for (const TestCase& c : cases) mesh.add(c.v0, c.v0 + c.e1, c.v0 + c.e2, 0);
  const bvh::WideBvh tree = bvh::build_wide_bvh(mesh, {.max_leaf_size = 8});
  // Block i's ray is aimed near its first triangle.
  std::vector<Ray> rays;
  std::vector<PreparedRay<K>> prepared;
  for (const bvh::TriangleBlock& b : tree.blocks) {
    rays.push_back(cases[b.prim[0]].ray);
    prepared.emplace_back(rays.back());
  }
  int64_t hits = 0;
  for (auto _ : state) {
    for (size_t i = 0; i < tree.blocks.size(); ++i) {
      Hit best;
      if constexpr (K == Kernel::kWatertight) {
        hits += bvh::block_watertight(tree.blocks[i], prepared[i].watertight(), &best);
      } else {
        hits += bvh::block_moller_trumbore(tree.blocks[i], rays[i], &best);
      }
      benchmark::DoNotOptimize(best);
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(tree.blocks.size()));
  state.counters["hit_rate"] =
      static_cast<double>(hits) / (static_cast<double>(state.iterations()) * tree.blocks.size());
}
BENCHMARK(BM_LeafBlock<Kernel::kMollerTrumbore>)->Name("LeafBlock/moller-trumbore");
BENCHMARK(BM_LeafBlock<Kernel::kWatertight>)->Name("LeafBlock/watertight");
#endif

// range(0): kernel index, range(1): image side, range(2): threads (0 = all cores).
void BM_LabFrame(benchmark::State& state) {
  const Kernel kernel = kAllKernels[static_cast<size_t>(state.range(0))];
  const int side = static_cast<int>(state.range(1));
  const Scene scene = make_cornell_box({.width = side, .height = side});
  const BruteForceAccel accel(scene.mesh, kernel);
  const LabIntegrator integrator;
  const RenderOptions options{.threads = static_cast<int>(state.range(2))};
  uint64_t rays = 0;
  for (auto _ : state) {
    RenderStats stats;
    Image image = render(scene, accel, integrator, options, &stats);
    benchmark::DoNotOptimize(image);
    rays += stats.rays;
  }
  state.SetLabel(std::string(kernel_name(kernel)) + " " + std::to_string(side) + "x" +
                 std::to_string(side) + (options.threads ? " 1 thread" : " all cores"));
  state.counters["Mrays/s"] =
      benchmark::Counter(static_cast<double>(rays) / 1e6, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LabFrame)
    ->ArgNames({"kernel", "side", "threads"})
    ->ArgsProduct({{0, 1, 2, 3}, {50, 500}, {1, 0}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace tritrace
