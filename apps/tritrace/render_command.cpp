// The render subcommand: flags, validation before any work, load, render, atomic write, one
// summary line.
#include "render_command.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "flags/flag_values.h"
#include "progress.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/image/image_io.h"
#include "tritrace/render/make_integrator.h"
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
      "lab's shading or the path tracer");
  add_scene_flags(*sub, args.scene);
  sub->add_option("-o,--output", args.output,
                  "Output image: .png, .ppm (8-bit) or .pfm (float); default: the scene's "
                  "output, else FILE's name with .png, else cornell.png")
      ->type_name("PATH")
      ->each([&args](const std::string&) { args.output_given = true; });
  sub->add_flag("-q,--quiet", args.quiet, "Print nothing on success: no summary, no progress bar");
  return sub;
}

int run_render(const RenderArgs& args) {
  // Flag values are checked before anything is loaded or rendered, so a bad output path costs no
  // time and leaves no file.
  if (args.output_given) {
    check_output_extension(args.output);
    check_writable_path(args.output);
  } else if (args.scene.file.empty()) {
    check_writable_path("cornell.png");
  }

  const SceneOverrides overrides = scene_overrides(args.scene);
  const AccelKind accel_kind = cli::accel_kind(args.scene);
  const Kernel kernel = kernel_choice(args.scene);
  RenderOptions render_options;
  render_options.threads = thread_count(args.scene);

  const LoadedScene loaded = load_scene_from(args.scene, overrides);
  const std::string output =
      args.output_given ? args.output : default_output(args.scene.file, loaded);
  if (!args.output_given) check_writable_path(output);

  const size_t dropped = loaded.stats.dropped_degenerate + loaded.stats.dropped_non_finite;
  if (dropped > 0 && !args.quiet) {
    std::fprintf(
        stderr, "tritrace: %s: warning: dropped %zu degenerate and %zu non-finite triangles\n",
        args.scene.file.c_str(), loaded.stats.dropped_degenerate, loaded.stats.dropped_non_finite);
  }

  const Scene& scene = loaded.scene;
  const IntegratorSpec spec = integrator_spec(args.scene, loaded);
  const bool path = spec.kind == IntegratorSpec::Kind::kPath;
  render_options.spp = spec.spp;
  render_options.seed = spec.seed;
  render_options.filter = filter_choice(args.scene);
  const std::unique_ptr<Accel> accel = make_accel(accel_kind, scene.mesh, kernel);
  const std::unique_ptr<Integrator> integrator = make_integrator(spec, scene);
  ProgressBar bar(stderr);
  if (!args.quiet && ::isatty(STDERR_FILENO)) render_options.progress = &bar;
  RenderStats stats;
  const Image image = render(scene, *accel, *integrator, render_options, &stats);
  bar.finish();
  write_image(image, output, path ? ImageEncoding::srgb() : ImageEncoding::lab());

  if (!args.quiet) {
    if (path) {
      std::printf(
          "rendered %dx%d, %u spp in %.1f ms (%.3g Mpaths/s, %.3g Mrays/s, %d thread%s) to %s\n",
          image.width(), image.height(), stats.spp, stats.milliseconds,
          stats.samples_per_second() * 1e-6, stats.mrays_per_second(), stats.threads,
          stats.threads == 1 ? "" : "s", output.c_str());
    } else {
      std::printf("rendered %dx%d in %.1f ms (%.3g Mrays/s, %d thread%s) to %s\n", image.width(),
                  image.height(), stats.milliseconds, stats.mrays_per_second(), stats.threads,
                  stats.threads == 1 ? "" : "s", output.c_str());
    }
  }
  return 0;
}

}  // namespace tritrace::cli
