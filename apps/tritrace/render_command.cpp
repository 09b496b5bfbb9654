// The render subcommand: flags, validation before any work, load, render, atomic write, one
// summary line.
#include "render_command.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string_view>

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
    throw Error(
        "--output",
        "'" + output + "' has an unknown extension (use " + std::string(kImageExtensions) + ")",
        ExitCode::kUsage);
  }
}

constexpr std::string_view kAovNames = "albedo, normal, depth";

// "albedo,normal,depth" or any subset, in any order; a name given twice counts once. nullopt
// with the reason in `why` for an empty list, an empty name or an unknown one.
std::optional<AovSet> parse_aovs(const std::string& text, std::string* why) {
  AovSet set;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    const std::string name =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (name == "albedo") {
      set.albedo = true;
    } else if (name == "normal") {
      set.normal = true;
    } else if (name == "depth") {
      set.depth = true;
    } else {
      *why = (name.empty() ? std::string("empty AOV name") : "unknown AOV '" + name + "'") +
             " in '" + text + "' (use a comma-separated list of " + std::string(kAovNames) + ")";
      return std::nullopt;
    }
    if (comma == std::string::npos) return set;
    start = comma + 1;
  }
}

// The checks between --aovs, --exr-half, --exposure and the output's format, once the output's
// name is known (from -o before loading, from the scene file after).
void check_output_options(const RenderArgs& args, const std::string& output) {
  const ImageFormat format = *image_format_for(output);
  if (!args.aovs.empty() && format != ImageFormat::kExr) {
    throw Error("--aovs", "needs an .exr output, got '" + output + "'", ExitCode::kUsage);
  }
  if (args.exr_half && format != ImageFormat::kExr) {
    throw Error("--exr-half", "needs an .exr output, got '" + output + "'", ExitCode::kUsage);
  }
  // Exposure is a display choice: float files keep the radiance the renderer computed, and a
  // viewer or compositor exposes them however it likes. Ignoring the flag silently would hide a
  // mistake, so it is refused.
  if (!args.exposure.empty() && is_float_format(format)) {
    throw Error("--exposure",
                "applies to 8-bit outputs (.png, .ppm); .pfm and .exr store the radiance "
                "unscaled, got '" +
                    output + "'",
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
                  "Output image: .png, .ppm (8-bit), .pfm or .exr (float, linear radiance); "
                  "default: the scene's output, else FILE's name with .png, else cornell.png")
      ->type_name("PATH")
      ->each([&args](const std::string&) { args.output_given = true; });
  sub->add_option("--aovs", args.aovs,
                  "Extra EXR layers of the first hit, comma-separated: albedo (albedo.R/G/B), "
                  "normal (normal.X/Y/Z, world space, facing the camera), depth (Z, distance "
                  "along the camera ray; 0 where nothing is hit); needs an .exr output")
      ->type_name("LIST")
      ->check(checked([](std::string& s) {
        std::string why;
        return parse_aovs(s, &why) ? std::string() : why;
      }));
  sub->add_flag("--exr-half", args.exr_half,
                "Store the EXR's colour channels as 16-bit half floats instead of 32-bit floats "
                "(depth stays 32-bit); needs an .exr output");
  sub->add_option("--exposure", args.exposure,
                  "Scale path images by 2^STOPS before the sRGB curve of .png and .ppm outputs "
                  "(default 0); float outputs store the radiance unscaled")
      ->type_name("STOPS")
      ->check(checked([](std::string& s) {
        return parse_float(s) ? std::string() : "must be a finite number, got '" + s + "'";
      }));
  sub->add_flag("-q,--quiet", args.quiet, "Print nothing on success: no summary, no progress bar");
  return sub;
}

int run_render(const RenderArgs& args) {
  // Flag values are checked before anything is loaded or rendered, so a bad output path costs no
  // time and leaves no file.
  if (args.output_given) {
    check_output_extension(args.output);
    check_output_options(args, args.output);
    check_writable_path(args.output);
  } else if (args.scene.file.empty()) {
    check_output_options(args, "cornell.png");
    check_writable_path("cornell.png");
  }

  const SceneOverrides overrides = scene_overrides(args.scene);
  const AccelKind accel_kind = cli::accel_kind(args.scene);
  const Kernel kernel = kernel_choice(args.scene);
  RenderOptions render_options;
  render_options.threads = thread_count(args.scene);

  const bool terminal = !args.quiet && ::isatty(STDERR_FILENO);
  PhaseLine loading(
      stderr, terminal,
      args.scene.file.empty()
          ? "making " + (args.scene.scene.empty() ? std::string("cornell") : args.scene.scene)
          : "loading " + args.scene.file);
  const LoadedScene loaded = load_scene_from(args.scene, overrides);
  loading.done();
  const std::string output =
      args.output_given ? args.output : default_output(args.scene.file, loaded);
  if (!args.output_given) {
    check_output_options(args, output);
    check_writable_path(output);
  }

  const size_t dropped = loaded.stats.dropped_degenerate + loaded.stats.dropped_non_finite;
  if (dropped > 0 && !args.quiet) {
    std::fprintf(
        stderr, "tritrace: %s: warning: dropped %zu degenerate and %zu non-finite triangles\n",
        args.scene.file.c_str(), loaded.stats.dropped_degenerate, loaded.stats.dropped_non_finite);
  }

  const Scene& scene = loaded.scene;
  const IntegratorSpec spec = integrator_spec(args.scene, loaded);
  const bool path = spec.kind == IntegratorSpec::Kind::kPath;
  if (!path && !args.exposure.empty()) {
    throw Error("--exposure",
                "applies to path images; the lab integrator keeps the lab's clamp without gamma",
                ExitCode::kUsage);
  }
  render_options.spp = spec.spp;
  render_options.seed = spec.seed;
  render_options.sampler = spec.sampler;
  render_options.filter = filter_choice(args.scene);
  PhaseLine building(stderr, terminal,
                     "building " + std::string(accel_name(accel_kind)) + " over " +
                         std::to_string(scene.mesh.size()) + " triangles");
  const std::unique_ptr<Accel> accel = make_accel(accel_kind, scene.mesh, kernel);
  building.done();
  const std::unique_ptr<Integrator> integrator = make_integrator(spec, scene);
  ProgressBar bar(stderr);
  if (terminal) render_options.progress = &bar;
  if (path) {
    bar.show_paths(static_cast<uint64_t>(scene.camera.width()) * scene.camera.height() * spec.spp,
                   spec.spp);
  }
  RenderStats stats;
  std::string aov_error;
  const AovSet aovs = args.aovs.empty() ? AovSet{} : *parse_aovs(args.aovs, &aov_error);
  Image image;
  AovImages aov_images;  // empty images for the AOVs not asked for
  if (aovs.any()) {
    Film film(scene.camera.width(), scene.camera.height(), aovs);
    render_to_film(scene, *accel, *integrator, film, render_options, &stats);
    image = film.resolve();
    aov_images = {film.resolve_albedo(), film.resolve_normal(), film.resolve_depth()};
  } else {
    image = render(scene, *accel, *integrator, render_options, &stats);
  }
  bar.finish();
  if (*image_format_for(output) == ImageFormat::kExr) {
    write_exr(image, output, aov_images,
              args.exr_half ? ExrPixelType::kHalf : ExrPixelType::kFloat);
  } else {
    const float stops = args.exposure.empty() ? 0.0f : *parse_float(args.exposure);
    write_image(image, output, path ? ImageEncoding::srgb(stops) : ImageEncoding::lab());
  }

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
