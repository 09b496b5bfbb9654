// The merge subcommand: checks the output first, then the parts (one render, each sample of each
// tile exactly once), merges them in the block tree's fixed order and writes the image atomically.
#include "merge_command.h"

#include <chrono>
#include <cstdio>

#include "flags/flag_values.h"
#include "tritrace/distributed/film_merger.h"
#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/image/image_io.h"

namespace tritrace::cli {

CLI::App* add_merge_command(CLI::App& app, MergeArgs& args) {
  CLI::App* sub = app.add_subcommand(
      "merge",
      "Merge partial films (render --spp-range / --tile, any order) into the image one process "
      "would render, bit for bit");
  sub->add_option("PART", args.parts, "Partial films (.exr) of one render")
      ->required()
      ->type_name("PART.exr");
  sub->add_option("-o,--output", args.output,
                  "Output image: .png, .ppm (8-bit), .pfm or .exr (float; with the parts' AOVs)")
      ->required()
      ->type_name("PATH");
  sub->add_option("--exposure", args.exposure,
                  "Scale path images by 2^STOPS before the sRGB curve of .png and .ppm outputs")
      ->type_name("STOPS")
      ->check(checked([](std::string& s) {
        return parse_float(s) ? std::string() : "must be a finite number, got '" + s + "'";
      }));
  sub->add_flag("-q,--quiet", args.quiet, "Print nothing on success");
  return sub;
}

int run_merge(const MergeArgs& args) {
  const auto format = image_format_for(args.output);
  if (!format) {
    throw Error("--output",
                "'" + args.output + "' has an unknown extension (use " +
                    std::string(kImageExtensions) + ")",
                ExitCode::kUsage);
  }
  if (!args.exposure.empty() && is_float_format(*format)) {
    throw Error("--exposure", "applies to 8-bit outputs (.png, .ppm), got '" + args.output + "'",
                ExitCode::kUsage);
  }
  check_writable_path(args.output);
  const auto start = std::chrono::steady_clock::now();
  const Film film = merge_parts(args.parts);
  const PartInfo info = read_part_info(args.parts.front());
  const bool path = info.render.integrator == "path";
  const Image image = film.resolve();
  if (*format == ImageFormat::kExr) {
    write_exr(image, args.output,
              {film.resolve_albedo(), film.resolve_normal(), film.resolve_depth()});
  } else {
    const float stops = args.exposure.empty() ? 0.0f : *parse_float(args.exposure);
    write_image(image, args.output, path ? ImageEncoding::srgb(stops) : ImageEncoding::lab());
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!args.quiet) {
    std::printf("merged %zu part%s of render %s (%dx%d, %u spp) in %.1f ms to %s\n",
                args.parts.size(), args.parts.size() == 1 ? "" : "s", info.render.hash.c_str(),
                image.width(), image.height(), info.render.spp, ms, args.output.c_str());
  }
  return 0;
}

}  // namespace tritrace::cli
