// One render, set up in one place for every front end (render, render --mpi, bench, the viewer,
// the Python module): the scene, the integrator spec with the user's settings over the scene's,
// the accel and its build, the integrator, the film's size and AOVs, the part of the render
// (sample range, tile part), the render identity, and every check of a combination of settings.
// Front ends add only what is theirs: terminal output, ranks, a window, timing loops, arrays.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tritrace/accel/accel.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/distributed/part.h"
#include "tritrace/distributed/render_identity.h"
#include "tritrace/image/image.h"
#include "tritrace/image/image_io.h"
#include "tritrace/job/job_settings.h"
#include "tritrace/math/random.h"
#include "tritrace/render/film.h"
#include "tritrace/render/integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/loaded_scene.h"

namespace tritrace {

// Why a render stopped taking samples.
enum class RenderStop {
  kSpp,        // every pixel took --spp samples, or adaptive sampling stopped it before
  kConverged,  // --time-limit with --noise-threshold: every pixel stopped before the time was up
  kTimeLimit,  // --time-limit: the time was up
};

// What a render took and was asked for: the summary line says it, and an EXR output records it
// in its header (render_attributes).
struct RenderRecord {
  uint32_t spp = 0;  // samples per pixel reached (adaptive: the most a pixel could take)
  double mean_spp =
      0.0;  // the samples a pixel took on average, with adaptive sampling (0: unknown)
  double render_seconds = 0.0;   // sampling only: no loading, accel build, denoising or writing
  double denoise_seconds = 0.0;  // with --denoise
  double time_limit = 0.0;       // --time-limit's seconds; 0: none
  float noise_threshold = 0.0f;  // --noise-threshold; 0: none
  RenderStop stop = RenderStop::kSpp;
  // The path tracer's sampler (the denoiser's variance factor depends on it); none for the lab.
  std::optional<SamplerKind> sampler;
  // bdpt's share of samples with a light subpath (0: not bdpt), and whether the pilot of
  // `--light-paths auto` chose it.
  float light_paths = 0.0f;
  bool light_paths_auto = false;
};

// The record as EXR header attributes: tritrace.spp (int), tritrace.meanSpp (float, adaptive),
// tritrace.renderSeconds and tritrace.denoiseSeconds (float, the latter with --denoise),
// tritrace.timeLimit and tritrace.noiseThreshold (float, when set), tritrace.stoppedBy (string:
// "spp", "converged" or "time limit"), tritrace.sampler (string: "sobol" or "independent", path
// renders), tritrace.lightPaths (float, bdpt: the share of samples with a light subpath) and
// tritrace.lightPathsChosenBy (string, bdpt: "auto" for the pilot's choice, else "setting"; a merge
// of auto parts has no lightPaths, which the parts do not carry). Only
// the two times differ between runs of the same render.
// None for a record of no render (spp 0: tritrace denoise's).
std::vector<ExrAttribute> render_attributes(const RenderRecord& record);

// The mean of a film's spp AOV (the samples its pixels took); 0 when the film keeps no spp AOV.
double film_mean_spp(const Film& film);

// The record of a film merged from the parts of the render `identity` (tritrace merge's): the
// render's spp and noise threshold, with adaptive sampling the mean spp when the film keeps the spp
// AOV, bdpt's share of light subpaths (or that auto chose it), and `seconds`, the merge's own time
// (parts do not carry theirs).
RenderRecord merged_record(const RenderIdentity& identity, const Film& film, double seconds);

// A whole render's image and the AOV images asked for (empty images for the others).
struct RenderedImage {
  Image image;
  AovImages aovs;
  double denoise_ms = 0.0;  // the denoiser's time, with --denoise
  RenderRecord record{};    // written to an EXR's header
};

// The denoiser as a render runs it on its film's image: the variance AOV (from the halves of the
// samples) averaged over 5 x 5 pixels and divided by half_buffer_variance_ratio(sampler), the
// overestimate of the halves of the sampler that took the samples; albedo, normal and depth as
// features. `tritrace denoise` runs the same on an EXR with those layers (the sampler from its
// tritrace.sampler attribute), so a merged render denoises as one process would.
Image denoise_film_image(const Image& colour, const AovImages& aovs, SamplerKind sampler);
// The variance denoise_film_image gives the denoiser: the variance AOV averaged over 5 x 5 pixels
// over half_buffer_variance_ratio(sampler).
Image film_denoise_variance(const AovImages& aovs, SamplerKind sampler);

// The sampler an EXR's tritrace.sampler attribute names; Sobol when it has none (what tritrace
// wrote before it recorded the sampler, and its default). Error(file, reason) for another value.
SamplerKind recorded_sampler(const std::map<std::string, std::string>& attributes,
                             const std::string& file);

// The settings of a command that writes an image it did not render (merge, denoise): its output
// and exposure, with the output checked as render checks its own (check_output) and its folder
// writable, before any work.
JobSettings image_output_settings(const std::string& output, const std::string& exposure);

// --exposure scales the path tracer's 8-bit images; with the lab integrator it is refused
// (Error("--exposure", ..., kUsage)), whichever front end asks.
void check_exposure(const JobSettings& settings, bool path);
// Writes a whole render to `file` in its format: EXR with the AOV layers (half floats with
// --exr-half), 8-bit through the sRGB curve with the exposure (path) or the lab's clamp without
// gamma (lab), PFM as floats. Atomic. The job writes through it, and so does a merge of parts.
void write_render(const RenderedImage& rendered, const std::string& file, bool path,
                  const JobSettings& settings);

class RenderJob {
 public:
  // The checks between the output's format and the settings, which need no scene: the caller runs
  // them before loading, so that a bad output costs no time (the constructor runs them again once
  // the output is known). Throws Error(flag, reason, kUsage).
  static void check_output(const JobSettings& settings, const std::string& output);

  // A job that owns its scene (load_job_scene's).
  RenderJob(const JobSettings& settings, LoadedScene loaded);
  // A job over a scene its caller keeps (the viewer's, the Python module's), which must outlive
  // it; `scene_spec` is how that scene asks to be rendered.
  RenderJob(const JobSettings& settings, const Scene& scene, const IntegratorSpec& scene_spec);
  RenderJob(const RenderJob&) = delete;
  RenderJob& operator=(const RenderJob&) = delete;

  const JobSettings& settings() const { return settings_; }
  const Scene& scene() const { return *scene_; }
  // The loaded scene's facts (dropped triangles, the file's output); nullopt for a borrowed scene.
  const LoadedScene* loaded() const { return loaded_ ? &*loaded_ : nullptr; }
  const IntegratorSpec& spec() const { return spec_; }
  // Physically based (path or bdpt): many samples per pixel, sRGB output; false for the lab's.
  bool path() const { return spec_.kind != IntegratorSpec::Kind::kLab; }
  AccelKind accel_kind() const { return accel_kind_; }
  Kernel kernel() const { return kernel_; }
  // The AOVs asked for (written with the image); the film also keeps the ones the denoiser needs.
  const AovSet& aovs() const { return aovs_; }
  int width() const { return scene_->camera.width(); }
  int height() const { return scene_->camera.height(); }
  // The options of this job's part: threads, its samples, seed, sampler, filter, tile part.
  const RenderOptions& options() const { return options_; }
  void set_progress(RenderProgress* progress) { options_.progress = progress; }
  // The part --spp-range and --tile ask for (samples [0, spp) of tile part 0 / 1 when neither).
  const PartRange& part() const { return part_; }
  bool partial() const { return partial_; }
  // The output path: the one given, else the scene file's, else <file stem>.png or cornell.png.
  const std::string& output() const { return output_; }
  // Everything that changes the pixels of the whole render this job is a part of.
  RenderIdentity identity() const;

  // The BVH build: --bvh-build, or for auto the faster to trace `rays` rays in all (default: this
  // render's expected rays; the viewer, which traces frame after frame, passes infinity).
  bvh::BuildMethod bvh_build(std::optional<double> rays = std::nullopt) const;
  // Builds the accel (or takes `prebuilt`, which must outlive the job) and makes the integrator.
  void prepare(AccelInfo* info = nullptr, const Accel* prebuilt = nullptr,
               std::optional<double> rays = std::nullopt);
  // Makes the integrator again for the scene as it is now (the viewer moves the light). With
  // bdpt's `--light-paths auto`, runs its pilot first (render/bdpt_pilot.h).
  void remake_integrator();
  // The pilot's choice of the last remake_integrator (bdpt with --light-paths auto only): the
  // share, the pilot's samples and rays, and the milliseconds it took.
  struct LightPathsPilot {
    float light_paths = 1.0f;
    uint64_t samples = 0, rays = 0;
    double milliseconds = 0.0;
  };
  const std::optional<LightPathsPilot>& light_paths_pilot() const { return light_paths_pilot_; }
  // The share of samples with a light subpath this bdpt render uses (the pilot's with auto; after
  // prepare()); 0 for other integrators.
  float light_paths() const;
  // With --light-paths auto, the line the front ends print after their summary: the chosen share
  // and the pilot's samples, rays and time ("" otherwise).
  std::string light_paths_summary() const;
  const Accel& accel() const { return *accel_; }
  const Integrator& integrator() const { return *integrator_; }

  // A film of the image's size with the job's AOVs (and the denoiser's features with --denoise).
  Film make_film() const;
  // Renders `options` (default: the job's) into `film`; prepare() first.
  void render_to_film(Film& film, RenderStats* stats = nullptr) const;
  void render_to_film(Film& film, const RenderOptions& options, RenderStats* stats) const;
  // The whole render (not a part): the image and the AOVs asked for. With --time-limit, whole
  // passes of samples until the time is up, or with --noise-threshold until every pixel has
  // stopped (stats->spp says how many passes' samples a pixel could take; the image is bit for bit
  // the one --spp of that many makes). The record says what it took and why it stopped.
  RenderedImage render(RenderStats* stats = nullptr) const;
  // Writes a whole render to `file` (write_render).
  void write(const RenderedImage& rendered, const std::string& file) const;
  // Writes the film's image, denoised with --denoise, and the AOVs asked for, with this job's
  // settings and `stats` (spp, samples and pixels for the mean spp, milliseconds) in the record:
  // how render --mpi writes the image it gathered.
  void write(const Film& film, const std::string& file, const RenderStats& stats) const;
  // The record of this job's settings for a render of `seconds` (stats: spp and mean spp).
  RenderRecord record(const RenderStats& stats, double seconds) const;
  // A part's film as a partial film for `tritrace merge`. Atomic.
  void write_part(const Film& film, const std::string& file) const;

 private:
  void set_up();
  RenderedImage render_for(double seconds, RenderStats* stats) const;
  bool adaptive() const { return options_.noise_threshold > 0.0f; }
  // The image of `film` (denoised with --denoise) and the AOVs asked for.
  RenderedImage resolve(const Film& film) const;

  JobSettings settings_;
  std::optional<LoadedScene> loaded_;
  const Scene* scene_ = nullptr;
  IntegratorSpec spec_;
  AccelKind accel_kind_ = AccelKind::kBvh;
  Kernel kernel_ = kDefaultKernel;
  AovSet aovs_;
  AovSet film_aovs_;
  RenderOptions options_;
  PartRange part_;
  bool partial_ = false;
  std::string output_;
  std::unique_ptr<Accel> own_accel_;
  const Accel* accel_ = nullptr;
  std::unique_ptr<Integrator> integrator_;
  std::optional<LightPathsPilot> light_paths_pilot_;
};

}  // namespace tritrace
