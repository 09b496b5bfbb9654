// tritrace-view's command line: the scene flags of `tritrace render` plus the viewer's own, and
// every error as one line `tritrace-view: <flag or file>: <reason>` with exit code 2 (usage) or 1.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <string>

#include "flags/flag_values.h"
#include "flags/scene_flags.h"
#include "tritrace/error.h"
#include "viewer.h"

namespace {

// CLI11's messages reduced to one line naming the flag, as the tritrace CLI does.
std::string usage_message(const CLI::ParseError& e) {
  return tritrace::cli::one_line_usage_message(e);
}

}  // namespace

// Setting up the parser can only throw std::bad_alloc, for which terminating is the right answer.
// NOLINTNEXTLINE(bugprone-exception-escape)
int main(int argc, char** argv) {
  CLI::App app(
      "tritrace-view: the lab's Cornell box (or any scene tritrace renders) in a window. With the "
      "path tracer the image refines while the view rests, up to the scene's --spp (or until "
      "--time-limit, or with --noise-threshold until every pixel has converged).\n"
      "Keys: Left/Right orbit the camera, Up/Down move it forward/back, W/S A/D Q/E move the "
      "light along +z/-z, -x/+x, up/down, R resets, P saves a screenshot, N denoises the resting "
      "image (path or bdpt), H shows help and statistics, Esc quits.",
      "tritrace-view");
  tritrace::view::ViewerOptions options;
  tritrace::cli::add_scene_flags(app, options.scene);
  app.add_flag("-q,--quiet", options.quiet, "Do not print the 'Render time' lines");
  app.add_flag("--print-state", options.print_state,
               "Print the view as a 'tritrace render' command each time it comes to rest (for "
               "path, at the scene's spp, the image the window converges to)");
  app.add_option("--noise-threshold", options.scene.noise_threshold,
                 "Adaptive sampling (path and bdpt) while the view rests, as 'tritrace render "
                 "--noise-threshold T' (0 < T < 1): every pixel takes a pilot of 64 samples, then "
                 "as many as its neighbours' error asks for; --spp is the most. The image at "
                 "rest is refined uniformly up to 64 spp, then in whole adaptive images of 128, "
                 "256, ... spp, each that of 'tritrace render --noise-threshold T --spp N'")
      ->type_name("T")
      ->check(tritrace::cli::checked(tritrace::setting_check("--noise-threshold")));
  app.add_option("--time-limit", options.time_limit,
                 "Stop refining the image (path or bdpt) this many seconds after the view comes "
                 "to rest (the title then says 'stopped: time limit'); without --spp, refinement "
                 "goes on until the time is up")
      ->type_name("SECONDS")
      ->check(tritrace::cli::checked(tritrace::setting_check("--time-limit")));
  app.add_flag("--denoise", options.denoise,
               "Start with the denoiser on (path or bdpt; N toggles it): the resting image is "
               "shown denoised as 'tritrace render --denoise' denoises it");
  std::string frames;
  app.add_option("--benchmark-frames", frames,
                 "Render N frames turning the camera as if Left were held, print the median "
                 "times per frame and exit")
      ->type_name("N")
      ->check(tritrace::cli::checked(
          [](std::string& s) { return tritrace::check_integer_in(s, 1, 100000); }));

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "tritrace-view: %s\n", usage_message(e).c_str());
    return static_cast<int>(tritrace::ExitCode::kUsage);
  }
  if (!frames.empty()) {
    options.benchmark_frames = static_cast<int>(*tritrace::parse_integer(frames));
  }

  try {
    return tritrace::view::run_viewer(options);
  } catch (const tritrace::Error& e) {
    // An error with no subject (no display) is a sentence of its own.
    std::fprintf(stderr, "tritrace-view: %s\n",
                 e.subject().empty() ? e.reason().c_str() : e.what());
    return static_cast<int>(e.exit_code());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tritrace-view: %s\n", e.what());
    return static_cast<int>(tritrace::ExitCode::kRuntime);
  }
}
