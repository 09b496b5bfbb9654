// tritrace_leaks: the full closed-mesh leak count for every kernel (docs/RELIABILITY.md), printed
// as a Markdown table. The ctest version runs fewer rays and checks the watertight kernel only.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "leaks/leak_count.h"

int main(int argc, char** argv) {
  using namespace tritrace;
  CLI::App app(
      "Counts rays that slip through closed meshes when aimed at their edges and vertices");
  leaks::LeakOptions options;
  options.rays = 10'000'000;
  std::string kernel_flag;
  app.add_option("--rays", options.rays, "Rays per mesh and kernel")->capture_default_str();
  app.add_option("--seed", options.seed, "Random seed (the same rays for every kernel)")
      ->capture_default_str();
  app.add_option("--kernel", kernel_flag, "Only this kernel (default: all)");
  app.add_flag("--all-triangles", options.all_triangles,
               "Test every triangle of the mesh, not only those around the target (slower)");
  CLI11_PARSE(app, argc, argv);

  std::vector<Kernel> kernels(kAllKernels.begin(), kAllKernels.end());
  if (!kernel_flag.empty()) {
    const auto k = parse_kernel(kernel_flag);
    if (!k) {
      std::fprintf(stderr, "tritrace_leaks: --kernel: unknown kernel '%s'\n", kernel_flag.c_str());
      return 2;
    }
    kernels = {*k};
  }

  const auto start = std::chrono::steady_clock::now();
  std::printf(
      "| mesh | triangles | kernel | rays | leaks | %% | from inside | from outside | "
      "at vertices |\n|---|---|---|---|---|---|---|---|---|\n");
  std::vector<leaks::LeakCounts> totals(kernels.size());
  for (const leaks::IndexedMesh& mesh : leaks::leak_test_meshes()) {
    for (size_t k = 0; k < kernels.size(); ++k) {
      const leaks::LeakCounts c = leaks::count_leaks(mesh, kernels[k], options);
      totals[k] += c;
      std::printf("| %s | %zu | %s | %llu | %llu | %.3f | %llu | %llu | %llu |\n",
                  mesh.name.c_str(), mesh.triangles.size(),
                  std::string(kernel_name(kernels[k])).c_str(),
                  static_cast<unsigned long long>(c.rays), static_cast<unsigned long long>(c.leaks),
                  c.percent(), static_cast<unsigned long long>(c.inside_leaks),
                  static_cast<unsigned long long>(c.outside_leaks),
                  static_cast<unsigned long long>(c.vertex_leaks));
      std::fflush(stdout);
    }
  }
  for (size_t k = 0; k < kernels.size(); ++k) {
    const leaks::LeakCounts& c = totals[k];
    std::printf("| **all meshes** | | %s | %llu | %llu | %.3f | %llu | %llu | %llu |\n",
                std::string(kernel_name(kernels[k])).c_str(),
                static_cast<unsigned long long>(c.rays), static_cast<unsigned long long>(c.leaks),
                c.percent(), static_cast<unsigned long long>(c.inside_leaks),
                static_cast<unsigned long long>(c.outside_leaks),
                static_cast<unsigned long long>(c.vertex_leaks));
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "tritrace_leaks: %.1f s\n", seconds);
  return 0;
}
