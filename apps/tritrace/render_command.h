// `tritrace render [FILE]`: renders a built-in scene, a JSON scene or a mesh file with the lab
// integrator or the path tracer to an image file (8-bit, PFM, or EXR with AOV layers).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "flags/scene_flags.h"

namespace tritrace::cli {

struct RenderArgs {
  // FILE, the scene and its view (the flags shared with tritrace-view), the output and its layers,
  // the part: everything the render job reads.
  JobSettings job;
  bool quiet = false;
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
