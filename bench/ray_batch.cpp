// tritrace_ray_batch: the C++ side of bench/python_rays.py. Traces a file of rays through a
// built-in scene's accel the way a C++ program using the library would (rays already in the
// library's Ray layout, batches of 256 through Accel::intersect or intersect_incoherent, one task
// per core taking batches from a shared counter, as the renderer takes tiles) and prints the median
// time as JSON, so that the Python module's intersect can be measured against the same work without
// Python.
//
//   tritrace_ray_batch SCENE ACCEL RAYS_FILE REPS coherent|incoherent|occluded
//
// occluded traces the rays one at a time through Accel::occluded_incoherent (any hit, as a path
// tracer's shadow rays) and counts the occluded rays as "hits".
//
// RAYS_FILE holds float32 rows (ox, oy, oz, dx, dy, dz), little-endian, nothing else.
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <string>
#include <vector>

#include "tritrace/accel/make_accel.h"
#include "tritrace/parallel.h"
#include "tritrace/render/integrator.h"
#include "tritrace/scene/io/scene_loader.h"

namespace {

using namespace tritrace;

std::vector<Ray> read_rays(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<float> values;
  float row[6];
  while (in.read(reinterpret_cast<char*>(row), sizeof row))
    values.insert(values.end(), row, row + 6);
  std::vector<Ray> rays(values.size() / 6);
  for (size_t i = 0; i < rays.size(); ++i) {
    const float* r = &values[6 * i];
    rays[i].origin = {r[0], r[1], r[2]};
    rays[i].dir = {r[3], r[4], r[5]};
  }
  return rays;
}

enum class Mode { kCoherent, kIncoherent, kOccluded };

// The CPU time of the whole process, in ms: under other programs' load a fairer measure than wall
// time, since time spent waiting for a core does not count.
double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

// One pass over every ray: batches of kMaxBatch handed to one task per core. Returns the wall time
// in ms and adds the CPU time to *cpu.

double trace_all(const Accel& accel, const std::vector<Ray>& rays, std::vector<Hit>& hits,
                 std::vector<uint8_t>& occluded, Mode mode, double* cpu = nullptr) {
  const double cpu_start = cpu_ms();
  const auto start = std::chrono::steady_clock::now();
  const size_t batches = (rays.size() + kMaxBatch - 1) / kMaxBatch;
  std::atomic<size_t> next{0};
  auto run = [&] {
    for (size_t b = next++; b < batches; b = next++) {
      const size_t first = b * kMaxBatch, n = std::min(kMaxBatch, rays.size() - first);
      const std::span<const Ray> in(rays.data() + first, n);
      const std::span<Hit> out(hits.data() + first, n);
      if (mode == Mode::kCoherent) {
        accel.intersect(in, out);
      } else if (mode == Mode::kIncoherent) {
        accel.intersect_incoherent(in, out);
      } else {
        accel.occluded_incoherent(in, std::span<uint8_t>(occluded.data() + first, n));
      }
    }
  };
  parallel::TaskGroup group;
  for (int t = 1; t < tbb::this_task_arena::max_concurrency(); ++t) group.run(run);
  run();
  group.wait();
  if (cpu) *cpu = cpu_ms() - cpu_start;
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr,
                 "usage: tritrace_ray_batch SCENE ACCEL RAYS_FILE REPS "
                 "coherent|incoherent|occluded\n");
    return 2;
  }
  try {
    const LoadedScene loaded = load_builtin_scene(argv[1]);
    const AccelKind kind = parse_accel(argv[2]).value_or(AccelKind::kBvh);
    const std::unique_ptr<Accel> accel = make_accel(kind, loaded.scene.mesh, kDefaultKernel);
    const std::vector<Ray> rays = read_rays(argv[3]);
    const int reps = std::max(1, std::stoi(argv[4]));
    const std::string mode_name = argv[5];
    const Mode mode = mode_name == "coherent"   ? Mode::kCoherent
                      : mode_name == "occluded" ? Mode::kOccluded
                                                : Mode::kIncoherent;
    std::vector<Hit> hits(rays.size());
    std::vector<uint8_t> occluded(rays.size(), 0);
    trace_all(*accel, rays, hits, occluded, mode);  // warm-up
    std::vector<double> ms, cpu(reps);
    for (int i = 0; i < reps; ++i)
      ms.push_back(trace_all(*accel, rays, hits, occluded, mode, &cpu[i]));
    std::sort(ms.begin(), ms.end());
    std::sort(cpu.begin(), cpu.end());
    const double median = reps % 2 ? ms[reps / 2] : 0.5 * (ms[reps / 2 - 1] + ms[reps / 2]);
    size_t found = 0;
    if (mode == Mode::kOccluded) {
      for (const uint8_t o : occluded) found += o;
    } else {
      for (const Hit& h : hits) found += h.found() ? 1 : 0;
    }
    std::printf(
        "{\"rays\": %zu, \"hits\": %zu, \"median_ms\": %.4f, \"min_ms\": %.4f, \"max_ms\": %.4f, "
        "\"mrays_per_s\": %.3f, \"cpu_ms_median\": %.4f}\n",
        rays.size(), found, median, ms.front(), ms.back(),
        static_cast<double>(rays.size()) / (median * 1e3), cpu[reps / 2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tritrace_ray_batch: %s\n", e.what());
    return 1;
  }
  return 0;
}
