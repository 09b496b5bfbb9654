// `tritrace render [FILE]`: renders a built-in scene, a JSON scene or a mesh file with the lab
// integrator to an image file.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace tritrace::cli {

struct RenderArgs {
  std::string file;           // empty: the built-in Cornell box
  std::string output;         // the scene file's output, else <file stem>.png or cornell.png
  bool output_given = false;  // -o was on the command line (its value may still be empty)
  std::string width;          // empty: the scene's (500 for the built-in and for meshes)
  std::string height;
  std::string scene;  // a built-in scene name (make_builtin_scene); empty: cornell
  std::string accel = "bvh";
  std::string kernel;   // empty: the default kernel
  std::string yaw;      // empty: no orbit
  std::string light;    // empty: the scene's light position
  std::string threads;  // empty: all cores
  bool quiet = false;
};

// Registers the subcommand and its flags on `app`; values land in `args` when parsed.
CLI::App* add_render_command(CLI::App& app, RenderArgs& args);

// Runs a parsed render; throws tritrace::Error on bad values or I/O failures. Returns the exit
// code.
int run_render(const RenderArgs& args);

}  // namespace tritrace::cli
