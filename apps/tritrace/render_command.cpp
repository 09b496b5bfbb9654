// The render subcommand: flags, the output checked before any work, then the render job (load,
// build, render, atomic write) with a phase line, a progress bar and one summary line.
#include "render_command.h"

#include <unistd.h>

#include <cstdio>
#include <utility>

#include "flags/flag_values.h"
#include "progress.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/job/render_job.h"
#include "tritrace/scene/io/load_progress.h"

namespace tritrace::cli {

CLI::App* add_render_command(CLI::App& app, RenderArgs& args) {
  CLI::App* sub = app.add_subcommand("render",
                                     "Render a scene (.json or .pbrt), a mesh file, or with no "
                                     "FILE the built-in Cornell box, with the "
                                     "lab's shading or the path tracer");
  add_scene_flags(*sub, args.job);
  sub->add_option("-o,--output", args.job.output,
                  "Output image: .png, .ppm (8-bit), .pfm or .exr (float, linear radiance); "
                  "default: the scene's output, else FILE's name with .png, else cornell.png")
      ->type_name("PATH")
      ->each([&args](const std::string&) { args.job.output_given = true; });
  sub->add_option("--aovs", args.job.aovs,
                  "Extra EXR layers for denoisers, comma-separated: albedo (albedo.R/G/B) and "
                  "normal (normal.X/Y/Z, world space, shading normal facing the ray) of the first "
                  "non-specular hit (path: through perfect mirrors and smooth glass, albedo times "
                  "their tint), depth (Z, distance along the camera ray to the first hit; 0 where "
                  "nothing is hit), variance (variance.R/G/B, the estimated variance of each "
                  "pixel's mean, from the halves of its samples split by sample index parity), "
                  "spp (the samples each pixel took, one channel spp); needs an .exr output")
      ->type_name("LIST")
      ->check(checked(setting_check("--aovs")));
  sub->add_flag("--exr-half", args.job.exr_half,
                "Store the EXR's colour channels as 16-bit half floats instead of 32-bit floats "
                "(depth and variance stay 32-bit); needs an .exr output");
  sub->add_option("--exposure", args.job.exposure,
                  "Scale path images by 2^STOPS before the sRGB curve of .png and .ppm outputs "
                  "(default 0); float outputs store the radiance unscaled")
      ->type_name("STOPS")
      ->check(checked(setting_check("--exposure")));
  sub->add_option("--spp-range", args.job.spp_range,
                  "Render only samples [A, B) of every pixel of the path tracer's spp and write a "
                  "partial film (.exr) for `tritrace merge`; A and B multiples of 8 (B may be "
                  "the spp)")
      ->type_name("A:B");
  sub->add_option("--tile", args.job.tile,
                  "Render only the I-th of N tile parts (16 x 16 tiles t with t % N == I, "
                  "interleaved to balance the work) and write a partial film (.exr) for "
                  "`tritrace merge`")
      ->type_name("I/N");
  sub->add_option("--time-limit", args.job.time_limit,
                  "Render the samples (path or bdpt) in passes until SECONDS have passed (the "
                  "first pass of 8 samples always; --spp, if given, is the most a pixel takes), "
                  "or with --noise-threshold until every pixel has stopped, whichever comes "
                  "first; then write the image and say how many spp it reached and why it "
                  "stopped; the image is the one --spp of that many gives")
      ->type_name("SECONDS")
      ->check(checked(setting_check("--time-limit")));
  sub->add_flag("--denoise", args.job.denoise,
                "Denoise the image (path or bdpt) with the built-in feature-guided denoiser "
                "(docs/DENOISING.md): the film also keeps albedo, normal, depth and the variance "
                "of each pixel from its two halves of samples; --aovs still chooses which of "
                "them are written");
  sub->add_option("--noise-threshold", args.job.noise_threshold,
                  "Adaptive sampling (path; bdpt in passes over the whole image, docs/BDPT.md): "
                  "every pixel takes 64 samples, then as "
                  "many as its neighbours' error says it needs, up to --spp: the neighbours (the "
                  "5 x 5 pixels around it in its 16 x 16 tile, itself left out) give their "
                  "standard error of the mean luminance L over sqrt(L) (sqrt(0.1) below L = 0.1), "
                  "a relative error at L = 1, after 64 samples; with e their root mean square, "
                  "the pixel takes 64 e / T samples rounded up to 64, 128, 256, ... (64 when e < "
                  "T), in proportion to the noise around it. The decision never reads the pixel's "
                  "own samples, so the image is "
                  "unbiased, and reads only its tile, so it is the same for any thread count and "
                  "tile size, and --tile parts and --mpi still merge exactly; not with "
                  "--spp-range. With --time-limit, passes until the time is up or every pixel has "
                  "stopped. "
                  "--aovs spp writes how many samples each pixel took")
      ->type_name("T")
      ->check(checked(setting_check("--noise-threshold")));
  sub->add_flag("--mpi", args.mpi,
                "Render across the ranks of an MPI job (mpirun -np N tritrace render --mpi ...): "
                "rank 0 hands out tiles x sample blocks, gathers and writes the image once");
  sub->add_flag("-q,--quiet", args.quiet, "Print nothing on success: no summary, no progress bar");
  return sub;
}

namespace {

// The summary's words on adaptive sampling: " at most (mean 37.2 spp, noise threshold 0.01)", or
// nothing when it is off.
std::string adaptive_text(const JobSettings& settings, const RenderStats& stats) {
  if (settings.noise_threshold.empty()) return "";
  char text[128];
  std::snprintf(text, sizeof text, " at most (mean %.1f spp, noise threshold %s)", stats.mean_spp(),
                settings.noise_threshold.c_str());
  return text;
}

}  // namespace

int run_render(const RenderArgs& args) {
  const JobSettings& settings = args.job;
  const bool partial = !settings.spp_range.empty() || !settings.tile.empty();
  if (args.mpi) {
    if (partial) {
      throw Error("--mpi", "renders the whole image; it does not take --spp-range or --tile",
                  ExitCode::kUsage);
    }
    if (!settings.time_limit.empty()) {
      throw Error("--time-limit",
                  "renders passes on one machine until the time is up; --mpi splits a fixed "
                  "number of samples among its ranks",
                  ExitCode::kUsage);
    }
    return run_render_mpi(args);
  }
  // The output is checked before anything is loaded or rendered, so a bad output path costs no
  // time and leaves no file; when it comes from the scene file, once the file is loaded.
  if (partial || settings.output_given || settings.file.empty()) {
    const std::string output = settings.output_given ? settings.output : "cornell.png";
    RenderJob::check_output(settings, output);
    check_writable_path(output);
  }

  const bool terminal = !args.quiet && ::isatty(STDERR_FILENO);
  LoadProgress load_progress;
  PhaseLine loading(stderr, terminal, loading_phase(settings), &load_progress);
  LoadedScene loaded = [&] {
    const LoadProgressScope report(&load_progress);
    return load_job_scene(settings);
  }();
  loading.done();
  const size_t dropped = loaded.stats.dropped_degenerate + loaded.stats.dropped_non_finite;
  if (dropped > 0 && !args.quiet) {
    std::fprintf(
        stderr, "tritrace: %s: warning: dropped %zu degenerate and %zu non-finite triangles\n",
        settings.file.c_str(), loaded.stats.dropped_degenerate, loaded.stats.dropped_non_finite);
  }
  if (!args.quiet) {
    for (const std::string& w : loaded.warnings) std::fprintf(stderr, "tritrace: %s\n", w.c_str());
  }

  RenderJob job(settings, std::move(loaded));
  const std::string& output = job.output();
  if (!settings.output_given) {
    RenderJob::check_output(settings, output);
    check_writable_path(output);
  }
  const Scene& scene = job.scene();
  PhaseLine building(stderr, terminal, building_phase(job.accel_kind(), scene.drawn_triangles()));
  job.prepare();
  building.done();

  ProgressBar bar(stderr);
  const bool timed = !settings.time_limit.empty();  // passes: no bar (their count is not known)
  if (terminal && !timed) job.set_progress(&bar);
  const uint32_t spp = job.spec().spp;
  if (job.path()) {
    // A part's share of the paths (tile parts hold about 1/N of the pixels each).
    bar.show_paths(static_cast<uint64_t>(job.width()) * job.height() * job.options().spp /
                       static_cast<uint64_t>(job.part().tiles),
                   job.options().spp);
  }
  RenderStats stats;
  if (partial) {
    Film film = job.make_film();
    job.render_to_film(film, &stats);
    bar.finish();
    job.write_part(film, output);
    if (!args.quiet) {
      std::printf("rendered %s of %dx%d, %u spp%s in %.1f ms (%.3g Mrays/s, %d thread%s) to %s\n",
                  job.part().describe().c_str(), job.width(), job.height(), spp,
                  adaptive_text(settings, stats).c_str(), stats.milliseconds,
                  stats.mrays_per_second(), stats.threads, stats.threads == 1 ? "" : "s",
                  output.c_str());
      if (const std::string lp = job.light_paths_summary(); !lp.empty()) {
        std::printf("%s\n", lp.c_str());
      }
    }
    return 0;
  }
  const RenderedImage rendered = job.render(&stats);
  bar.finish();
  job.write(rendered, output);

  if (!args.quiet) {
    const Image& image = rendered.image;
    if (job.path()) {
      const RenderStop stop = rendered.record.stop;
      const std::string limit =
          !timed ? std::string()
                 : " (time limit " + settings.time_limit + " s" +
                       (stop == RenderStop::kTimeLimit   ? ": stopped by the time limit)"
                        : stop == RenderStop::kConverged ? ": every pixel converged first)"
                                                         : ": --spp reached first)");
      std::printf(
          "rendered %dx%d, %u spp%s in %.1f ms%s (%.3g Mpaths/s, %.3g Mrays/s, %d thread%s) to "
          "%s\n",
          image.width(), image.height(), stats.spp, adaptive_text(settings, stats).c_str(),
          stats.milliseconds, limit.c_str(), stats.samples_per_second() * 1e-6,
          stats.mrays_per_second(), stats.threads, stats.threads == 1 ? "" : "s", output.c_str());
      if (settings.denoise) std::printf("denoised in %.1f ms\n", rendered.denoise_ms);
      if (const std::string lp = job.light_paths_summary(); !lp.empty()) {
        std::printf("%s\n", lp.c_str());
      }
    } else {
      std::printf("rendered %dx%d in %.1f ms (%.3g Mrays/s, %d thread%s) to %s\n", image.width(),
                  image.height(), stats.milliseconds, stats.mrays_per_second(), stats.threads,
                  stats.threads == 1 ? "" : "s", output.c_str());
    }
  }
  return 0;
}

}  // namespace tritrace::cli
