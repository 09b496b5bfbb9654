// tritrace-view's window: loads the scene and builds the accel as `tritrace render` does, then
// renders with the same Renderer whenever the view changes, uploads the image as a texture, and
// handles the lab's keys.
#pragma once

#include <string>

#include "flags/scene_flags.h"

namespace tritrace::view {

struct ViewerOptions {
  JobSettings scene;
  bool quiet = false;        // no "Render time" lines
  bool print_state = false;  // print the view as a `tritrace render` command when it comes to rest
  int benchmark_frames = 0;  // > 0: render this many frames turning, print medians, exit
  // The path tracer's refinement at rest stops this many seconds after the view came to rest
  // (the checked text of --time-limit; empty: no limit). scene.noise_threshold is the viewer's
  // --noise-threshold, and scene.spp the most samples at rest.
  std::string time_limit;
  bool denoise = false;  // --denoise: start with the denoiser on (as if N were pressed)
};

// The line printed (after "tritrace-view: ") when there is no display to open a window on.
inline constexpr const char* kNoDisplay =
    "no display available (set DISPLAY or use 'tritrace render')";

// Runs until the window is closed or Esc is pressed; returns the exit code. Throws Error for a
// bad scene, and Error with an empty subject and kNoDisplay as reason when there is no display.
int run_viewer(const ViewerOptions& options);

}  // namespace tritrace::view
