// `tritrace render [FILE]`: renders a built-in scene, a JSON scene or a mesh file with the lab
// integrator to an image file.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "flags/scene_flags.h"

namespace tritrace::cli {

struct RenderArgs {
  SceneFlags scene;           // FILE, the scene and its view, shared with tritrace-view
  std::string output;         // the scene file's output, else <file stem>.png or cornell.png
  bool output_given = false;  // -o was on the command line (its value may still be empty)
  bool quiet = false;
};

// Registers the subcommand and its flags on `app`; values land in `args` when parsed.
CLI::App* add_render_command(CLI::App& app, RenderArgs& args);

// Runs a parsed render; throws tritrace::Error on bad values or I/O failures. Returns the exit
// code.
int run_render(const RenderArgs& args);

}  // namespace tritrace::cli
