// The render subcommand: flags, validation before any work, load, render, atomic write, one
// summary line.
#include "render_command.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "flag_values.h"
#include "progress.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/image/image_io.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/io/scene_loader.h"
#include "tritrace/scene/procedural.h"

namespace tritrace::cli {
namespace {

// The output path when -o is not given: the scene file's own, else the input's name as .png.
std::string default_output(const std::string& file, const LoadedScene& loaded) {
  if (!loaded.output.empty()) return loaded.output;
  if (file.empty()) return "cornell.png";  // the lab's name, whatever the built-in scene
  return std::filesystem::path(file).stem().string() + ".png";
}

void check_output_extension(const std::string& output) {
  if (!image_format_for(output)) {
    throw Error("--output", "'" + output + "' has an unknown extension (use .png, .ppm or .pfm)",
                ExitCode::kUsage);
  }
}

}  // namespace

CLI::App* add_render_command(CLI::App& app, RenderArgs& args) {
  CLI::App* sub = app.add_subcommand(
      "render",
      "Render a scene (.json), a mesh file, or with no FILE the built-in Cornell box, with the "
      "lab's shading");
  sub->add_option("FILE", args.file,
                  "Scene (.json) or mesh file (.obj, .ply, .stl, .gltf, .glb, .fbx, .dae, .3ds, "
                  "... anything assimp reads); default: the built-in Cornell box")
      ->type_name("FILE");
  sub->add_option("-o,--output", args.output,
                  "Output image: .png, .ppm (8-bit) or .pfm (float); default: the scene's "
                  "output, else FILE's name with .png, else cornell.png")
      ->type_name("PATH")
      ->each([&args](const std::string&) { args.output_given = true; });
  auto side = checked([](std::string& s) { return check_integer_in(s, 1, kMaxImageSide); });
  sub->add_option("--width", args.width,
                  "Image width in pixels, 1 to 16384 (default: the scene's, 500)")
      ->type_name("W")
      ->check(side);
  sub->add_option("--height", args.height,
                  "Image height in pixels, 1 to 16384 (default: the scene's, 500); the built-in "
                  "scene's focal length")
      ->type_name("H")
      ->check(side);
  sub->add_option("--scene", args.scene,
                  std::string("Built-in scene when no FILE is given: ") +
                      std::string(kBuiltinSceneHelp) + " (default cornell)")
      ->type_name("NAME")
      ->check(checked(check_builtin_scene));
  sub->add_option("--accel", args.accel,
                  "Acceleration structure: " + accel_list() +
                      " (brute is the lab's loop over all triangles)")
      ->type_name("NAME")
      ->capture_default_str()
      ->check(checked(check_accel));
  sub->add_option("--kernel", args.kernel,
                  "Ray/triangle intersection: " + kernel_list() +
                      " (default: watertight with --accel brute, where it costs 1.06x; "
                      "moller-trumbore with bvh, whose SIMD leaves and packets have only that "
                      "kernel; watertight lets no ray through shared edges)")
      ->type_name("NAME")
      ->check(checked(check_kernel));
  sub->add_option("--yaw", args.yaw,
                  "Orbit the camera about the vertical axis through what it looks at, radians "
                  "(default 0)")
      ->type_name("RAD")
      ->check(checked(check_finite));
  sub->add_option("--light", args.light,
                  "Position of the (first) point light (default: the scene's; the built-in's is "
                  "0,-0.5,-0.7)")
      ->type_name("X,Y,Z")
      ->check(checked(check_vec3));
  sub->add_option("--threads", args.threads, "Worker threads (default: all cores)")
      ->type_name("N")
      ->check(checked([](std::string& s) { return check_integer_in(s, 1, kMaxThreads); }));
  sub->add_flag("-q,--quiet", args.quiet, "Print nothing on success: no summary, no progress bar");
  return sub;
}

int run_render(const RenderArgs& args) {
  // Flag values are checked before anything is loaded or rendered, so a bad output path costs no
  // time and leaves no file.
  if (args.output_given) {
    check_output_extension(args.output);
    check_writable_path(args.output);
  } else if (args.file.empty()) {
    check_writable_path("cornell.png");
  }

  SceneOverrides overrides;
  if (!args.width.empty()) overrides.width = static_cast<int>(*parse_integer(args.width));
  if (!args.height.empty()) overrides.height = static_cast<int>(*parse_integer(args.height));
  if (!args.yaw.empty()) overrides.yaw = *parse_finite(args.yaw);
  if (!args.light.empty()) overrides.light = *parse_vec3(args.light);
  const AccelKind accel_kind = *parse_accel(args.accel);
  const Kernel kernel =
      args.kernel.empty() ? default_kernel_for(accel_kind) : *parse_kernel(args.kernel);
  RenderOptions render_options;
  if (!args.threads.empty())
    render_options.threads = static_cast<int>(*parse_integer(args.threads));

  if (!args.file.empty() && !args.scene.empty()) {
    throw Error("--scene", "give either a FILE or --scene, not both", ExitCode::kUsage);
  }
  const LoadedScene loaded =
      args.file.empty() ? load_builtin_scene(args.scene.empty() ? "cornell" : args.scene, overrides)
                        : load_scene(args.file, overrides);
  const std::string output = args.output_given ? args.output : default_output(args.file, loaded);
  if (!args.output_given) check_writable_path(output);

  const size_t dropped = loaded.stats.dropped_degenerate + loaded.stats.dropped_non_finite;
  if (dropped > 0 && !args.quiet) {
    std::fprintf(
        stderr, "tritrace: %s: warning: dropped %zu degenerate and %zu non-finite triangles\n",
        args.file.c_str(), loaded.stats.dropped_degenerate, loaded.stats.dropped_non_finite);
  }

  const Scene& scene = loaded.scene;
  const std::unique_ptr<Accel> accel = make_accel(accel_kind, scene.mesh, kernel);
  const LabIntegrator integrator;
  ProgressBar bar(stderr);
  if (!args.quiet && ::isatty(STDERR_FILENO)) render_options.progress = &bar;
  RenderStats stats;
  const Image image = render(scene, *accel, integrator, render_options, &stats);
  bar.finish();
  write_image(image, output);

  if (!args.quiet) {
    std::printf("rendered %dx%d in %.1f ms (%.3g Mrays/s, %d thread%s) to %s\n", image.width(),
                image.height(), stats.milliseconds, stats.mrays_per_second(), stats.threads,
                stats.threads == 1 ? "" : "s", output.c_str());
  }
  return 0;
}

}  // namespace tritrace::cli
