// The denoiser's time on a synthetic 1920 x 1080 frame (docs/DENOISING.md): a smooth image plus
// noise of known variance, with features that change in blocks (edges for the weights to find).
// The argument is the search radius.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>

#include "tritrace/denoise/denoiser.h"
#include "tritrace/math/random.h"

namespace tritrace {
namespace {

struct Frame {
  Image colour, variance, albedo, normal, depth;
};

Frame make_frame(int w, int h) {
  Frame f{Image(w, h), Image(w, h), Image(w, h), Image(w, h), Image(w, h)};
  Pcg32 rng(1, 2);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int block = (x / 200) + 7 * (y / 150);
      const float a = 0.2f + 0.1f * static_cast<float>(block % 7);
      const float shade = 0.5f + 0.4f * std::sin(0.01f * x) * std::cos(0.013f * y);
      const float noise = 0.2f * (rng.next_float() - 0.5f) * 3.4641f;  // sd 0.2
      f.colour.at(x, y) = glm::vec3(a * shade * (1.0f + noise));
      f.variance.at(x, y) = glm::vec3(0.04f * a * shade * a * shade);
      f.albedo.at(x, y) = glm::vec3(a);
      f.normal.at(x, y) = block % 3 == 0 ? glm::vec3(0, 0, 1) : glm::vec3(0.6f, 0, 0.8f);
      f.depth.at(x, y) = glm::vec3(block % 5 == 0 ? 0.0f : 1.0f + 0.001f * x);
    }
  }
  return f;
}

void BM_Denoise1080p(benchmark::State& state) {
  static const Frame frame = make_frame(1920, 1080);
  DenoiseOptions options;
  options.search_radius = static_cast<int>(state.range(0));
  for (auto _ : state) {
    Image out =
        denoise(frame.colour, frame.variance, {frame.albedo, frame.normal, frame.depth}, options);
    benchmark::DoNotOptimize(out.pixels().data());
  }
  state.SetItemsProcessed(state.iterations() * 1920 * 1080);
}
BENCHMARK(BM_Denoise1080p)
    ->Arg(7)
    ->Arg(5)
    ->Arg(10)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(2);

}  // namespace
}  // namespace tritrace

BENCHMARK_MAIN();
