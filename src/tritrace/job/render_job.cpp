// The render job: settings resolved against the scene, checked together, then rendered and written
// the same way whichever front end asked.
#include "tritrace/job/render_job.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <utility>

#include "tritrace/denoise/denoiser.h"
#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/job/setting_values.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/make_integrator.h"

namespace tritrace {
namespace {

// "A:B" or "I/N": two unsigned integers; nullopt when the text is not of that form.
std::optional<std::pair<long long, long long>> parse_two(const std::string& text, char sep) {
  const size_t at = text.find(sep);
  if (at == std::string::npos) return std::nullopt;
  const std::optional<long long> a = parse_integer(text.substr(0, at));
  const std::optional<long long> b = parse_integer(text.substr(at + 1));
  if (!a || !b || *a < 0 || *b < 0) return std::nullopt;
  return std::pair{*a, *b};
}

// What the first bidirectional path tracer cannot do yet, refused rather than rendered wrong
// (docs/BDPT.md).
void check_bdpt(const Scene& scene, const IntegratorSpec& spec) {
  if (spec.clamp > 0.0f) {
    throw Error("--clamp",
                "applies to the path tracer; bdpt has no clamp (its connections have no "
                "direct/indirect split)",
                ExitCode::kUsage);
  }
  if (const std::string why = bdpt_unsupported(scene); !why.empty()) {
    throw Error("--integrator", why, ExitCode::kUsage);
  }
}

// The part --spp-range and --tile ask for, checked against the render's spp and image size.
PartRange part_range(const JobSettings& settings, bool path, uint32_t spp, int width, int height) {
  PartRange range{0, path ? spp : 1, 0, 1};
  if (!settings.spp_range.empty()) {
    if (!path) {
      throw Error("--spp-range",
                  "the lab integrator takes one sample per pixel; split its image with --tile",
                  ExitCode::kUsage);
    }
    const auto ab = parse_two(settings.spp_range, ':');
    if (!ab) {
      throw Error("--spp-range",
                  "expected A:B (two whole numbers), got '" + settings.spp_range + "'",
                  ExitCode::kUsage);
    }
    const auto [a, b] = *ab;
    if (a >= b || b > static_cast<long long>(spp)) {
      throw Error(
          "--spp-range",
          settings.spp_range + " is not a range A < B <= " + std::to_string(spp) + " (the spp)",
          ExitCode::kUsage);
    }
    if (a % kSampleBlock != 0 || (b % kSampleBlock != 0 && b != static_cast<long long>(spp))) {
      throw Error("--spp-range",
                  settings.spp_range + " is not split at multiples of " +
                      std::to_string(kSampleBlock) +
                      ": parts merge bit for bit only at whole blocks of 8 samples (B may also be "
                      "the spp, " +
                      std::to_string(spp) + ")",
                  ExitCode::kUsage);
    }
    range.first = static_cast<uint32_t>(a);
    range.end = static_cast<uint32_t>(b);
  }
  if (!settings.tile.empty()) {
    const auto in = parse_two(settings.tile, '/');
    if (!in || in->second < 1 || in->first >= in->second) {
      throw Error("--tile", "expected I/N with 0 <= I < N, got '" + settings.tile + "'",
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

void RenderJob::check_output(const JobSettings& settings, const std::string& output) {
  const bool partial = !settings.spp_range.empty() || !settings.tile.empty();
  const std::optional<ImageFormat> format = image_format_for(output);
  if (partial) {
    const char* flag = !settings.spp_range.empty() ? "--spp-range" : "--tile";
    if (!settings.output_given || format != ImageFormat::kExr) {
      throw Error(flag, "writes a partial film, an OpenEXR file: give -o PART.exr",
                  ExitCode::kUsage);
    }
    if (settings.exr_half) {
      throw Error("--exr-half", "partial films keep 32-bit float sums (merging needs every bit)",
                  ExitCode::kUsage);
    }
  }
  if (!format) {
    throw Error(
        "--output",
        "'" + output + "' has an unknown extension (use " + std::string(kImageExtensions) + ")",
        ExitCode::kUsage);
  }
  if (!settings.aovs.empty() && *format != ImageFormat::kExr) {
    throw Error("--aovs", "needs an .exr output, got '" + output + "'", ExitCode::kUsage);
  }
  if (settings.exr_half && *format != ImageFormat::kExr) {
    throw Error("--exr-half", "needs an .exr output, got '" + output + "'", ExitCode::kUsage);
  }
  // Exposure is a display choice: float files keep the radiance the renderer computed, and a
  // viewer or compositor exposes them however it likes. Ignoring the flag silently would hide a
  // mistake, so it is refused.
  if (!settings.exposure.empty() && is_float_format(*format)) {
    throw Error("--exposure",
                "applies to 8-bit outputs (.png, .ppm); .pfm and .exr store the radiance "
                "unscaled, got '" +
                    output + "'",
                ExitCode::kUsage);
  }
}

JobSettings image_output_settings(const std::string& output, const std::string& exposure) {
  JobSettings settings;
  settings.output = output;
  settings.output_given = true;
  settings.exposure = exposure;
  RenderJob::check_output(settings, output);
  check_writable_path(output);
  return settings;
}

void check_exposure(const JobSettings& settings, bool path) {
  if (!path && !settings.exposure.empty()) {
    throw Error("--exposure",
                "applies to path images; the lab integrator keeps the lab's clamp without gamma",
                ExitCode::kUsage);
  }
}

void write_render(const RenderedImage& rendered, const std::string& file, bool path,
                  const JobSettings& settings) {
  if (image_format_for(file) == ImageFormat::kExr) {
    write_exr(rendered.image, file, rendered.aovs,
              settings.exr_half ? ExrPixelType::kHalf : ExrPixelType::kFloat);
  } else {
    write_image(
        rendered.image, file,
        path ? ImageEncoding::srgb(exposure_stops(settings).value_or(0.0f)) : ImageEncoding::lab());
  }
}

Image denoise_film_image(const Image& colour, const AovImages& aovs) {
  // The half-buffer variance of one pixel has one degree of freedom: averaged over 5 x 5 pixels
  // it is steady enough to weigh neighbours by (docs/DENOISING.md).
  const Image variance = smooth_variance(aovs.variance, 2);
  return denoise(colour, variance, {aovs.albedo, aovs.normal, aovs.depth});
}

RenderJob::RenderJob(const JobSettings& settings, LoadedScene loaded)
    : settings_(settings), loaded_(std::move(loaded)) {
  scene_ = &loaded_->scene;
  spec_ = integrator_spec(settings_, loaded_->integrator);
  set_up();
}

RenderJob::RenderJob(const JobSettings& settings, const Scene& scene,
                     const IntegratorSpec& scene_spec)
    : settings_(settings), scene_(&scene) {
  spec_ = integrator_spec(settings_, scene_spec);
  set_up();
}

void RenderJob::set_up() {
  check_exposure(settings_, path());
  if (!path()) {
    // Settings that only the path tracer has, each refused with the reason it means nothing to
    // the lab integrator.
    const struct {
      const char* flag;
      bool given;
      const char* why;
    } path_only[] = {
        {"--clamp", !settings_.clamp.empty(), "the lab integrator has no indirect samples"},
        {"--time-limit", !settings_.time_limit.empty(),
         "the lab integrator takes one sample per pixel"},
        {"--denoise", settings_.denoise, "the lab integrator's image has no noise"},
        {"--noise-threshold", !settings_.noise_threshold.empty(),
         "the lab integrator takes one sample per pixel"},
    };
    for (const auto& setting : path_only) {
      if (setting.given) {
        throw Error(setting.flag, std::string("applies to the path tracer; ") + setting.why,
                    ExitCode::kUsage);
      }
    }
  }
  if (!settings_.time_limit.empty()) {
    if (!settings_.spp_range.empty() || !settings_.tile.empty()) {
      throw Error("--time-limit",
                  "renders passes until the time is up, so a part's samples are not known in "
                  "advance; it does not take --spp-range or --tile",
                  ExitCode::kUsage);
    }
    if (!settings_.noise_threshold.empty()) {
      throw Error("--time-limit",
                  "does not take --noise-threshold yet (adaptive sampling renders each pixel's "
                  "samples in one pass); give one or the other",
                  ExitCode::kUsage);
    }
    // --spp is the most samples a pixel takes; without it, passes go on until the time is up.
    if (settings_.spp.empty()) spec_.spp = kMaxSpp;
  }
  if (settings_.denoise && (!settings_.spp_range.empty() || !settings_.tile.empty())) {
    throw Error("--denoise",
                "denoises a whole image; render the parts with --aovs "
                "albedo,normal,depth,variance, merge them, then run `tritrace denoise`",
                ExitCode::kUsage);
  }
  if (!settings_.noise_threshold.empty() && !settings_.spp_range.empty()) {
    throw Error("--noise-threshold",
                "decides per pixel from all its samples [0, spp), so a sample range cannot be "
                "rendered apart; split the image with --tile instead of --spp-range",
                ExitCode::kUsage);
  }
  if (spec_.kind == IntegratorSpec::Kind::kBdpt) check_bdpt(*scene_, spec_);
  accel_kind_ = tritrace::accel_kind(settings_);
  kernel_ = kernel_choice(settings_);
  aovs_ = aov_set(settings_);
  film_aovs_ = aovs_;
  if (settings_.denoise) {
    film_aovs_.albedo = film_aovs_.normal = film_aovs_.depth = film_aovs_.variance = true;
  }
  partial_ = !settings_.spp_range.empty() || !settings_.tile.empty();
  part_ = part_range(settings_, path(), spec_.spp, width(), height());
  options_.threads = thread_count(settings_);
  options_.seed = spec_.seed;
  options_.sampler = spec_.sampler;
  options_.filter = filter_choice(settings_);
  options_.first_sample = part_.first;
  options_.spp = partial_ ? part_.end - part_.first : spec_.spp;
  options_.tile_part = part_.tile;
  options_.tile_parts = part_.tiles;
  options_.noise_threshold = tritrace::noise_threshold(settings_);
  if (settings_.output_given) {
    output_ = settings_.output;
  } else if (loaded_ && !loaded_->output.empty()) {
    output_ = loaded_->output;
  } else if (settings_.file.empty()) {
    output_ = "cornell.png";  // the lab's name, whatever the built-in scene
  } else {
    output_ = std::filesystem::path(settings_.file).stem().string() + ".png";
  }
}

RenderIdentity RenderJob::identity() const {
  RenderOptions whole = options_;
  whole.spp = spec_.spp;
  whole.first_sample = 0;
  whole.tile_part = 0;
  whole.tile_parts = 1;
  whole.progress = nullptr;
  return render_identity(*scene_, spec_, whole, accel_name(accel_kind_), kernel_name(kernel_),
                         aovs_);
}

bvh::BuildMethod RenderJob::bvh_build(std::optional<double> rays) const {
  const uint64_t pixels = static_cast<uint64_t>(width()) * height();
  return bvh_build_choice(settings_, scene_->stored_triangles(),
                          rays.value_or(expected_rays(spec_, pixels)));
}

void RenderJob::prepare(AccelInfo* info, const Accel* prebuilt, std::optional<double> rays) {
  if (prebuilt) {
    accel_ = prebuilt;
  } else {
    own_accel_ = make_accel(accel_kind_, *scene_, kernel_, info, bvh_build(rays));
    accel_ = own_accel_.get();
  }
  remake_integrator();
}

void RenderJob::remake_integrator() {
  integrator_ = make_integrator(spec_, *scene_);
}

Film RenderJob::make_film() const {
  return Film(width(), height(), film_aovs_);
}

RenderedImage RenderJob::resolve(const Film& film) const {
  RenderedImage out{film.resolve(), film.resolve_aovs()};
  if (settings_.denoise) {
    const auto start = std::chrono::steady_clock::now();
    out.image = denoise_film_image(out.image, out.aovs);
    out.denoise_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  // Only the AOVs asked for are written.
  if (!aovs_.albedo) out.aovs.albedo = Image();
  if (!aovs_.normal) out.aovs.normal = Image();
  if (!aovs_.depth) out.aovs.depth = Image();
  if (!aovs_.variance) out.aovs.variance = Image();
  return out;
}

void RenderJob::render_to_film(Film& film, RenderStats* stats) const {
  render_to_film(film, options_, stats);
}

void RenderJob::render_to_film(Film& film, const RenderOptions& options, RenderStats* stats) const {
  tritrace::render_to_film(*scene_, *accel_, *integrator_, film, options, stats);
}

RenderedImage RenderJob::render(RenderStats* stats) const {
  if (const std::optional<double> seconds = time_limit_seconds(settings_)) {
    return render_for(*seconds, stats);
  }
  RenderedImage out;
  if (film_aovs_.any()) {
    Film film = make_film();
    render_to_film(film, stats);
    out = resolve(film);
  } else {
    // The same bits as a film's resolve, without the film's memory.
    out.image = tritrace::render(*scene_, *accel_, *integrator_, options_, stats);
  }
  return out;
}

RenderedImage RenderJob::render_for(double seconds, RenderStats* stats) const {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  Film film = make_film();
  RenderStats total;
  uint32_t taken = 0;
  const uint32_t cap = spec_.spp;
  // With --denoise the limit covers the denoiser too: its time, measured on the first pass's
  // image, is kept back from the passes.
  double reserve = 0.0;
  while (taken < cap) {
    // Passes of whole sample blocks, each at most as many samples as the film holds (so the time
    // per sample is measured again before a long pass), as many as the time left fits at the
    // time per sample so far. The first pass is always rendered: an image needs samples.
    uint32_t n = std::min(cap - taken, kSampleBlock);
    if (taken > 0) {
      const double per_sample = (elapsed() - reserve) / taken;
      const double fit = (seconds - reserve - elapsed()) / per_sample;
      if (cap - taken < kSampleBlock) {
        n = fit >= static_cast<double>(cap - taken) ? cap - taken : 0;
      } else {
        const double most =
            std::min({fit, static_cast<double>(taken), static_cast<double>(cap - taken)});
        n = most >= kSampleBlock ? static_cast<uint32_t>(most) / kSampleBlock * kSampleBlock : 0;
      }
      if (n == 0) break;
    }
    RenderOptions options = options_;
    options.first_sample = taken;
    options.spp = n;
    options.progress = nullptr;
    RenderStats pass;
    render_to_film(film, options, &pass);
    total.rays += pass.rays;
    total.samples += pass.samples;
    total.pixels = pass.pixels;
    total.threads = std::max(total.threads, pass.threads);
    taken += n;
    if (settings_.denoise && reserve == 0.0) {
      const double before = elapsed();
      (void)resolve(film);
      reserve = elapsed() - before;
    }
  }
  total.spp = taken;
  total.milliseconds = elapsed() * 1e3;
  if (stats) *stats = total;
  return resolve(film);
}

void RenderJob::write(const RenderedImage& rendered, const std::string& file) const {
  write_render(rendered, file, path(), settings_);
}

void RenderJob::write(const Film& film, const std::string& file) const {
  write(resolve(film), file);
}

void RenderJob::write_part(const Film& film, const std::string& file) const {
  write_file_atomic(
      file, encode_partial_film(pack_part(film, part_.tile, part_.tiles), {identity(), part_}));
}

}  // namespace tritrace
