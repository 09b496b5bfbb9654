// The render subcommand: flags, validation before any work, load, render, atomic write, one
// summary line.
#include "render_command.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string_view>
#include <utility>

#include "flags/flag_values.h"
#include "progress.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/image/image_io.h"
#include "tritrace/render/make_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/io/load_progress.h"
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

// "A:B" or "I/N": two unsigned integers; nullopt when the text is not of that form.
std::optional<std::pair<long long, long long>> parse_two(const std::string& text, char sep) {
  const size_t at = text.find(sep);
  if (at == std::string::npos) return std::nullopt;
  const std::optional<long long> a = parse_integer(text.substr(0, at));
  const std::optional<long long> b = parse_integer(text.substr(at + 1));
  if (!a || !b || *a < 0 || *b < 0) return std::nullopt;
  return std::pair{*a, *b};
}

// The part --spp-range and --tile ask for, checked against the render's spp and image size.
PartRange part_range(const RenderArgs& args, bool path, uint32_t spp, int width, int height) {
  PartRange range{0, path ? spp : 1, 0, 1};
  if (!args.spp_range.empty()) {
    if (!path) {
      throw Error("--spp-range",
                  "the lab integrator takes one sample per pixel; split its image with --tile",
                  ExitCode::kUsage);
    }
    const auto ab = parse_two(args.spp_range, ':');
    if (!ab) {
      throw Error("--spp-range", "expected A:B (two whole numbers), got '" + args.spp_range + "'",
                  ExitCode::kUsage);
    }
    const auto [a, b] = *ab;
    if (a >= b || b > static_cast<long long>(spp)) {
      throw Error("--spp-range",
                  args.spp_range + " is not a range A < B <= " + std::to_string(spp) + " (the spp)",
                  ExitCode::kUsage);
    }
    if (a % kSampleBlock != 0 || (b % kSampleBlock != 0 && b != static_cast<long long>(spp))) {
      throw Error("--spp-range",
                  args.spp_range + " is not split at multiples of " + std::to_string(kSampleBlock) +
                      ": parts merge bit for bit only at whole blocks of 8 samples (B may also be "
                      "the spp, " +
                      std::to_string(spp) + ")",
                  ExitCode::kUsage);
    }
    range.first = static_cast<uint32_t>(a);
    range.end = static_cast<uint32_t>(b);
  }
  if (!args.tile.empty()) {
    const auto in = parse_two(args.tile, '/');
    if (!in || in->second < 1 || in->first >= in->second) {
      throw Error("--tile", "expected I/N with 0 <= I < N, got '" + args.tile + "'",
                  ExitCode::kUsage);
    }
    const long long tiles = static_cast<long long>((width + kPartTileSize - 1) / kPartTileSize) *
                            ((height + kPartTileSize - 1) / kPartTileSize);
    if (in->second > tiles) {
      throw Error("--tile",
                  std::to_string(in->second) + " parts, but the " + std::to_string(width) + "x" +
                      std::to_string(height) + " image has only " + std::to_string(tiles) +
                      " tiles of " + std::to_string(kPartTileSize) + " x " +
                      std::to_string(kPartTileSize),
                  ExitCode::kUsage);
    }
    range.tile = static_cast<int>(in->first);
    range.tiles = static_cast<int>(in->second);
  }
  return range;
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
  sub->add_option("--spp-range", args.spp_range,
                  "Render only samples [A, B) of every pixel of the path tracer's spp and write a "
                  "partial film (.exr) for `tritrace merge`; A and B multiples of 8 (B may be "
                  "the spp)")
      ->type_name("A:B");
  sub->add_option("--tile", args.tile,
                  "Render only the I-th of N tile parts (16 x 16 tiles t with t % N == I, "
                  "interleaved to balance the work) and write a partial film (.exr) for "
                  "`tritrace merge`")
      ->type_name("I/N");
  sub->add_flag("--mpi", args.mpi,
                "Render across the ranks of an MPI job (mpirun -np N tritrace render --mpi ...): "
                "rank 0 hands out tiles x sample blocks, gathers and writes the image once");
  sub->add_flag("-q,--quiet", args.quiet, "Print nothing on success: no summary, no progress bar");
  return sub;
}

int run_render(const RenderArgs& args) {
  const bool partial = !args.spp_range.empty() || !args.tile.empty();
  if (args.mpi) {
    if (partial) {
      throw Error("--mpi", "renders the whole image; it does not take --spp-range or --tile",
                  ExitCode::kUsage);
    }
    return run_render_mpi(args);
  }
  if (partial) {
    const char* flag = !args.spp_range.empty() ? "--spp-range" : "--tile";
    if (!args.output_given || *image_format_for(args.output) != ImageFormat::kExr) {
      throw Error(flag, "writes a partial film, an OpenEXR file: give -o PART.exr",
                  ExitCode::kUsage);
    }
    if (args.exr_half) {
      throw Error("--exr-half", "partial films keep 32-bit float sums (merging needs every bit)",
                  ExitCode::kUsage);
    }
  }
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
  LoadProgress load_progress;
  PhaseLine loading(stderr, terminal, loading_phase(args.scene), &load_progress);
  const LoadedScene loaded = [&] {
    const LoadProgressScope report(&load_progress);
    return load_scene_from(args.scene, overrides);
  }();
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
  PhaseLine building(stderr, terminal, building_phase(accel_kind, scene.drawn_triangles()));
  const std::unique_ptr<Accel> accel =
      make_accel(accel_kind, scene, kernel, nullptr,
                 bvh_build_choice(args.scene, scene.stored_triangles(), spec, scene.camera));
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
  if (partial) {
    const PartRange range =
        part_range(args, path, spec.spp, scene.camera.width(), scene.camera.height());
    render_options.first_sample = range.first;
    render_options.spp = range.end - range.first;
    render_options.tile_part = range.tile;
    render_options.tile_parts = range.tiles;
    RenderOptions whole = render_options;
    whole.spp = spec.spp;
    const PartInfo info{
        render_identity(scene, spec, whole, accel_name(accel_kind), kernel_name(kernel), aovs),
        range};
    if (path) {
      // The part's share of the paths (tile parts hold about 1/N of the pixels each).
      bar.show_paths(static_cast<uint64_t>(scene.camera.width()) * scene.camera.height() *
                         render_options.spp / static_cast<uint64_t>(range.tiles),
                     render_options.spp);
    }
    Film film(scene.camera.width(), scene.camera.height(), aovs);
    render_to_film(scene, *accel, *integrator, film, render_options, &stats);
    bar.finish();
    write_file_atomic(output, encode_partial_film(pack_part(film, range.tile, range.tiles), info));
    if (!args.quiet) {
      std::printf("rendered %s of %dx%d, %u spp in %.1f ms (%.3g Mrays/s, %d thread%s) to %s\n",
                  range.describe().c_str(), scene.camera.width(), scene.camera.height(), spec.spp,
                  stats.milliseconds, stats.mrays_per_second(), stats.threads,
                  stats.threads == 1 ? "" : "s", output.c_str());
    }
    return 0;
  }
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
