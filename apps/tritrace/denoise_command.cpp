// The denoise subcommand: checks the output first, reads the input's layers (colour, albedo,
// normal, depth required; variance optional, else estimated from the image), denoises and writes
// the result with the input's AOV layers, atomically.
#include "denoise_command.h"

#include <array>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "flags/flag_values.h"
#include "tritrace/denoise/denoiser.h"
#include "tritrace/error.h"
#include "tritrace/image/image_io.h"
#include "tritrace/job/render_job.h"

namespace tritrace::cli {

CLI::App* add_denoise_command(CLI::App& app, DenoiseArgs& args) {
  CLI::App* sub = app.add_subcommand(
      "denoise",
      "Denoise a rendered EXR: colour R, G, B with the layers albedo.R/G/B, normal.X/Y/Z and Z "
      "(render --aovs albedo,normal,depth) and, if present, variance.R/G/B, the variance of each "
      "pixel's mean; without it the variance is estimated from each pixel's neighbourhood, which "
      "overestimates it at edges");
  sub->add_option("IN", args.input, "Rendered image (.exr) with AOV layers")
      ->required()
      ->type_name("IN.exr");
  sub->add_option("-o,--output", args.output,
                  "Output image: .png, .ppm (8-bit sRGB), .pfm or .exr (float; with the input's "
                  "AOV layers)")
      ->required()
      ->type_name("PATH");
  sub->add_option("--search-radius", args.search_radius,
                  "Neighbourhood radius in pixels (a (2r+1)^2 window); larger smooths more and "
                  "takes longer")
      ->check(CLI::Range(1, 32))
      ->capture_default_str();
  sub->add_option("--exposure", args.exposure,
                  "Scale the image by 2^STOPS before the sRGB curve of .png and .ppm outputs")
      ->type_name("STOPS")
      ->check(checked(setting_check("--exposure")));
  sub->add_flag("-q,--quiet", args.quiet, "Print nothing on success");
  return sub;
}

int run_denoise(const DenoiseArgs& args) {
  const JobSettings settings = image_output_settings(args.output, args.exposure);
  check_exposure(settings, true);
  const auto start = std::chrono::steady_clock::now();

  const std::array<std::array<std::string, 3>, 5> layers = {{
      {"R", "G", "B"},
      {"albedo.R", "albedo.G", "albedo.B"},
      {"normal.X", "normal.Y", "normal.Z"},
      {"Z", "Z", "Z"},
      {"variance.R", "variance.G", "variance.B"},
  }};
  std::map<std::string, std::string> attributes;
  const std::vector<Image> images = read_exr_layers(args.input, layers, &attributes);
  const char* missing[4] = {"colour channels R, G, B", "albedo layer (albedo.R, .G, .B)",
                            "normal layer (normal.X, .Y, .Z)", "depth channel Z"};
  for (int l = 0; l < 4; ++l) {
    if (images[l].pixels().empty()) {
      throw Error(args.input, std::string("has no ") + missing[l] +
                                  " (render with --aovs albedo,normal,depth,variance and -o .exr)");
    }
  }
  const Image& colour = images[0];
  const bool has_variance = !images[4].pixels().empty();
  // With the render's variance layer, the render's own denoising (render --denoise), its
  // overestimate that of the sampler the file records (Sobol when it records none, as tritrace
  // wrote before it recorded the sampler); without, the variance estimated from the image.
  const SamplerKind sampler = recorded_sampler(attributes, args.input);
  const Image variance = has_variance
                             ? smooth_variance(images[4], 2, half_buffer_variance_ratio(sampler))
                             : estimate_variance_spatially(colour, images[1]);
  DenoiseOptions options;
  options.search_radius = args.search_radius;
  RenderedImage rendered{denoise(colour, variance, {images[1], images[2], images[3]}, options),
                         {images[1], images[2], images[3], images[4], Image()}};
  write_render(rendered, args.output, true, settings);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!args.quiet) {
    const std::string from_layer =
        "from its layer, " + std::string(sampler_name(sampler)) + " sampler";
    std::printf("denoised %s (%dx%d, variance %s) in %.1f ms to %s\n", args.input.c_str(),
                colour.width(), colour.height(),
                has_variance ? from_layer.c_str() : "estimated from the image", ms,
                args.output.c_str());
  }
  return 0;
}

}  // namespace tritrace::cli
