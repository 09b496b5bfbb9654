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
  Kernel kernel;
  leaks::LeakCounts counts;
};

bool is_default(const leaks::LeakPath& path, Kernel kernel) {
  return path.accel && default_kernel_for(*path.accel) == kernel;
}

unsigned long long ull(uint64_t n) {
  return static_cast<unsigned long long>(n);
}

void print_row(const std::string& mesh, const std::string& triangles, const Cell& c) {
  std::printf("| %s | %s | %s | %s%s | %llu | %llu | %.3f | %llu | %llu | %llu |\n", mesh.c_str(),
              triangles.c_str(), leaks::leak_path_name(c.path).c_str(),
              std::string(kernel_name(c.kernel)).c_str(),
              is_default(c.path, c.kernel) ? " (default)" : "", ull(c.counts.rays),
              ull(c.counts.leaks), c.counts.percent(), ull(c.counts.inside_leaks),
              ull(c.counts.outside_leaks), ull(c.counts.vertex_leaks));
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
                 "Only this path, repeatable: kernel, brute, bvh-single, bvh, 'bvh bundles' "
                 "(default: all)");
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
  if (!path_flags.empty()) {
    std::vector<leaks::LeakPath> chosen;
    for (const std::string& name : path_flags) {
      const auto it = std::find_if(paths.begin(), paths.end(), [&](const leaks::LeakPath& p) {
        return leaks::leak_path_name(p) == name;
      });
      if (it == paths.end()) {
        std::fprintf(stderr, "tritrace_leaks: --path: unknown path '%s'\n", name.c_str());
        return 2;
      }
      chosen.push_back(*it);
    }
    paths = chosen;
  }

  const auto start = std::chrono::steady_clock::now();
  std::printf(
      "| mesh | triangles | path | kernel | rays | leaks | %% | from inside | from outside | "
      "at vertices |\n|---|---|---|---|---|---|---|---|---|---|\n");
  std::vector<Cell> totals;
  for (const leaks::LeakPath& path : paths) {
    for (Kernel k : kernels) totals.push_back({path, k, {}});
  }
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
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "tritrace_leaks: %.1f s\n", seconds);
  return 0;
}
