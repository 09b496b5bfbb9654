// The render subcommand: flags, validation before any work, render, atomic write, one summary line.
#include "render_command.h"

#include <cstdio>

#include "flag_values.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/image/image_io.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/procedural.h"

namespace tritrace::cli {
namespace {

constexpr long long kMaxImageSide = 16384;
constexpr long long kMaxThreads = 1024;

CLI::Validator validator(std::string description, std::function<std::string(std::string&)> fn) {
  return CLI::Validator(std::move(fn), std::move(description), "");
}

std::string accel_list() {
  std::string names;
  for (AccelKind k : available_accels()) {
    if (!names.empty()) names += "|";
    names += accel_name(k);
  }
  return names;
}

std::string kernel_list() {
  std::string names;
  for (Kernel k : kAllKernels) {
    if (!names.empty()) names += "|";
    names += kernel_name(k);
  }
  return names;
}

}  // namespace

CLI::App* add_render_command(CLI::App& app, RenderArgs& args) {
  CLI::App* sub = app.add_subcommand(
      "render", "Render a built-in scene with the lab's camera, light and shading");
  sub->add_option("-o,--output", args.output, "Output image: .png, .ppm (8-bit) or .pfm (float)")
      ->type_name("PATH")
      ->capture_default_str();
  auto side = validator("", [](std::string& s) { return check_integer_in(s, 1, kMaxImageSide); });
  sub->add_option("--width", args.width, "Image width in pixels, 1 to 16384")
      ->type_name("W")
      ->capture_default_str()
      ->check(side);
  sub->add_option("--height", args.height,
                  "Image height in pixels, 1 to 16384 (also the focal length)")
      ->type_name("H")
      ->capture_default_str()
      ->check(side);
  sub->add_option("--scene", args.scene,
                  std::string("Built-in scene: ") + std::string(kBuiltinSceneHelp))
      ->type_name("NAME")
      ->capture_default_str()
      ->check(validator("", [](std::string& s) {
        return s == "cornell" || parse_terrain_triangles(s)
                   ? std::string()
                   : "unknown scene '" + s + "' (use " + std::string(kBuiltinSceneHelp) + ")";
      }));
  sub->add_option("--accel", args.accel,
                  "Acceleration structure: " + accel_list() +
                      " (brute is the lab's loop over all triangles)")
      ->type_name("NAME")
      ->capture_default_str()
      ->check(validator("", [](std::string& s) {
        const std::optional<AccelKind> kind = parse_accel(s);
        if (kind && accel_available(*kind)) return std::string();
        if (kind) return "'" + s + "' is not built in (this build has " + accel_list() + ")";
        return "unknown acceleration structure '" + s + "' (use " + accel_list() + ")";
      }));
  sub->add_option("--kernel", args.kernel,
                  "Ray/triangle intersection: " + kernel_list() + " (default " +
                      std::string(kernel_name(kDefaultKernel)) + ", the fastest)")
      ->type_name("NAME")
      ->check(validator("", [](std::string& s) {
        return parse_kernel(s) ? std::string()
                               : "unknown kernel '" + s + "' (use " + kernel_list() + ")";
      }));
  sub->add_option("--yaw", args.yaw, "Camera orbit angle about the y axis, radians")
      ->type_name("RAD")
      ->capture_default_str()
      ->check(validator("", [](std::string& s) { return check_finite(s); }));
  sub->add_option("--light", args.light, "Point light position (default 0,-0.5,-0.7)")
      ->type_name("X,Y,Z")
      ->check(validator("", [](std::string& s) { return check_vec3(s); }));
  sub->add_option("--threads", args.threads, "Worker threads (default: all cores)")
      ->type_name("N")
      ->check(validator("", [](std::string& s) { return check_integer_in(s, 1, kMaxThreads); }));
  sub->add_flag("-q,--quiet", args.quiet, "Print nothing on success");
  return sub;
}

int run_render(const RenderArgs& args) {
  // Everything is checked before rendering, so a bad output path costs no render time and leaves
  // no file.
  if (!image_format_for(args.output)) {
    throw Error("--output",
                "'" + args.output + "' has an unknown extension (use .png, .ppm or .pfm)",
                ExitCode::kUsage);
  }
  check_writable_path(args.output);

  CornellOptions scene_options;
  scene_options.width = static_cast<int>(*parse_integer(args.width));
  scene_options.height = static_cast<int>(*parse_integer(args.height));
  scene_options.yaw = *parse_finite(args.yaw);
  if (!args.light.empty()) scene_options.light_position = *parse_vec3(args.light);
  const Kernel kernel = args.kernel.empty() ? kDefaultKernel : *parse_kernel(args.kernel);
  RenderOptions render_options;
  if (!args.threads.empty())
    render_options.threads = static_cast<int>(*parse_integer(args.threads));

  const Scene scene = make_builtin_scene(args.scene, scene_options);
  const std::unique_ptr<Accel> accel = make_accel(*parse_accel(args.accel), scene.mesh, kernel);
  const LabIntegrator integrator;
  RenderStats stats;
  const Image image = render(scene, *accel, integrator, render_options, &stats);
  write_image(image, args.output);

  if (!args.quiet) {
    std::printf("rendered %dx%d in %.1f ms (%.1f Mrays/s, %d thread%s) to %s\n", image.width(),
                image.height(), stats.milliseconds, stats.mrays_per_second(), stats.threads,
                stats.threads == 1 ? "" : "s", args.output.c_str());
  }
  return 0;
}

}  // namespace tritrace::cli
