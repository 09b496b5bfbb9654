// tritrace's command line: parses the subcommand and turns every error into one line on stderr,
// `tritrace: <file or flag>: <reason>`, with exit code 2 for usage errors and 1 for runtime ones.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "bench_command.h"
#include "build_info.h"
#include "denoise_command.h"
#include "flags/flag_values.h"
#include "info_command.h"
#include "merge_command.h"
#include "render_command.h"
#include "tritrace/error.h"

namespace {

// CLI11's messages, reduced to one line that names the flag first where CLI11 gives one.
std::string usage_message(const CLI::ParseError& e, int argc, char** argv) {
  const std::string msg = e.what();
  if (dynamic_cast<const CLI::RequiredError*>(&e) && msg.find("subcommand") != std::string::npos) {
    if (argc > 1 && argv[1][0] != '-') {
      return std::string(argv[1]) +
             ": unknown command (use 'tritrace render', 'tritrace view', 'tritrace info', "
             "'tritrace merge', 'tritrace denoise' or 'tritrace bench'; see --help)";
    }
    return "missing command: use 'tritrace render', 'tritrace view', 'tritrace info', "
           "'tritrace merge', 'tritrace denoise' or 'tritrace bench' (see --help)";
  }
  return tritrace::cli::one_line_usage_message(e);
}

// `tritrace view ARGS` runs tritrace-view ARGS, the executable built next to this one, so that
// the CLI itself links no SDL. Returns only when it cannot be started.
int exec_viewer(int argc, char** argv) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  std::string viewer = (self.parent_path() / "tritrace-view").string();
  std::vector<char*> args{viewer.data()};
  for (int i = 2; i < argc; ++i) args.push_back(argv[i]);
  args.push_back(nullptr);
  if (!ec) ::execv(viewer.c_str(), args.data());
  std::fprintf(stderr, "tritrace: %s: cannot run the viewer: %s\n", viewer.c_str(),
               std::strerror(ec ? ec.value() : errno));
  return static_cast<int>(tritrace::ExitCode::kRuntime);
}

}  // namespace

// Setting up the parser can only throw std::bad_alloc, for which terminating is the right answer;
// everything after it runs inside the try blocks below.
// NOLINTNEXTLINE(bugprone-exception-escape)
int main(int argc, char** argv) {
  if (argc > 1 && std::strcmp(argv[1], "view") == 0) return exec_viewer(argc, argv);

  CLI::App app("tritrace: a fast ray tracer for triangle scenes", "tritrace");
  app.require_subcommand(1);
  app.set_version_flag(
      "--version", [] { return tritrace::cli::version_text(); },
      "Print the version, commit, compiler, SIMD width and optional parts, and exit");
  tritrace::cli::RenderArgs render_args;
  CLI::App* render = tritrace::cli::add_render_command(app, render_args);
  // Listed for --help only: `view` is handed to tritrace-view above, before any parsing.
  app.add_subcommand("view",
                     "Open the interactive viewer, tritrace-view (the same scene flags as render; "
                     "see tritrace view --help)")
      ->prefix_command()
      ->allow_extras();
  tritrace::cli::BenchArgs bench_args;
  CLI::App* bench = tritrace::cli::add_bench_command(app, bench_args);
  tritrace::cli::InfoArgs info_args;
  CLI::App* info = tritrace::cli::add_info_command(app, info_args);
  tritrace::cli::MergeArgs merge_args;
  CLI::App* merge = tritrace::cli::add_merge_command(app, merge_args);
  tritrace::cli::DenoiseArgs denoise_args;
  CLI::App* denoise = tritrace::cli::add_denoise_command(app, denoise_args);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "tritrace: %s\n", usage_message(e, argc, argv).c_str());
    return static_cast<int>(tritrace::ExitCode::kUsage);
  }

  try {
    if (render->parsed()) return tritrace::cli::run_render(render_args);
    if (bench->parsed()) return tritrace::cli::run_bench(bench_args);
    if (info->parsed()) return tritrace::cli::run_info(info_args);
    if (merge->parsed()) return tritrace::cli::run_merge(merge_args);
    if (denoise->parsed()) return tritrace::cli::run_denoise(denoise_args);
  } catch (const tritrace::Error& e) {
    std::fprintf(stderr, "tritrace: %s\n", e.what());
    return static_cast<int>(e.exit_code());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tritrace: %s\n", e.what());
    return static_cast<int>(tritrace::ExitCode::kRuntime);
  }
  return 0;
}
