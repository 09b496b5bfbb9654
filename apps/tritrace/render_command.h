// `tritrace render [FILE]`: renders a built-in scene, a JSON scene or a mesh file with the lab
// integrator or the path tracer to an image file (8-bit, PFM, or EXR with AOV layers).
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
  std::string aovs;       // --aovs: "albedo,normal,depth" or a subset; empty: not given
  bool exr_half = false;  // --exr-half: half floats in the EXR
  std::string exposure;   // --exposure STOPS for path's 8-bit images; empty: not given
  std::string spp_range;  // --spp-range A:B: a partial film of samples [A, B); empty: not given
  std::string tile;  // --tile I/N: a partial film of the I-th of N tile parts; empty: not given
  bool mpi = false;  // --mpi: render across the ranks of an MPI job (TRITRACE_WITH_MPI)
};

// Registers the subcommand and its flags on `app`; values land in `args` when parsed.
CLI::App* add_render_command(CLI::App& app, RenderArgs& args);

// Runs a parsed render; throws tritrace::Error on bad values or I/O failures. Returns the exit
// code.
int run_render(const RenderArgs& args);

// `render --mpi`, in mpi_render.cpp when built with TRITRACE_WITH_MPI (else it throws a usage error
// saying so).
int run_render_mpi(const RenderArgs& args);

}  // namespace tritrace::cli
