// `tritrace denoise IN.exr -o OUT`: denoises a rendered EXR (colour plus tritrace's albedo,
// normal and depth layers, and a variance layer where there is one) with the feature-guided
// denoiser (docs/DENOISING.md), for example after `tritrace merge`.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace tritrace::cli {

struct DenoiseArgs {
  std::string input;
  std::string output;
  int search_radius = 7;
  std::string exposure;  // --exposure STOPS for 8-bit outputs; empty: not given
  bool quiet = false;
};

CLI::App* add_denoise_command(CLI::App& app, DenoiseArgs& args);

// Throws tritrace::Error naming the file or flag at fault. Returns the exit code.
int run_denoise(const DenoiseArgs& args);

}  // namespace tritrace::cli
