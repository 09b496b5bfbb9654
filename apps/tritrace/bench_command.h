// `tritrace bench`: the lab workload (one primary and one shadow ray per pixel, all threads), or
// with --integrator path the path tracer's (coherent camera rays, incoherent bounces and shadow
// rays), on several scenes, every acceleration structure and the kernels asked for, side by side
// in one run, with the ratio of each to Embree's best non-robust mode and to Embree's robust mode.
// Also takes scene and mesh files. Prints a table; --json writes the same records for scripts,
// each with the build and CPU (build_info.h).
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace tritrace::cli {

struct BenchArgs {
  std::vector<std::string> scenes;  // empty (and no files): cornell, terrain:1m, terrain:10m
                                    // (path: cornell-area)
  std::vector<std::string> files;   // scene files (.json) and mesh files, after the built-ins
  std::vector<std::string> accels;  // empty: every accel this build has
  std::string integrator = "lab";
  std::string width;        // empty: 1920 (path: 256)
  std::string height;       // empty: 1080 (path: 256)
  std::string spp;          // path only; empty: 16
  std::string light_paths;  // bdpt only: F or auto; empty: the scene's (as render's)
  std::string reps = "5";
  std::string threads;                  // empty: all cores
  std::vector<std::string> kernels;     // empty: each accel's default kernel
  std::vector<std::string> bvh_builds;  // empty: sah
  std::string json;                     // empty: no JSON file
  bool denoise = false;  // path: each frame's film keeps the denoiser's AOVs and is denoised
  bool quiet = false;
  // path, bdpt: the frame's bounce and shadow rays recorded and traced again through each accel
  // (secondary_rays_bench.h) instead of whole frames.
  bool secondary_rays = false;
};

CLI::App* add_bench_command(CLI::App& app, BenchArgs& args);
int run_bench(const BenchArgs& args);

}  // namespace tritrace::cli
