// The merge subcommand: checks the output first, then the parts (one render, each sample of each
// tile exactly once), merges them in the block tree's fixed order and writes the image atomically.
#include "merge_command.h"

#include <chrono>
#include <cstdio>

#include "flags/flag_values.h"
#include "tritrace/distributed/film_merger.h"
#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/error.h"
#include "tritrace/image/image_io.h"
#include "tritrace/job/render_job.h"

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
      ->check(checked(setting_check("--exposure")));
  sub->add_flag("-q,--quiet", args.quiet, "Print nothing on success");
  return sub;
}

int run_merge(const MergeArgs& args) {
  // The output's checks and its writing are the render job's, so a merged image is written as
  // the one-process render would be.
  const JobSettings settings = image_output_settings(args.output, args.exposure);
  const auto start = std::chrono::steady_clock::now();
  const PartInfo info = read_part_info(args.parts.front());
  const bool path = info.render.integrator != "lab";  // path or bdpt: sRGB output
  check_exposure(settings, path);
  const Film film = merge_parts(args.parts);
  RenderedImage rendered{film.resolve(), film.resolve_aovs()};
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  rendered.record = merged_record(info.render, film, ms * 1e-3);
  write_render(rendered, args.output, path, settings);
  const Image& image = rendered.image;
  if (!args.quiet) {
    std::printf("merged %zu part%s of render %s (%dx%d, %u spp) in %.1f ms to %s\n",
                args.parts.size(), args.parts.size() == 1 ? "" : "s", info.render.hash.c_str(),
                image.width(), image.height(), info.render.spp, ms, args.output.c_str());
  }
  return 0;
}

}  // namespace tritrace::cli
