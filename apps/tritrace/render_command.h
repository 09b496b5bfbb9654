// `tritrace render`: renders a built-in scene with the lab integrator to an image file.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace tritrace::cli {

struct RenderArgs {
  std::string output = "cornell.png";
  std::string width = "500";
  std::string height = "500";
  std::string scene = "cornell";
  std::string accel = "bvh";
  std::string kernel;  // empty: the default kernel
  std::string yaw = "0";
  std::string light;    // empty: the lab's light position
  std::string threads;  // empty: all cores
  bool quiet = false;
};

// Registers the subcommand and its flags on `app`; values land in `args` when parsed.
CLI::App* add_render_command(CLI::App& app, RenderArgs& args);

// Runs a parsed render; throws tritrace::Error on bad values or I/O failures. Returns the exit
// code.
int run_render(const RenderArgs& args);

}  // namespace tritrace::cli
