// The bench subcommand: for each scene, build every accel with each kernel asked for (timed),
// render one warm-up frame, then `reps` timed frames; report medians and the ratios to the fastest
// non-robust Embree mode and to Embree's robust mode of the same scene. The integrator comes from
// make_integrator, as in render and the viewer.
#include "bench_command.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "bench_stats.h"
#include "build_info.h"
#include "flags/flag_values.h"
#include "secondary_rays_bench.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/job/render_job.h"
#include "tritrace/render/make_integrator.h"
#include "tritrace/scene/io/input_file.h"

namespace tritrace::cli {
namespace {

// brute is skipped where a frame would take longer than this (estimated from its cost per test).
constexpr double kBruteBudgetSeconds = 3.0;
constexpr double kBruteNsPerTest = 4.0;  // Möller–Trumbore, measured in docs/PERFORMANCE.md
// Rays a path traces on average, for that estimate: camera ray, bounces and shadow rays. Measured
// on cornell-area at 16 spp (RenderStats rays over samples): 4.8.

// The path tracer's samples per pixel when --spp is not given: enough that bounces dominate the
// frame, few enough that every accel of a run takes seconds.
constexpr int kDefaultBenchSpp = 16;

struct Record {
  std::string scene;
  size_t triangles = 0;
  std::string accel;
  std::string kernel;     // "embree" for Embree's own
  std::string bvh_build;  // bvh and bvh-single: "sah" or "morton"; empty for the others
  bool robust = false;    // Embree with RTC_SCENE_FLAG_ROBUST
  double build_ms = 0.0;
  double bytes_per_tri = 0.0;
  double copy_bytes_per_tri = 0.0;
  double frame_ms_median = 0.0, frame_ms_min = 0.0, frame_ms_max = 0.0;
  double mrays_per_s = 0.0;
  std::string integrator;  // "lab", "path" or "bdpt"
  uint32_t spp = 1;
  double light_paths = 0.0;   // bdpt: the share of samples with a light subpath (0: not bdpt)
  double mpaths_per_s = 0.0;  // camera samples (paths) per second, in millions
  std::optional<double> ratio_to_embree;         // the fastest non-robust Embree mode
  std::optional<double> ratio_to_embree_robust;  // embree-robust
  // --denoise: the denoiser's time on each frame (median); frame_ms is then the render with AOVs.
  std::optional<double> denoise_ms_median;
  int threads = 0;
  int width = 0, height = 0;
};

nlohmann::json to_json(const Record& r) {
  nlohmann::json j = {{"scene", r.scene},
                      {"triangles", r.triangles},
                      {"accel", r.accel},
                      {"kernel", r.kernel},
                      {"bvh_build", r.bvh_build},
                      {"robust", r.robust},
                      {"build_ms", r.build_ms},
                      {"bytes_per_tri", r.bytes_per_tri},
                      {"triangle_copy_bytes_per_tri", r.copy_bytes_per_tri},
                      {"frame_ms_median", r.frame_ms_median},
                      {"frame_ms_min", r.frame_ms_min},
                      {"frame_ms_max", r.frame_ms_max},
                      {"mrays_per_s", r.mrays_per_s},
                      {"integrator", r.integrator},
                      {"spp", r.spp},
                      {"light_paths", r.light_paths},
                      {"mpaths_per_s", r.mpaths_per_s},
                      {"threads", r.threads},
                      {"width", r.width},
                      {"height", r.height}};
  auto optional = [](std::optional<double> v) { return v ? nlohmann::json(*v) : nlohmann::json(); };
  j["ratio_to_embree"] = optional(r.ratio_to_embree);
  j["ratio_to_embree_robust"] = optional(r.ratio_to_embree_robust);
  j["denoise_ms_median"] = optional(r.denoise_ms_median);
  return j;
}

bool is_embree(AccelKind kind) {
  return accel_name(kind).starts_with("embree");
}

std::string ratio_text(std::optional<double> ratio) {
  char text[16] = "-";
  if (ratio) std::snprintf(text, sizeof(text), "%.2fx", *ratio);
  return text;
}

}  // namespace

CLI::App* add_bench_command(CLI::App& app, BenchArgs& args) {
  CLI::App* sub = app.add_subcommand(
      "bench",
      "Measure every acceleration structure on the lab workload or the path tracer's, beside "
      "Embree, in one run");
  sub->add_option(
         "files", args.files,
         "Scene files (.json, .pbrt) or mesh files to measure, after the --scene ones (the "
         "default scenes only when neither is given)")
      ->type_name("FILE ...");
  sub->add_option("--scene", args.scenes,
                  "Scene to measure, repeatable (default: cornell, terrain:1m, terrain:10m; with "
                  "--integrator path, cornell-area)")
      ->type_name("NAME")
      ->check(checked(setting_check("--scene")));
  sub->add_option("--integrator", args.integrator,
                  "lab (one primary and one shadow ray per pixel), path (the path tracer: "
                  "paths/s and Mrays/s over camera, bounce and shadow rays) or bdpt (the "
                  "bidirectional path tracer, the same figures)")
      ->type_name("NAME")
      ->capture_default_str()
      ->check(checked(setting_check("--integrator")));
  sub->add_option("--spp", args.spp,
                  "Samples per pixel of each path-traced frame (default 16; lab: always 1)")
      ->type_name("N")
      ->check(checked(setting_check("--spp")));
  sub->add_option("--light-paths", args.light_paths,
                  "bdpt: share of samples that also trace a light subpath, greater than 0 and at "
                  "most 1, or auto (a pilot chooses it per scene, before the timed frames), as "
                  "render's --light-paths (default: the scene's, auto)")
      ->type_name("F|auto")
      ->check(checked(setting_check("--light-paths")));
  sub->add_option("--accel", args.accels, "Acceleration structure, repeatable (default: all)")
      ->type_name("NAME")
      ->check(checked(setting_check("--accel")));
  sub->add_option("--width", args.width, "Frame width (default 1920; path: 256)")
      ->type_name("W")
      ->check(checked(setting_check("--width")));
  sub->add_option("--height", args.height, "Frame height (default 1080; path: 256)")
      ->type_name("H")
      ->check(checked(setting_check("--height")));
  sub->add_option("--reps", args.reps, "Timed frames per scene and accel, after one warm-up")
      ->type_name("N")
      ->capture_default_str()
      ->check(checked([](std::string& s) { return check_integer_in(s, 1, 1000); }));
  sub->add_option("--threads", args.threads, "Worker threads (default: all cores)")
      ->type_name("N")
      ->check(checked(setting_check("--threads")));
  sub->add_option("--kernel", args.kernels,
                  "Ray/triangle kernel for bvh and brute, repeatable: one row per kernel "
                  "(default: each one's own, as in render)")
      ->type_name("NAME")
      ->check(checked(setting_check("--kernel")));
  sub->add_option("--bvh-build", args.bvh_builds,
                  "How bvh and bvh-single build their tree, repeatable: one row per build: sah "
                  "(binned SAH) or morton (Morton codes: faster to build, slower to trace); "
                  "default sah")
      ->type_name("NAME")
      ->check(checked(check_bvh_build));
  sub->add_flag("--denoise", args.denoise,
                "path: render each frame with the denoiser's AOVs (albedo, normal, depth, "
                "variance) and time the denoiser on it too (column 'denoise ms', JSON "
                "denoise_ms_median); frame ms is then the render with AOVs");
  sub->add_flag("--secondary-rays", args.secondary_rays,
                "path, bdpt: record one frame's bounce and shadow rays (through the first "
                "--accel; default bvh and embree-single) and trace exactly those rays again, in "
                "the frame's batches, through each accel's single-ray queries: closest-hit and "
                "any-hit Mrays/s, ratios to embree-single, answers checked against the frame's");
  sub->add_option("--json", args.json, "Also write the records as a JSON array to PATH")
      ->type_name("PATH");
  sub->add_flag("-q,--quiet", args.quiet, "Print only the table");
  return sub;
}

int run_bench(const BenchArgs& args) {
  if (!args.json.empty()) check_writable_path(args.json);
  for (const std::string& file : args.files) check_input_file(file);  // before any output
  const bool path = args.integrator != "lab";                         // path or bdpt
  if (args.denoise && !path) {
    throw Error("--denoise",
                "times the denoiser on the path tracer's frames; use --integrator path",
                ExitCode::kUsage);
  }
  if (!args.light_paths.empty() && args.integrator != "bdpt") {
    throw Error("--light-paths", "applies to bdpt; use --integrator bdpt", ExitCode::kUsage);
  }
  IntegratorSpec spec;
  spec.kind = args.integrator == "bdpt" ? IntegratorSpec::Kind::kBdpt
              : path                    ? IntegratorSpec::Kind::kPath
                                        : IntegratorSpec::Kind::kLab;
  spec.spp =
      path ? static_cast<uint32_t>(args.spp.empty() ? kDefaultBenchSpp : *parse_integer(args.spp))
           : 1;
  std::vector<std::string> scenes = args.scenes;
  if (scenes.empty() && args.files.empty()) {
    scenes = path ? std::vector<std::string>{"cornell-area"}
                  : std::vector<std::string>{"cornell", "terrain:1m", "terrain:10m"};
  }
  if (args.secondary_rays && !path) {
    throw Error("--secondary-rays", "records the path tracer's rays; use --integrator path or bdpt",
                ExitCode::kUsage);
  }
  if (args.secondary_rays && (args.denoise || !args.kernels.empty() || !args.bvh_builds.empty())) {
    throw Error("--secondary-rays",
                "traces through each accel's default kernel and SAH tree; --denoise, --kernel and "
                "--bvh-build do not apply",
                ExitCode::kUsage);
  }
  std::vector<AccelKind> accels;
  for (const std::string& name : args.accels) accels.push_back(*parse_accel(name));
  if (accels.empty() && args.secondary_rays) {
    accels = {AccelKind::kBvh};
    if (accel_available(AccelKind::kEmbreeSingle)) accels.push_back(AccelKind::kEmbreeSingle);
  }
  if (accels.empty()) accels = available_accels();
  const auto side = [path](const std::string& given, int lab_default) {
    if (!given.empty()) return static_cast<int>(*parse_integer(given));
    return path ? 256 : lab_default;  // the Cornell box size for path
  };
  const int width = side(args.width, 1920);
  const int height = side(args.height, 1080);
  const int reps = static_cast<int>(*parse_integer(args.reps));
  const int threads = args.threads.empty() ? default_thread_count()
                                           : static_cast<int>(*parse_integer(args.threads));
  // Empty: each accel's default kernel (default_kernel_for).
  std::vector<Kernel> chosen_kernels;
  for (const std::string& name : args.kernels) {
    const Kernel k = *parse_kernel(name);
    if (std::find(chosen_kernels.begin(), chosen_kernels.end(), k) == chosen_kernels.end()) {
      chosen_kernels.push_back(k);
    }
  }

  if (args.secondary_rays) {
    SecondaryRaysOptions options;
    for (const std::string& name : scenes) options.sources.emplace_back(name, "");
    for (const std::string& file : args.files) {
      options.sources.emplace_back(std::filesystem::path(file).filename().string(), file);
    }
    options.accels = accels;
    options.settings.width = std::to_string(width);
    options.settings.height = std::to_string(height);
    options.settings.threads = std::to_string(threads);
    options.settings.integrator = std::string(integrator_name(spec.kind));
    options.settings.spp = std::to_string(spec.spp);
    options.settings.light_paths = args.light_paths;
    options.threads = threads;
    options.reps = reps;
    options.json = args.json;
    options.quiet = args.quiet;
    return run_secondary_rays(options);
  }

  // The lab's table keeps its columns; path adds spp and paths per second.
  if (path) {
    std::printf("%-13s %10s %-13s %-15s %10s %8s %8s %26s %6s %9s %9s %8s %8s%s\n", "scene",
                "triangles", "accel", "kernel", "build ms", "B/tri", "+tri B",
                "frame ms median (min-max)", "spp", "Mpaths/s", "Mrays/s", "/embree", "/robust",
                args.denoise ? "  denoise ms" : "");
  } else {
    std::printf("%-13s %10s %-13s %-15s %10s %8s %8s %26s %9s %8s %8s\n", "scene", "triangles",
                "accel", "kernel", "build ms", "B/tri", "+tri B", "frame ms median (min-max)",
                "Mrays/s", "/embree", "/robust");
  }
  std::fflush(stdout);

  std::vector<Record> records;
  // Built-in scenes by name, then files: each loaded as `tritrace render` loads it, at the
  // bench's image size; a file's row is named after the file.
  std::vector<std::pair<std::string, std::string>> sources;  // (row name, file or "")
  for (const std::string& name : scenes) sources.emplace_back(name, "");
  for (const std::string& file : args.files) {
    sources.emplace_back(std::filesystem::path(file).filename().string(), file);
  }
  for (const auto& [scene_name, file] : sources) {
    // Every row of a scene is a render job over the one loaded scene, with the bench's own
    // integrator, spp, size and threads and the row's accel, kernel and build.
    JobSettings settings;
    settings.file = file;
    settings.scene = file.empty() ? scene_name : std::string();
    settings.width = std::to_string(width);
    settings.height = std::to_string(height);
    settings.threads = std::to_string(threads);
    settings.integrator = std::string(integrator_name(spec.kind));
    settings.spp = std::to_string(spec.spp);
    settings.light_paths = args.light_paths;
    if (args.denoise) settings.aovs = "albedo,normal,depth,variance";
    const LoadedScene loaded = load_job_scene(settings);
    const Scene& scene = loaded.scene;
    const size_t first = records.size();
    std::vector<std::string> skipped;
    for (AccelKind kind : accels) {
      // Embree has its own kernel: one row whatever --kernel asks.
      std::vector<std::optional<Kernel>> kernels;
      if (is_embree(kind)) {
        kernels = {std::nullopt};
      } else if (chosen_kernels.empty()) {
        kernels = {default_kernel_for(kind)};
      } else {
        kernels.assign(chosen_kernels.begin(), chosen_kernels.end());
      }
      std::vector<std::optional<bvh::BuildMethod>> builds = {std::nullopt};
      if (kind == AccelKind::kBvh || kind == AccelKind::kBvhSingle) {
        builds = {bvh::BuildMethod::kBinnedSah};
        if (!args.bvh_builds.empty()) builds.clear();
        for (const std::string& name : args.bvh_builds) {
          const bvh::BuildMethod b = *parse_bvh_build(name);
          if (std::find(builds.begin(), builds.end(), b) == builds.end()) builds.emplace_back(b);
        }
      }
      for (const std::optional<Kernel> kernel : kernels) {
        for (const std::optional<bvh::BuildMethod> build : builds) {
          Record r;
          r.scene = scene_name;
          r.triangles = static_cast<size_t>(scene.drawn_triangles());
          r.accel = std::string(accel_name(kind));
          if (build) {
            r.bvh_build = std::string(bvh_build_name(*build));
            if (*build != bvh::BuildMethod::kBinnedSah) r.accel += "/" + r.bvh_build;
          }
          r.kernel = kernel ? std::string(kernel_name(*kernel)) : "embree";
          r.robust = kind == AccelKind::kEmbreeRobust;
          r.threads = threads;
          r.width = width;
          r.height = height;
          r.integrator = std::string(integrator_name(spec.kind));
          r.spp = spec.spp;
          if (kind == AccelKind::kBrute) {
            const double estimate = expected_rays(spec, static_cast<uint64_t>(width) * height) *
                                    static_cast<double>(scene.drawn_triangles()) * kBruteNsPerTest *
                                    1e-9 / threads;
            if (estimate > kBruteBudgetSeconds) {
              char line[160];
              std::snprintf(
                  line, sizeof(line), "%-13s %10zu %-13s %-15s skipped: about %.0f s per frame",
                  scene_name.c_str(), r.triangles, r.accel.c_str(), r.kernel.c_str(), estimate);
              skipped.emplace_back(line);
              continue;
            }
          }
          JobSettings row = settings;
          row.accel = std::string(accel_name(kind));
          row.kernel = kernel ? std::string(kernel_name(*kernel)) : std::string();
          row.bvh_build = std::string(bvh_build_name(build.value_or(bvh::BuildMethod::kBinnedSah)));
          RenderJob job(row, scene, loaded.integrator);
          AccelInfo info;
          job.prepare(&info);
          r.light_paths = job.light_paths();
          if (!args.quiet && kind == accels.front()) {
            if (const std::string lp = job.light_paths_summary(); !lp.empty()) {
              std::printf("%s: %s\n", scene_name.c_str(), lp.c_str());
            }
          }
          r.build_ms = info.build_ms;
          r.bytes_per_tri =
              static_cast<double>(info.structure_bytes) / std::max<size_t>(1, r.triangles);
          r.copy_bytes_per_tri =
              static_cast<double>(info.triangle_copy_bytes) / std::max<size_t>(1, r.triangles);
          std::vector<double> ms, denoise_ms;
          uint64_t rays = 0, samples = 0;
          for (int i = 0; i <= reps; ++i) {  // frame 0 warms caches and threads up, untimed
            RenderStats stats;
            const RenderedImage frame = job.render(&stats);
            if (args.denoise) {
              const auto start = std::chrono::steady_clock::now();
              // What render --denoise runs: the variance layer smoothed and corrected, both passes.
              const Image denoised =
                  denoise_film_image(frame.image, frame.aovs, job.options().sampler);
              const std::chrono::duration<double, std::milli> took =
                  std::chrono::steady_clock::now() - start;
              if (i > 0) denoise_ms.push_back(took.count());
            }
            if (i == 0) continue;
            ms.push_back(stats.milliseconds);
            rays += stats.rays;
            samples += stats.samples;
          }
          r.frame_ms_median = median(ms);
          r.frame_ms_min = *std::min_element(ms.begin(), ms.end());
          r.frame_ms_max = *std::max_element(ms.begin(), ms.end());
          // Rays per frame are the same every frame; the rate uses the median frame.
          r.mrays_per_s = static_cast<double>(rays) / reps / (r.frame_ms_median * 1e3);
          r.mpaths_per_s = static_cast<double>(samples) / reps / (r.frame_ms_median * 1e3);
          if (args.denoise) r.denoise_ms_median = median(denoise_ms);
          records.push_back(r);
        }
      }
    }
    // Ratios against the fastest non-robust Embree mode of this scene (Embree at its fastest), and
    // against its robust mode (like for like with a watertight kernel). For the path tracer the
    // measure is paths per second: every accel renders the same paths, and their rays (how many
    // bounces survive) differ slightly where Embree's rounding sends a path elsewhere.
    const auto speed = [path](const Record& r) { return path ? r.mpaths_per_s : r.mrays_per_s; };
    double embree_best = 0.0, embree_robust = 0.0;
    for (size_t i = first; i < records.size(); ++i) {
      if (records[i].robust) {
        embree_robust = speed(records[i]);
      } else if (records[i].kernel == "embree") {
        embree_best = std::max(embree_best, speed(records[i]));
      }
    }
    for (size_t i = first; i < records.size(); ++i) {
      Record& r = records[i];
      if (embree_best > 0.0) r.ratio_to_embree = speed(r) / embree_best;
      if (embree_robust > 0.0) r.ratio_to_embree_robust = speed(r) / embree_robust;
      char frame[64];
      std::snprintf(frame, sizeof(frame), "%.1f (%.1f-%.1f)", r.frame_ms_median, r.frame_ms_min,
                    r.frame_ms_max);
      if (path) {
        char denoise_column[32] = "";
        if (r.denoise_ms_median) {
          std::snprintf(denoise_column, sizeof denoise_column, " %11.1f", *r.denoise_ms_median);
        }
        std::printf("%-13s %10zu %-13s %-15s %10.1f %8.1f %8.1f %26s %6u %9.3g %9.1f %8s %8s%s\n",
                    r.scene.c_str(), r.triangles, r.accel.c_str(), r.kernel.c_str(), r.build_ms,
                    r.bytes_per_tri, r.copy_bytes_per_tri, frame, r.spp, r.mpaths_per_s,
                    r.mrays_per_s, ratio_text(r.ratio_to_embree).c_str(),
                    ratio_text(r.ratio_to_embree_robust).c_str(), denoise_column);
      } else {
        std::printf("%-13s %10zu %-13s %-15s %10.1f %8.1f %8.1f %26s %9.1f %8s %8s\n",
                    r.scene.c_str(), r.triangles, r.accel.c_str(), r.kernel.c_str(), r.build_ms,
                    r.bytes_per_tri, r.copy_bytes_per_tri, frame, r.mrays_per_s,
                    ratio_text(r.ratio_to_embree).c_str(),
                    ratio_text(r.ratio_to_embree_robust).c_str());
      }
    }
    for (const std::string& line : skipped) std::printf("%s\n", line.c_str());
    std::fflush(stdout);
  }
  if (!args.quiet && path) {
    std::printf(
        "/embree: Mpaths/s over the fastest non-robust Embree mode's (embree, embree8, "
        "embree-single); /robust: over embree-robust's (RTC_SCENE_FLAG_ROBUST)\n");
    std::printf("integrator %s, %u spp, max depth %d, %s sampler, seed %llu, box filter\n",
                std::string(integrator_name(spec.kind)).c_str(), spec.spp, spec.max_depth,
                std::string(sampler_name(spec.sampler)).c_str(),
                static_cast<unsigned long long>(spec.seed));
  } else if (!args.quiet) {
    std::printf(
        "/embree: Mrays/s over the fastest non-robust Embree mode's (embree, embree8, "
        "embree-single); /robust: over embree-robust's (RTC_SCENE_FLAG_ROBUST)\n");
    std::printf("%dx%d, %d thread%s, %d timed frames after one warm-up; peak RSS %ld MiB\n", width,
                height, threads, threads == 1 ? "" : "s", reps, peak_rss_mib());
  }
  if (!args.json.empty()) {
    nlohmann::json out = nlohmann::json::array();
    const nlohmann::json build = build_json();
    for (const Record& r : records) {
      nlohmann::json j = to_json(r);
      j.update(build);  // commit, compiler, CPU model, Embree version ... in every record
      out.push_back(j);
    }
    const std::string text = out.dump(2) + "\n";
    write_file_atomic(args.json,
                      std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
  }
  return 0;
}

}  // namespace tritrace::cli
