#include "secondary_rays_bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "bench_stats.h"
#include "build_info.h"
#include "tritrace/accel/recording_accel.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/job/render_job.h"

namespace tritrace::cli {
namespace {

// Closest hits whose t differ by more than this fraction of t (at least of 1) disagree.
constexpr double kTTolerance = 1e-5;

// CPU seconds of the whole process (every thread), which other processes on a loaded machine
// barely change, beside the wall-clock time.
double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Times {
  std::vector<double> wall_ms, cpu_ms;
};

// How an accel's answers differ from the recorded ones.
struct Disagreements {
  uint64_t closest_hit_or_miss = 0;    // one found a hit, the other none
  uint64_t closest_t = 0;              // both hit, t beyond kTTolerance
  uint64_t closest_not_identical = 0;  // t, u, v or prim not bit for bit the recorded
  uint64_t any = 0;                    // occluded differs
};

Disagreements compare(const RecordedRays& recorded, const std::vector<Hit>& hits,
                      const std::vector<uint8_t>& occluded) {
  Disagreements d;
  for (size_t i = 0; i < hits.size(); ++i) {
    const Hit& a = recorded.hits[i];
    const Hit& b = hits[i];
    if (std::memcmp(&a, &b, sizeof(Hit)) != 0) ++d.closest_not_identical;
    if (a.found() != b.found()) {
      ++d.closest_hit_or_miss;
    } else if (a.found() && std::abs(static_cast<double>(a.t) - b.t) >
                                kTTolerance * std::max(1.0, std::abs(static_cast<double>(a.t)))) {
      ++d.closest_t;
    }
  }
  for (size_t i = 0; i < occluded.size(); ++i) {
    if ((recorded.occluded[i] != 0) != (occluded[i] != 0)) ++d.any;
  }
  return d;
}

struct Row {
  std::string scene;
  size_t triangles = 0;
  std::string accel;
  double build_ms = 0.0;
  uint64_t closest_rays = 0, any_rays = 0, closest_batches = 0, any_batches = 0;
  double closest_ms = 0.0, any_ms = 0.0, closest_cpu_ms = 0.0, any_cpu_ms = 0.0;
  double closest_min = 0.0, closest_max = 0.0, any_min = 0.0, any_max = 0.0;
  std::optional<double> closest_ratio, any_ratio, closest_cpu_ratio, any_cpu_ratio;
  Disagreements disagree;
  bool recorder = false;  // the accel that rendered the recorded frame
};

double mrays(uint64_t rays, double ms) {
  return ms > 0.0 ? static_cast<double>(rays) / (ms * 1e3) : 0.0;
}

std::string ratio_text(std::optional<double> ratio) {
  char text[16] = "-";
  if (ratio) std::snprintf(text, sizeof(text), "%.2fx", *ratio);
  return text;
}

nlohmann::json to_json(const Row& r, const JobSettings& settings, int threads, int reps) {
  auto optional = [](std::optional<double> v) { return v ? nlohmann::json(*v) : nlohmann::json(); };
  return {{"scene", r.scene},
          {"triangles", r.triangles},
          {"accel", r.accel},
          {"build_ms", r.build_ms},
          {"recorded_with", r.recorder},
          {"integrator", settings.integrator},
          {"spp", std::stoi(settings.spp)},
          {"width", std::stoi(settings.width)},
          {"height", std::stoi(settings.height)},
          {"threads", threads},
          {"reps", reps},
          {"closest_rays", r.closest_rays},
          {"closest_batches", r.closest_batches},
          {"any_rays", r.any_rays},
          {"any_batches", r.any_batches},
          {"closest_ms_median", r.closest_ms},
          {"closest_ms_min", r.closest_min},
          {"closest_ms_max", r.closest_max},
          {"any_ms_median", r.any_ms},
          {"any_ms_min", r.any_min},
          {"any_ms_max", r.any_max},
          {"closest_cpu_ms_median", r.closest_cpu_ms},
          {"any_cpu_ms_median", r.any_cpu_ms},
          {"closest_mrays_per_s", mrays(r.closest_rays, r.closest_ms)},
          {"any_mrays_per_s", mrays(r.any_rays, r.any_ms)},
          {"closest_ratio_to_embree_single", optional(r.closest_ratio)},
          {"any_ratio_to_embree_single", optional(r.any_ratio)},
          {"closest_cpu_ratio_to_embree_single", optional(r.closest_cpu_ratio)},
          {"any_cpu_ratio_to_embree_single", optional(r.any_cpu_ratio)},
          {"closest_hit_or_miss_disagreements", r.disagree.closest_hit_or_miss},
          {"closest_t_disagreements", r.disagree.closest_t},
          {"closest_not_identical", r.disagree.closest_not_identical},
          {"any_disagreements", r.disagree.any}};
}

}  // namespace

int run_secondary_rays(const SecondaryRaysOptions& options) {
  const int threads = options.threads;
  std::printf("%-13s %10s %-13s %10s %9s %9s %22s %22s %8s %8s %8s %8s %8s %8s\n", "scene",
              "triangles", "accel", "build ms", "closest", "any", "closest ms (min-max)",
              "any ms (min-max)", "closestM", "anyM", "/single", "/single", "cpu/sgl", "cpu/sgl");
  std::fflush(stdout);
  std::vector<Row> rows;
  std::vector<std::string> notes;
  for (const auto& [scene_name, file] : options.sources) {
    JobSettings settings = options.settings;
    settings.file = file;
    settings.scene = file.empty() ? scene_name : std::string();
    const LoadedScene loaded = load_job_scene(settings);
    const Scene& scene = loaded.scene;

    std::vector<std::unique_ptr<Accel>> accels;
    std::vector<Row> scene_rows;
    for (const AccelKind kind : options.accels) {
      AccelInfo info;
      accels.push_back(
          make_accel(kind, scene, default_kernel_for(kind), &info, bvh::BuildMethod::kBinnedSah));
      Row r;
      r.scene = scene_name;
      r.triangles = static_cast<size_t>(scene.drawn_triangles());
      r.accel = std::string(accel_name(kind));
      r.build_ms = info.build_ms;
      scene_rows.push_back(r);
    }
    scene_rows[0].recorder = true;

    // The frame `bench --integrator path` renders, through the first accel, recorded on one
    // thread so that the batches come in the order of the tiles (RecordingAccel::take); the same
    // rays on any number of threads.
    RecordingAccel recording(*accels[0], GroupOrder::kCallOrder);
    JobSettings row = settings;
    row.threads = "1";
    row.accel = std::string(accel_name(options.accels[0]));
    row.bvh_build = "sah";
    RenderJob job(row, scene, loaded.integrator);
    job.prepare(nullptr, &recording);
    RenderStats stats;
    job.render(&stats);
    const RecordedRays recorded = recording.take();
    const uint64_t closest_rays = recorded.closest.rays.size();
    const uint64_t any_rays = recorded.any.rays.size();
    {
      char line[256];
      std::snprintf(
          line, sizeof(line),
          "%s: frame of %llu rays recorded through %s: %llu camera (coherent) in %zu groups, "
          "%llu closest-hit in %zu batches, %llu any-hit in %zu batches%s",
          scene_name.c_str(), static_cast<unsigned long long>(stats.rays), row.accel.c_str(),
          static_cast<unsigned long long>(recorded.coherent_rays), recorded.closest.groups.size(),
          static_cast<unsigned long long>(closest_rays), recorded.closest.sizes.size(),
          static_cast<unsigned long long>(any_rays), recorded.any.sizes.size(),
          recorded.coherent_rays + closest_rays + any_rays == stats.rays
              ? ""
              : " (NOT the frame's count)");
      notes.emplace_back(line);
    }

    // Rounds of every accel in turn, the first accel of each round rotating; round 0 warms up and
    // keeps the answers to check.
    const size_t n = accels.size();
    std::vector<Times> closest_times(n), any_times(n);
    std::vector<Hit> hits(closest_rays);
    std::vector<uint8_t> occluded(any_rays);
    for (int round = 0; round <= options.reps; ++round) {
      for (size_t j = 0; j < n; ++j) {
        const size_t a = (j + static_cast<size_t>(round)) % n;
        const auto time = [&](Times& into, const auto& trace) {
          const double cpu0 = process_cpu_seconds();
          const auto start = std::chrono::steady_clock::now();
          trace();
          const std::chrono::duration<double, std::milli> took =
              std::chrono::steady_clock::now() - start;
          const double cpu = (process_cpu_seconds() - cpu0) * 1e3;
          if (round > 0) {
            into.wall_ms.push_back(took.count());
            into.cpu_ms.push_back(cpu);
          }
        };
        time(closest_times[a],
             [&] { replay_closest(*accels[a], recorded.closest, hits, threads); });
        time(any_times[a], [&] { replay_any(*accels[a], recorded.any, occluded, threads); });
        if (round == 0) scene_rows[a].disagree = compare(recorded, hits, occluded);
      }
    }
    for (size_t a = 0; a < n; ++a) {
      Row& r = scene_rows[a];
      r.closest_rays = closest_rays;
      r.any_rays = any_rays;
      r.closest_batches = recorded.closest.sizes.size();
      r.any_batches = recorded.any.sizes.size();
      const Times& c = closest_times[a];
      const Times& y = any_times[a];
      r.closest_ms = median(c.wall_ms);
      r.any_ms = median(y.wall_ms);
      r.closest_cpu_ms = median(c.cpu_ms);
      r.any_cpu_ms = median(y.cpu_ms);
      r.closest_min = *std::min_element(c.wall_ms.begin(), c.wall_ms.end());
      r.closest_max = *std::max_element(c.wall_ms.begin(), c.wall_ms.end());
      r.any_min = *std::min_element(y.wall_ms.begin(), y.wall_ms.end());
      r.any_max = *std::max_element(y.wall_ms.begin(), y.wall_ms.end());
    }
    // Ratios of speed (time of embree-single over the row's time) on the same rays.
    const auto single =
        std::find(options.accels.begin(), options.accels.end(), AccelKind::kEmbreeSingle);
    if (single != options.accels.end()) {
      const Row& s = scene_rows[static_cast<size_t>(single - options.accels.begin())];
      for (Row& r : scene_rows) {
        r.closest_ratio = s.closest_ms / r.closest_ms;
        r.any_ratio = s.any_ms / r.any_ms;
        r.closest_cpu_ratio = s.closest_cpu_ms / r.closest_cpu_ms;
        r.any_cpu_ratio = s.any_cpu_ms / r.any_cpu_ms;
      }
    }
    for (const Row& r : scene_rows) {
      char closest[64], any[64];
      std::snprintf(closest, sizeof(closest), "%.1f (%.1f-%.1f)", r.closest_ms, r.closest_min,
                    r.closest_max);
      std::snprintf(any, sizeof(any), "%.1f (%.1f-%.1f)", r.any_ms, r.any_min, r.any_max);
      std::printf("%-13s %10zu %-13s %10.1f %9llu %9llu %22s %22s %8.2f %8.2f %8s %8s %8s %8s\n",
                  r.scene.c_str(), r.triangles, r.accel.c_str(), r.build_ms,
                  static_cast<unsigned long long>(r.closest_rays),
                  static_cast<unsigned long long>(r.any_rays), closest, any,
                  mrays(r.closest_rays, r.closest_ms), mrays(r.any_rays, r.any_ms),
                  ratio_text(r.closest_ratio).c_str(), ratio_text(r.any_ratio).c_str(),
                  ratio_text(r.closest_cpu_ratio).c_str(), ratio_text(r.any_cpu_ratio).c_str());
      char line[256];
      std::snprintf(line, sizeof(line),
                    "%s, %s against the recorded answers: closest hit %llu hit/miss and %llu t "
                    "disagreements, %llu not bit for bit; any hit %llu disagreements",
                    r.scene.c_str(), r.accel.c_str(),
                    static_cast<unsigned long long>(r.disagree.closest_hit_or_miss),
                    static_cast<unsigned long long>(r.disagree.closest_t),
                    static_cast<unsigned long long>(r.disagree.closest_not_identical),
                    static_cast<unsigned long long>(r.disagree.any));
      notes.emplace_back(line);
    }
    std::fflush(stdout);
    rows.insert(rows.end(), scene_rows.begin(), scene_rows.end());
  }
  for (const std::string& line : notes) std::printf("%s\n", line.c_str());
  if (!options.quiet) {
    std::printf(
        "closest: intersect_incoherent (bounce rays), any: occluded_incoherent (shadow rays), "
        "recorded on one thread, replayed in the frame's batches and tile order; ms: medians of %d "
        "alternated rounds after a warm-up; "
        "closestM, anyM: Mrays/s; /single: speed over embree-single's (wall time), cpu/sgl: the "
        "same from process CPU time; t tolerance %g relative\n",
        options.reps, kTTolerance);
    std::printf("integrator %s, %s spp, %sx%s, %d thread%s; peak RSS %ld MiB\n",
                options.settings.integrator.c_str(), options.settings.spp.c_str(),
                options.settings.width.c_str(), options.settings.height.c_str(), threads,
                threads == 1 ? "" : "s", peak_rss_mib());
  }
  if (!options.json.empty()) {
    nlohmann::json out = nlohmann::json::array();
    const nlohmann::json build = build_json();
    for (const Row& r : rows) {
      nlohmann::json j = to_json(r, options.settings, threads, options.reps);
      j.update(build);
      out.push_back(j);
    }
    const std::string text = out.dump(2) + "\n";
    write_file_atomic(options.json,
                      std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
  }
  return 0;
}

}  // namespace tritrace::cli
