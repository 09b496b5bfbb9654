// tritrace_leaks: the full closed-mesh leak count for every kernel, alone and through every accel
// (docs/RELIABILITY.md), printed as Markdown tables. The ctest version runs fewer rays and checks
// the watertight and default kernels only.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "leaks/leak_count.h"

namespace {

using namespace tritrace;

struct Cell {
  leaks::LeakPath path;
  Kernel kernel;  // ignored by Embree
  leaks::LeakCounts counts;
};

bool embree(const leaks::LeakPath& path) {
  return path.accel == AccelKind::kEmbree || path.accel == AccelKind::kEmbreeRobust;
}

bool is_default(const leaks::LeakPath& path, Kernel kernel) {
  return path.accel && !embree(path) && default_kernel_for(*path.accel) == kernel;
}

std::string kernel_text(const Cell& c) {
  if (embree(c.path)) return "embree's own";
  return std::string(kernel_name(c.kernel)) + (is_default(c.path, c.kernel) ? " (default)" : "");
}

unsigned long long ull(uint64_t n) {
  return static_cast<unsigned long long>(n);
}

void print_row(const std::string& mesh, const std::string& triangles, const Cell& c) {
  std::printf("| %s | %s | %s | %s | %llu | %llu | %.3f | %llu | %llu | %llu |\n", mesh.c_str(),
              triangles.c_str(), leaks::leak_path_name(c.path).c_str(), kernel_text(c).c_str(),
              ull(c.counts.rays), ull(c.counts.leaks), c.counts.percent(),
              ull(c.counts.inside_leaks), ull(c.counts.outside_leaks), ull(c.counts.vertex_leaks));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "Counts rays that slip through closed meshes when aimed at their edges and vertices, for "
      "each kernel alone and through each accel");
  leaks::LeakOptions options;
  options.rays = 2'000'000;
  // Brute force tests every triangle for every ray: on the spheres (1280 and 2208 triangles) it
  // gets the first rays of the same set, as many as this many triangle tests allow.
  uint64_t brute_tests = 200'000'000;
  std::vector<std::string> kernel_flags, path_flags;
  app.add_option("--rays", options.rays, "Rays per mesh, kernel and path")->capture_default_str();
  app.add_option("--brute-tests", brute_tests,
                 "Ray/triangle tests per mesh and kernel for brute (fewer rays on big meshes)")
      ->capture_default_str();
  app.add_option("--seed", options.seed, "Random seed (the same rays for every kernel and path)")
      ->capture_default_str();
  app.add_option("--kernel", kernel_flags, "Only this kernel, repeatable (default: all)");
  app.add_option("--path", path_flags,
                 "Only this path, repeatable: kernel, brute, bvh-single, bvh, 'bvh bundles', "
                 "embree, 'embree bundles', embree-robust, 'embree-robust bundles' (default: all "
                 "this build has)");
  app.add_flag("--all-triangles", options.all_triangles,
               "Kernel alone: test every triangle of the mesh, not only those around the target");
  CLI11_PARSE(app, argc, argv);

  std::vector<Kernel> kernels(kAllKernels.begin(), kAllKernels.end());
  if (!kernel_flags.empty()) kernels.clear();
  for (const std::string& name : kernel_flags) {
    const auto k = parse_kernel(name);
    if (!k) {
      std::fprintf(stderr, "tritrace_leaks: --kernel: unknown kernel '%s'\n", name.c_str());
      return 2;
    }
    kernels.push_back(*k);
  }
  std::vector<leaks::LeakPath> paths = leaks::report_paths();
  // Embree, for comparison, with its own kernel: plain and robust (RTC_SCENE_FLAG_ROBUST).
  std::vector<leaks::LeakPath> embree_paths;
  for (AccelKind kind : {AccelKind::kEmbree, AccelKind::kEmbreeRobust}) {
    if (!accel_available(kind)) continue;
    embree_paths.push_back({kind});
    embree_paths.push_back({kind, /*bundles=*/true});
  }
  if (!path_flags.empty()) {
    auto keep = [&](std::vector<leaks::LeakPath>& list) {
      std::erase_if(list, [&](const leaks::LeakPath& p) {
        return std::find(path_flags.begin(), path_flags.end(), leaks::leak_path_name(p)) ==
               path_flags.end();
      });
    };
    for (const std::string& name : path_flags) {
      auto named = [&](const leaks::LeakPath& p) { return leaks::leak_path_name(p) == name; };
      if (std::none_of(paths.begin(), paths.end(), named) &&
          std::none_of(embree_paths.begin(), embree_paths.end(), named)) {
        std::fprintf(stderr, "tritrace_leaks: --path: unknown path '%s'\n", name.c_str());
        return 2;
      }
    }
    keep(paths);
    keep(embree_paths);
  }

  const auto start = std::chrono::steady_clock::now();
  std::printf(
      "| mesh | triangles | path | kernel | rays | leaks | %% | from inside | from outside | "
      "at vertices |\n|---|---|---|---|---|---|---|---|---|---|\n");
  // The path x kernel grid first, then one cell per Embree path.
  std::vector<Cell> totals;
  for (const leaks::LeakPath& path : paths) {
    for (Kernel k : kernels) totals.push_back({path, k, {}});
  }
  for (const leaks::LeakPath& path : embree_paths)
    totals.push_back({path, Kernel::kWatertight, {}});
  for (const leaks::IndexedMesh& mesh : leaks::leak_test_meshes()) {
    std::vector<leaks::LeakRun> runs;
    for (const Cell& c : totals) {
      uint64_t rays = options.rays;
      if (c.path.accel == AccelKind::kBrute) {
        rays = std::min(rays, std::max<uint64_t>(1, brute_tests / mesh.triangles.size()));
      }
      runs.push_back({c.path, c.kernel, rays});
    }
    const std::vector<leaks::LeakCounts> counts = leaks::count_leaks(mesh, runs, options);
    for (size_t i = 0; i < runs.size(); ++i) {
      totals[i].counts += counts[i];
      print_row(mesh.name, std::to_string(mesh.triangles.size()),
                {runs[i].path, runs[i].kernel, counts[i]});
    }
    std::fflush(stdout);
  }
  for (const Cell& c : totals) print_row("**all meshes**", "", c);

  // The summary: one row per path, one column per kernel.
  std::printf("\n| path |");
  for (Kernel k : kernels) std::printf(" %s |", std::string(kernel_name(k)).c_str());
  std::printf("\n|---|");
  for (size_t k = 0; k < kernels.size(); ++k) std::printf("---|");
  std::printf("\n");
  for (size_t p = 0; p < paths.size(); ++p) {
    std::printf("| %s |", leaks::leak_path_name(paths[p]).c_str());
    for (size_t k = 0; k < kernels.size(); ++k) {
      const Cell& c = totals[p * kernels.size() + k];
      const char* mark = is_default(c.path, c.kernel) ? "**" : "";
      std::printf(" %s%llu / %llu (%.3f%%)%s |", mark, ull(c.counts.leaks), ull(c.counts.rays),
                  c.counts.percent(), mark);
    }
    std::printf("\n");
  }
  std::printf("\nBold: the accel's default kernel (default_kernel_for).\n");
  if (!embree_paths.empty()) {
    std::printf("\n| Embree, its own kernel | leaks / rays |\n|---|---|\n");
    for (size_t i = paths.size() * kernels.size(); i < totals.size(); ++i) {
      const Cell& c = totals[i];
      std::printf("| %s | %llu / %llu (%.3f%%) |\n", leaks::leak_path_name(c.path).c_str(),
                  ull(c.counts.leaks), ull(c.counts.rays), c.counts.percent());
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "tritrace_leaks: %.1f s\n", seconds);
  return 0;
}
