// BdptIntegrator: bidirectional path tracing (Veach 1997, chapter 10; Lafortune and Willems 1993):
// per camera sample one camera subpath and one light subpath, every connection strategy (s, t)
// with t >= 2, and light tracing to the camera (t = 1, s >= 2: a light subpath vertex connected to
// the pinhole or the lens, added to the pixel it projects to through the film's SplatBuffer; not
// to an orthographic camera without a lens, which it cannot reach), and where light reaches
// surfaces through specular ones a caustic strategy (camera paths guided by the photons of a
// pre-pass, render/caustic_guide.h), combined by multiple importance sampling (power heuristic).
// Point, spot and directional lights, emissive triangles and the environment (a constant colour or
// a map). docs/BDPT.md has the design.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "tritrace/math/offset_ray.h"
#include "tritrace/math/sampling.h"
#include "tritrace/render/caustic_guide.h"
#include "tritrace/render/environment_light.h"
#include "tritrace/render/integrator.h"

namespace tritrace {

// What the pilot of `--light-paths auto` (render/bdpt_pilot.h) reads off each sample of a
// BdptIntegrator::pilot_radiance call: per sample of the batch, the
// luminance of its contributions at F = 1 weighted as a render at each candidate share F
// (kPilotShares) would weigh them (add_pilot_contribution), split by whether they need the light
// subpath past its first vertex, and its counted work.
inline constexpr int kPilotCandidates = 7;
inline constexpr std::array<float, kPilotCandidates> kPilotShares = {
    1.0f, 0.5f, 0.25f, 0.125f, 0.0625f, 0.03125f, 0.015625f};
struct LightPathsTally {
  struct Sample {
    std::array<double, kPilotCandidates> always{};  // s <= 1, t >= 2: every sample has them
    std::array<double, kPilotCandidates> light{};   // s >= 2, t >= 2 (unscaled: as at F = 1)
    std::array<double, kPilotCandidates> splat2{};  // the squares of its t = 1 splats
    // Counted work: camera subpath vertices and shadow rays of s <= 1 (every sample), light
    // subpath vertices past the first and shadow rays of s >= 2 and t = 1 (F's share).
    uint32_t camera_vertices = 0, light_vertices = 0;
    uint32_t always_rays = 0, light_rays = 0;
  };
  std::vector<Sample> samples;  // one per sample of the batch (the caller sizes it)
};

struct BdptSettings {
  // Bounces, as PathSettings::max_depth: paths of at most max_depth + 1 edges (s + t <=
  // max_depth + 2 vertices).
  int max_depth = 1024;
  // Bounces of a subpath before Russian roulette may end it (the path tracer's rule: survival
  // min(1, sqrt(max component of the subpath's throughput))).
  int roulette_depth = 3;
  // For tests: evaluate only strategy (only_s, only_t) when both are >= 0, and with
  // `unweighted` without its MIS weight (each strategy alone is then an unbiased estimate of the
  // paths it can sample).
  int only_s = -1;
  int only_t = -1;
  bool unweighted = false;
  // The balance heuristic instead of the power heuristic (for tests: both are unbiased).
  bool balance = false;
  // Light tracing to the camera (the strategies (s, 1), s >= 2), splatted onto the pixel each
  // connection projects to. Off: only t >= 2, each sample's contribution stays in its pixel, and
  // the weights cover exactly those strategies (the first version's image).
  bool light_tracing = true;
  // For tests: every MIS weight is also computed by the ratio walk over the whole path (Veach
  // 1997, sec. 10.2; the first version's weights, which the O(1) recursion replaced), and the
  // largest absolute difference between the two is recorded here. The image is the recursion's.
  struct WeightCheck {
    std::mutex mutex;
    double max_difference = 0.0;
    uint64_t count = 0;
  };
  WeightCheck* weight_check = nullptr;
  // For tests: multiplies the light-tracing count ratio that the MIS weights use (not the
  // splats' normalisation), so that a test can render with ratios other than 1 and check that the
  // weights stay a partition of unity (the image mean does not move).
  float mis_count_scale = 1.0f;
  // The share F of camera samples that also trace a light subpath, in (0, 1] (at least
  // kMinLightPaths): sample i of a pixel traces one when floor((i + 1) F + phi) > floor(i F + phi),
  // with phi uniform per pixel (a hash of the seed and the pixel), so each sample does with
  // probability F and any n consecutive samples of a pixel hold floor(n F) or ceil(n F) of them.
  // The strategies that use the light subpath past its first vertex (s >= 2, light tracing
  // included) are then sampled F times as often: their contributions are divided by F and the
  // MIS weights count their densities F times (Veach 1997, sec. 9.2: each strategy's density
  // times its number of samples; Grittmann et al. 2022, "Efficiency-aware multiple importance
  // sampling for bidirectional rendering algorithms", make the light path count a free
  // parameter). s = 0 and s = 1 (next-event estimation from the light subpath's first vertex,
  // which every sample draws) are sampled by every sample. 1: every sample, the image as before.
  float light_paths = 1.0f;
  // For tests: false walks every camera vertex with the scalar code, which the SIMD lanes for flat
  // Lambert vertices (where the build has AVX2) must match bit for bit.
  bool lanes = true;
  // For tests: false connects the samples whose light subpath is its first vertex only (most of
  // them where light_paths < 1) with the general code too, whose image the dedicated one
  // (s = 0 and s = 1 only, each connection weighted as it is made) must match bit for bit.
  bool camera_only_connect = true;
  // Light paths traced by the caustic guide's pre-pass (render/caustic_guide.h, docs/BDPT.md):
  // where light from emissive triangles reaches non-specular surfaces through specular ones
  // (smooth glass, mirrors), a guided strategy samples those paths from the camera subpath's
  // vertices towards the specular surfaces, weighted against the camera subpath's own sampling of
  // them (which the light subpath's strategies then leave out). 0: no guide. Off, whatever its
  // value, where only_s and only_t or `unweighted` are set (they test the other strategies).
  int caustic_paths = 1 << 17;
  // Extra camera rays per sample for the light seen through specular surfaces only (E S+ L: an
  // emitter, or the environment, reached from the camera through smooth glass or mirrors with no
  // other vertex). No connection reaches those paths through a pinhole, so the camera subpath
  // (s = 0) is their only strategy, and a pixel that a small piece of a light's refracted image
  // covers in part is noisy: each of these rays, at its own stratified position in the pixel
  // (a second Sobol sequence of the pixel's samples), follows specular surfaces only and adds
  // those paths' emission, and the sample's own s = 0 term of such a path counts as one of the
  // 1 + specular_view_rays estimates it is averaged with. Taken only in the pixels that
  // non-diffuse triangles may cover (their projected bounds; elsewhere there are no such paths)
  // and only with light tracing on (the box filter); off with only_s / only_t or `unweighted`.
  // 0: none.
  int specular_view_rays = 3;
};

// The smallest BdptSettings::light_paths accepted (smaller shares divide contributions by
// numbers whose reciprocals leave float's range in practice).
inline constexpr float kMinLightPaths = 1e-6f;

// Why `light_paths` is not a valid BdptSettings::light_paths (empty when it is).
std::string check_light_paths(double light_paths);

// Why bdpt cannot render `scene` correctly yet (empty when it can): the caller refuses it.
std::string bdpt_unsupported(const Scene& scene);

// Whether light tracing (t = 1) can reach `camera`: a pinhole, a thin lens and an orthographic
// camera with a lens can; an orthographic camera without one cannot (its direction is a delta, so
// those strategies do not exist: BdptIntegrator turns light tracing off for it).
bool camera_light_tracing(const Camera& camera);

class BdptIntegrator final : public Integrator {
 public:
  // Keeps the scene's emitters (built here): the scene must outlive it. Throws Error when
  // bdpt_unsupported(scene) is not empty.
  BdptIntegrator(const Scene& scene, const BdptSettings& settings = {},
                 const RayOffsetParams& offset = {});

  uint64_t radiance(const SampleBatch& batch, const SampleOutput& out, const Scene& scene,
                    const Accel& accel) const override;

  bool splats() const override { return settings_.light_tracing; }

  // `--light-paths auto`'s pilot (render/bdpt_pilot.h): radiance with each sample's contributions
  // and work going to tally.samples (one per sample of the batch, sized by the caller) instead of
  // the image (no splats are added), for a BdptSettings with light_paths 1; every sample is
  // connected by the general code (camera_only_connect is not used). Calls with distinct tallies
  // may run at once.
  uint64_t pilot_radiance(const SampleBatch& batch, const SampleOutput& out, const Scene& scene,
                          const Accel& accel, LightPathsTally& tally) const;

  const BdptSettings& settings() const { return settings_; }

  // The caustic guide (BdptSettings::caustic_paths), built by its pre-pass on the first call (or
  // the first radiance call) and kept; null where the settings or the scene have none (no
  // emissive triangle, no material other than diffuse, or no photon found). The pre-pass runs on
  // the calling thread's TBB arena (its threads help; the guide is the same for any number).
  const CausticGuide* caustic_guide(const Scene& scene, const Accel& accel) const;

  // The caustic guide's storage (built or not), which integrators of one scene can share: the
  // render job's `--light-paths auto` pilot builds the guide, and the render uses the same one.
  struct GuideSlot;
  std::shared_ptr<GuideSlot> shared_caustic_guide() const { return guide_; }
  // Uses `slot` (another integrator's shared_caustic_guide()) as this one's guide, where the two
  // build the same guide: the same settings for it (caustic_paths, max_depth, ray offsets, the cell
  // from the scene's bounds), and the caller vouches for the same scene and accel. Returns whether
  // it did (otherwise this integrator keeps its own).
  bool use_caustic_guide(const std::shared_ptr<GuideSlot>& slot);

  // An emitter for light subpaths: a point, spot or directional light, an emissive triangle or the
  // environment.
  struct Emitter {
    bool point = false;
    bool spot = false;
    bool directional = false;
    bool environment = false;
    // The triangle (scene numbering), or the index into scene.lights, spot_lights or
    // directional_lights.
    uint32_t prim = 0;
    glm::vec3 position{0.0f};   // a point or spot light's
    glm::vec3 intensity{0.0f};  // a point light's, P / (4 pi); a spot light's on its axis
    float pmf = 0.0f;           // the probability of choosing it
    float area = 0.0f;          // a triangle's
  };

 private:
  BdptSettings settings_;
  RayOffsetParams offset_;
  std::vector<Emitter> emitters_;
  AliasTable table_;
  std::vector<uint32_t> emissive_prims_;  // sorted, for the density of choosing a hit emitter
  std::vector<uint32_t> emissive_index_;  // parallel: the emitter's index in emitters_
  float inverse_light_paths_ = 1.0f;      // 1 / settings_.light_paths
  // The caustic guide, built once (shared by copies of the integrator and use_caustic_guide).
  std::shared_ptr<GuideSlot> guide_;
  bool wants_guide_ = false;  // the settings ask for one and the scene can have caustics
  // The triangles (scene numbering) whose material may be specular (not diffuse, and a Bsdf of
  // delta lobes only or parameter textures), for specular_view_rays' pixels; empty where the
  // settings take no such rays.
  std::vector<uint32_t> specular_prims_;
  // Per material: kMayBeSpecular where it may be specular (as specular_prims_), kViewEmitter
  // where it emits.
  static constexpr uint8_t kMayBeSpecular = 1, kViewEmitter = 2;
  std::vector<uint8_t> view_materials_;
  // The pixels that specular_view_rays' rays are taken in, for the camera they were made for
  // (made again when the camera moves: the viewer keeps its integrator).
  struct SpecularMask;
  struct MaskSlot;
  std::shared_ptr<MaskSlot> mask_;
  std::shared_ptr<const SpecularMask> specular_mask(const Scene& scene) const;

  // radiance, and pilot_radiance with its tally.
  uint64_t trace_batch(const SampleBatch& batch, const SampleOutput& out, const Scene& scene,
                       const Accel& accel, LightPathsTally* tally) const;

  // Appends the scene's spot and directional lights to emitters_ with their selection weights.
  void add_delta_lights(const Scene& scene, std::vector<float>& power);

  // The area density with which a light subpath starts at point of triangle `prim` (pmf / area);
  // 0 for a triangle that is not an emitter.
  float origin_pdf(uint32_t prim) const;

  // The environment (a map, or a constant colour that is not black): its radiance from direction
  // w (pointing away from the scene), the solid-angle density with which light subpaths choose w,
  // and that choice. Light subpaths from it (and from directional lights) start on the disk of
  // radius environment_radius_ about environment_centre_ across w (the scene's bounding sphere),
  // density environment_pdf_pos_.
  glm::vec3 environment_radiance(glm::vec3 w) const;
  float environment_dir_pdf(glm::vec3 w) const;
  glm::vec3 sample_environment(glm::vec2 u, float& pdf) const;
  bool has_environment_ = false;
  bool environment_map_ = false;
  EnvironmentLight environment_;
  glm::vec3 environment_colour_{0.0f};
  float environment_pmf_ = 0.0f;
  float environment_pdf_pos_ = 0.0f;
  glm::vec3 environment_centre_{0.0f};
  float environment_radius_ = 0.0f;

  friend class BdptTracer;
};

// The pixels (y * width + x) that specular surfaces' projected bounds may cover, for `camera`.
struct BdptIntegrator::SpecularMask {
  Camera camera;
  std::vector<uint8_t> pixels;
};
struct BdptIntegrator::MaskSlot {
  std::mutex mutex;
  std::shared_ptr<const SpecularMask> mask;
};

struct BdptIntegrator::GuideSlot {
  std::once_flag once;
  CausticGuide guide;
  // What the guide is a function of, besides the scene and accel (use_caustic_guide compares).
  int paths = 0;
  int max_depth = 0;
  float cell = 0.0f;
  RayOffsetParams offset;
};

}  // namespace tritrace
