// The flags that choose a scene, its view and how to render it (FILE, --scene, --accel, --kernel,
// --width, --height, --bvh-build, --yaw, --distance, --light, --threads, --integrator, --spp,
// --seed, --sampler, --max-depth, --filter), shared by `tritrace render` and `tritrace-view`: each
// flag's value lands in the render job's settings and is checked by the library's rule for it
// (tritrace/job/job_settings.h), so both apps and the Python module accept the same values.
#pragma once

#include <CLI/CLI.hpp>

#include "tritrace/job/job_settings.h"

namespace tritrace::cli {

void add_scene_flags(CLI::App& app, JobSettings& flags);

}  // namespace tritrace::cli
