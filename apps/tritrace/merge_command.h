// `tritrace merge PART... -o OUT`: combines partial films (render --spp-range / --tile) into the
// image one process would have rendered, bit for bit.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace tritrace::cli {

struct MergeArgs {
  std::vector<std::string> parts;
  std::string output;
  std::string exposure;  // --exposure STOPS for path's 8-bit outputs; empty: not given
  bool quiet = false;
};

CLI::App* add_merge_command(CLI::App& app, MergeArgs& args);

// Throws tritrace::Error naming the part or flag at fault. Returns the exit code.
int run_merge(const MergeArgs& args);

}  // namespace tritrace::cli
