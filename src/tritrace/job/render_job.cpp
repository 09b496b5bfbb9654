// The render job: settings resolved against the scene, checked together, then rendered and written
// the same way whichever front end asked.
#include "tritrace/job/render_job.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <utility>

#include "tritrace/denoise/denoiser.h"
#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/job/setting_values.h"
#include "tritrace/parallel.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/bdpt_pilot.h"
#include "tritrace/render/lab_integrator.h"
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

// Light tracing (bdpt's t = 1) splats onto any pixel, and estimates each pixel from all pixels'
// samples together (Integrator::splats): refused where that cannot hold (docs/BDPT.md).
void check_light_tracing(const JobSettings& settings, const Camera& camera) {
  // Its connections reach a pinhole or a lens; an orthographic camera without a lens has none
  // (bdpt turns light tracing off for it, so the rules below do not apply; docs/BDPT.md).
  if (!camera_light_tracing(camera)) return;
  if (!settings.tile.empty()) {
    throw Error("--tile",
                "bdpt's light tracing lands on pixels of every tile, so a tile part cannot hold "
                "its image; split a bdpt render with --spp-range",
                ExitCode::kUsage);
  }
  if (filter_choice(settings) != FilterKind::kBox) {
    throw Error("--filter", "bdpt's light tracing has the camera's density for the box filter only",
                ExitCode::kUsage);
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

std::vector<ExrAttribute> render_attributes(const RenderRecord& record) {
  // No render behind the image (tritrace denoise of a file): nothing to record.
  if (record.spp == 0) return {};
  std::vector<ExrAttribute> out = {
      {"tritrace.spp", static_cast<int>(record.spp)},
      {"tritrace.renderSeconds", static_cast<float>(record.render_seconds)},
      {"tritrace.stoppedBy", std::string(record.stop == RenderStop::kConverged   ? "converged"
                                         : record.stop == RenderStop::kTimeLimit ? "time limit"
                                                                                 : "spp")}};
  if (record.mean_spp > 0.0) {
    out.push_back({"tritrace.meanSpp", static_cast<float>(record.mean_spp)});
  }
  if (record.denoise_seconds > 0.0) {
    out.push_back({"tritrace.denoiseSeconds", static_cast<float>(record.denoise_seconds)});
  }
  if (record.time_limit > 0.0) {
    out.push_back({"tritrace.timeLimit", static_cast<float>(record.time_limit)});
  }
  if (record.noise_threshold > 0.0f) {
    out.push_back({"tritrace.noiseThreshold", record.noise_threshold});
  }
  if (record.sampler) {
    out.push_back({"tritrace.sampler", std::string(sampler_name(*record.sampler))});
  }
  if (record.light_paths > 0.0f) out.push_back({"tritrace.lightPaths", record.light_paths});
  if (record.light_paths > 0.0f || record.light_paths_auto) {
    out.push_back(
        {"tritrace.lightPathsChosenBy", std::string(record.light_paths_auto ? "auto" : "setting")});
  }
  return out;
}

double film_mean_spp(const Film& film) {
  if (!film.aovs().spp) return 0.0;
  const Image spp = film.resolve_spp();
  // Whole numbers, summed exactly in double: the same mean as the renderer's sample count.
  double sum = 0.0;
  for (const glm::vec3& p : spp.pixels()) sum += p.x;
  return spp.pixels().empty() ? 0.0 : sum / static_cast<double>(spp.pixels().size());
}

RenderRecord merged_record(const RenderIdentity& identity, const Film& film, double seconds) {
  RenderRecord r;
  r.spp = identity.spp;
  r.render_seconds = seconds;
  // The value of ` key=` in the identity's settings text (up to the next space), if it is there.
  const auto value_of = [&](std::string_view key) -> std::optional<std::string_view> {
    const size_t at = identity.settings.find(key);
    if (at == std::string::npos) return std::nullopt;
    const size_t from = at + key.size();
    return std::string_view(identity.settings)
        .substr(from, identity.settings.find(' ', from) - from);
  };
  if (const auto threshold = value_of(" noise_threshold=")) {
    r.noise_threshold = std::strtof(std::string(*threshold).c_str(), nullptr);
    r.mean_spp = film_mean_spp(film);
  }
  if (const auto sampler = value_of(" sampler=")) r.sampler = parse_sampler(*sampler);
  // bdpt: the share the identity names (absent: 1). With auto every part made the pilot's choice,
  // which the parts do not carry: the merged header says auto and no share.
  if (identity.integrator == "bdpt") {
    const std::string_view share = value_of(" light_paths=").value_or("1");
    r.light_paths_auto = share == "auto";
    if (!r.light_paths_auto) r.light_paths = std::strtof(std::string(share).c_str(), nullptr);
  }
  return r;
}

void write_render(const RenderedImage& rendered, const std::string& file, bool path,
                  const JobSettings& settings) {
  if (image_format_for(file) == ImageFormat::kExr) {
    write_exr(rendered.image, file, rendered.aovs,
              settings.exr_half ? ExrPixelType::kHalf : ExrPixelType::kFloat,
              render_attributes(rendered.record));
  } else {
    write_image(
        rendered.image, file,
        path ? ImageEncoding::srgb(exposure_stops(settings).value_or(0.0f)) : ImageEncoding::lab());
  }
}

Image film_denoise_variance(const AovImages& aovs, SamplerKind sampler) {
  // The half-buffer variance of one pixel has one degree of freedom: averaged over 5 x 5 pixels
  // it is steady enough to weigh neighbours by (docs/DENOISING.md).
  return smooth_variance(aovs.variance, 2, half_buffer_variance_ratio(sampler));
}

Image denoise_film_image(const Image& colour, const AovImages& aovs, SamplerKind sampler) {
  return denoise(colour, film_denoise_variance(aovs, sampler),
                 {aovs.albedo, aovs.normal, aovs.depth});
}

SamplerKind recorded_sampler(const std::map<std::string, std::string>& attributes,
                             const std::string& file) {
  const auto it = attributes.find("tritrace.sampler");
  if (it == attributes.end()) return SamplerKind::kSobol;
  if (const std::optional<SamplerKind> kind = parse_sampler(it->second)) return *kind;
  throw Error(file, "attribute tritrace.sampler is '" + it->second +
                        "', not a sampler (sobol or independent)");
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
        {"--light-paths", !settings_.light_paths.empty(),
         "the lab integrator traces no light subpaths"},
        {"--time-limit", !settings_.time_limit.empty(),
         "the lab integrator takes one sample per pixel"},
        {"--denoise", settings_.denoise, "the lab integrator's image has no noise"},
        {"--noise-threshold", !settings_.noise_threshold.empty(),
         "the lab integrator takes one sample per pixel"},
        {"--aperture", !settings_.aperture.empty(),
         "the lab integrator traces one ray through each pixel's corner, without a lens"},
        {"--focus", !settings_.focus.empty(),
         "the lab integrator traces one ray through each pixel's corner, without a lens"},
    };
    for (const auto& setting : path_only) {
      if (setting.given) {
        throw Error(setting.flag, std::string("applies to the path tracer; ") + setting.why,
                    ExitCode::kUsage);
      }
    }
    // A lens the scene file gives: the lab's corner rays would ignore it without a word.
    if (scene_->camera.has_lens()) {
      throw Error("--integrator",
                  "the scene's camera has a lens (aperture_radius > 0), which the lab integrator "
                  "ignores (one ray through each pixel's corner); use path or bdpt",
                  ExitCode::kUsage);
    }
  }
  if (!settings_.time_limit.empty()) {
    if (!settings_.spp_range.empty() || !settings_.tile.empty()) {
      throw Error("--time-limit",
                  "renders passes until the time is up, so a part's samples are not known in "
                  "advance; it does not take --spp-range or --tile",
                  ExitCode::kUsage);
    }
    // --spp is the most samples a pixel takes; without it, passes go on until the time is up
    // (or, with --noise-threshold, until every pixel has stopped).
    if (settings_.spp.empty()) spec_.spp = kMaxSpp;
  }
  if (settings_.denoise && (!settings_.spp_range.empty() || !settings_.tile.empty())) {
    throw Error("--denoise",
                "denoises a whole image; render the parts with --aovs "
                "albedo,normal,depth,variance, merge them, then run `tritrace denoise`",
                ExitCode::kUsage);
  }
  if (!settings_.noise_threshold.empty() && !settings_.spp_range.empty()) {
    // bdpt's light tracing cannot be split into tiles either (check_light_tracing).
    const bool bdpt = spec_.kind == IntegratorSpec::Kind::kBdpt;
    throw Error("--noise-threshold",
                std::string("decides per pixel from all its samples [0, spp), so a sample range "
                            "cannot be rendered apart; ") +
                    (bdpt ? "with bdpt, render the whole image in one go"
                          : "split the image with --tile instead of --spp-range"),
                ExitCode::kUsage);
  }
  if (spec_.kind == IntegratorSpec::Kind::kPath && !settings_.light_paths.empty()) {
    throw Error("--light-paths", "applies to bdpt; the path tracer traces no light subpaths",
                ExitCode::kUsage);
  }
  if (spec_.kind == IntegratorSpec::Kind::kBdpt) {
    check_bdpt(*scene_, spec_);
    check_light_tracing(settings_, scene_->camera);
  }
  if (spec_.kind == IntegratorSpec::Kind::kLab) {
    if (const std::string why = lab_unsupported(*scene_); !why.empty()) {
      throw Error("--integrator", why, ExitCode::kUsage);
    }
  }
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
  // The job's threads, on which bdpt's caustic guide is built (its pre-pass is parallel).
  const int guide_threads = options_.threads > 0 ? options_.threads : default_thread_count();
  if (spec_.kind == IntegratorSpec::Kind::kBdpt && spec_.light_paths_auto) {
    // The pilot's choice depends on the scene, the seed and the sampler only (bdpt_pilot.h), so
    // every part, pass and thread count of this render makes the same.
    const auto start = std::chrono::steady_clock::now();
    BdptSettings settings;
    settings.max_depth = spec_.max_depth;
    // In the job's arena: the pilot's samples and its caustic guide's pre-pass run on its threads.
    LightPathsChoice choice;
    parallel::in_arena(guide_threads, [&] {
      choice = choose_light_paths(*scene_, *accel_, settings, spec_.seed, spec_.sampler);
    });
    light_paths_pilot_ = LightPathsPilot{
        choice.light_paths, choice.samples, choice.rays,
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count()};
    IntegratorSpec chosen = spec_;
    chosen.light_paths = choice.light_paths;
    integrator_ = make_integrator(chosen, *scene_);
    // The render's caustic guide is the pilot's (built once per job).
    if (auto* bdpt = dynamic_cast<BdptIntegrator*>(integrator_.get())) {
      bdpt->use_caustic_guide(choice.guide);
    }
    return;
  }
  integrator_ = make_integrator(spec_, *scene_);
  // bdpt's caustic guide, built here on the job's threads (its first radiance call would build
  // it inside one render task, where the other threads wait instead of helping).
  if (const auto* bdpt = dynamic_cast<const BdptIntegrator*>(integrator_.get())) {
    parallel::in_arena(guide_threads, [&] { bdpt->caustic_guide(*scene_, *accel_); });
  }
}

std::string RenderJob::light_paths_summary() const {
  if (!light_paths_pilot_) return "";
  const LightPathsPilot& c = *light_paths_pilot_;
  char text[160];
  std::snprintf(text, sizeof text,
                "bdpt --light-paths auto chose %s (pilot: %llu samples, %llu rays, %.1f ms)",
                format_double(c.light_paths).c_str(), static_cast<unsigned long long>(c.samples),
                static_cast<unsigned long long>(c.rays), c.milliseconds);
  return text;
}

float RenderJob::light_paths() const {
  if (spec_.kind != IntegratorSpec::Kind::kBdpt) return 0.0f;
  return light_paths_pilot_ ? light_paths_pilot_->light_paths : spec_.light_paths;
}

Film RenderJob::make_film() const {
  return Film(width(), height(), film_aovs_);
}

RenderedImage RenderJob::resolve(const Film& film) const {
  RenderedImage out{film.resolve(), film.resolve_aovs()};
  if (settings_.denoise) {
    const auto start = std::chrono::steady_clock::now();
    out.image = denoise_film_image(out.image, out.aovs, options_.sampler);
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

RenderRecord RenderJob::record(const RenderStats& stats, double seconds) const {
  RenderRecord r;
  r.spp = stats.spp;
  if (adaptive() && path()) r.mean_spp = stats.mean_spp();
  r.render_seconds = seconds;
  r.time_limit = time_limit_seconds(settings_).value_or(0.0);
  r.noise_threshold = path() ? options_.noise_threshold : 0.0f;
  if (path()) r.sampler = options_.sampler;
  r.light_paths = light_paths();
  r.light_paths_auto = light_paths_pilot_.has_value();
  return r;
}

RenderedImage RenderJob::render(RenderStats* stats) const {
  if (const std::optional<double> seconds = time_limit_seconds(settings_)) {
    return render_for(*seconds, stats);
  }
  RenderedImage out;
  RenderStats own;
  if (film_aovs_.any()) {
    Film film = make_film();
    render_to_film(film, &own);
    out = resolve(film);
  } else {
    // The same bits as a film's resolve, without the film's memory.
    out.image = tritrace::render(*scene_, *accel_, *integrator_, options_, &own);
  }
  out.record = record(own, own.milliseconds * 1e-3);
  out.record.denoise_seconds = out.denoise_ms * 1e-3;
  if (stats) *stats = own;
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
  // With --noise-threshold, each pixel's sums and decisions carry from pass to pass, so the
  // passes decide exactly as one render of the same spp would.
  AdaptiveState state;
  RenderStop stop = RenderStop::kSpp;
  // With --denoise the limit covers the denoiser too: its time, measured on the first pass's
  // image, is kept back from the passes.
  double reserve = 0.0;
  while (taken < cap) {
    // Passes of whole sample blocks, each at most as many samples as the film holds (so the time
    // per sample is measured again before a long pass), as many as the time left fits at the
    // time per pixel sample so far times the pixels still taking samples (all of them without
    // adaptive sampling). The first pass is always rendered: an image needs samples.
    uint32_t n = std::min(cap - taken, kSampleBlock);
    if (taken > 0) {
      const double pixels_on = adaptive() ? static_cast<double>(state.active_pixels())
                                          : static_cast<double>(total.pixels);
      const double per_sample = (elapsed() - reserve) /
                                std::max(1.0, static_cast<double>(total.samples)) *
                                std::max(1.0, pixels_on);
      const double fit = (seconds - reserve - elapsed()) / per_sample;
      if (cap - taken < kSampleBlock) {
        n = fit >= static_cast<double>(cap - taken) ? cap - taken : 0;
      } else {
        const double most =
            std::min({fit, static_cast<double>(taken), static_cast<double>(cap - taken)});
        n = most >= kSampleBlock ? static_cast<uint32_t>(most) / kSampleBlock * kSampleBlock : 0;
      }
      if (n == 0) {
        stop = RenderStop::kTimeLimit;
        break;
      }
    }
    RenderOptions options = options_;
    options.first_sample = taken;
    options.spp = n;
    options.progress = nullptr;
    options.adaptive_state = &state;
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
    // Every pixel has stopped: later passes would add nothing (before --spp was reached).
    if (adaptive() && taken < cap && state.active_pixels() == 0) {
      stop = RenderStop::kConverged;
      break;
    }
  }
  total.spp = taken;
  total.milliseconds = elapsed() * 1e3;
  if (stats) *stats = total;
  RenderedImage out = resolve(film);
  out.record = record(total, total.milliseconds * 1e-3);
  out.record.denoise_seconds = out.denoise_ms * 1e-3;
  out.record.stop = stop;
  return out;
}

void RenderJob::write(const RenderedImage& rendered, const std::string& file) const {
  write_render(rendered, file, path(), settings_);
}

void RenderJob::write(const Film& film, const std::string& file, const RenderStats& stats) const {
  RenderedImage rendered = resolve(film);
  rendered.record = record(stats, stats.milliseconds * 1e-3);
  rendered.record.denoise_seconds = rendered.denoise_ms * 1e-3;
  write(rendered, file);
}

void RenderJob::write_part(const Film& film, const std::string& file) const {
  write_file_atomic(
      file, encode_partial_film(pack_part(film, part_.tile, part_.tiles), {identity(), part_}));
}

}  // namespace tritrace
