// `tritrace info [FILE]`: loads a scene or mesh file as `render` would and prints what it holds.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace tritrace::cli {

struct InfoArgs {
  std::string file;  // empty: the built-in Cornell box
};

CLI::App* add_info_command(CLI::App& app, InfoArgs& args);

// Throws tritrace::Error when the file cannot be loaded. Returns the exit code.
int run_info(const InfoArgs& args);

}  // namespace tritrace::cli
