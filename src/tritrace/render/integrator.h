// Integrator: turns a batch of camera samples into radiance. A batch is one tile at one sample
// index, at most kMaxBatch rays, so integrators keep their working memory on the stack and never
// allocate while rendering; the virtual call happens once per batch.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <span>

#include "tritrace/accel/accel.h"
#include "tritrace/render/film.h"
#include "tritrace/render/sampler.h"
#include "tritrace/render/splat_pass.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

inline constexpr size_t kMaxBatch = 256;

// The camera samples of one batch: rays[i] is sample i's camera ray, samplers[i] its random
// numbers, already past the dimensions the camera used (empty for integrators that draw none).
struct SampleBatch {
  std::span<const Ray> rays{};
  std::span<Sampler> samplers{};
  // pixels[i] is sample i's pixel (y * width + x); given to integrators that splat (may be empty
  // for others).
  std::span<const uint32_t> pixels{};
};

// Where an integrator writes: radiance always; the AOVs when their spans are not empty: albedo and
// normal (world space, facing the ray) of the first hit (lab: geometric normal) or of the first
// non-specular hit (path: path_integrator.cpp), depth the distance along the camera ray to the
// first hit; zero where the ray escapes.
struct SampleOutput {
  std::span<glm::vec3> radiance{};
  std::span<glm::vec3> albedo{};
  std::span<glm::vec3> normal{};
  std::span<float> depth{};
  // The film's light image, for integrators whose splats() is true (never null for them): the
  // contributions that land on other pixels (Integrator::splats).
  SplatBuffer* splats = nullptr;
  // With adaptive sampling, the pass's light-tracing counts (SplatPass); null when every pixel
  // takes every sample.
  const SplatPass* pass = nullptr;
};

// Fills out's AOV spans (those not empty) from the camera rays' first hits: the hit material's
// albedo (its texture's value at the hit where it has one), the geometric normal facing the ray,
// and the distance t; zero where a ray escapes.
void write_first_hit_aovs(const Scene& scene, std::span<const Ray> rays, std::span<const Hit> hits,
                          const SampleOutput& out);

class Integrator {
 public:
  virtual ~Integrator() = default;

  // True for the lab's integrator: one deterministic sample through each pixel's corner, no random
  // numbers. Otherwise the renderer places samples over the pixel with the film's filter.
  virtual bool pixel_corner_only() const { return false; }

  // True for an integrator that also adds to other pixels than the sample's own (bdpt's light
  // tracing): the renderer then gives it the film's SplatBuffer in SampleOutput::splats, and the
  // image is each pixel's mean plus the light image over the pixel's sample count. Such
  // contributions are estimates over every pixel's samples together: the renderer refuses tile
  // parts and filters other than the box with them, and renders adaptive sampling pass by pass
  // with each pass's counts in SampleOutput::pass.
  virtual bool splats() const { return false; }

  // out.radiance.size() == batch.rays.size() <= kMaxBatch. Returns the number of rays traced
  // (camera and secondary), for the renderer's statistics.
  virtual uint64_t radiance(const SampleBatch& batch, const SampleOutput& out, const Scene& scene,
                            const Accel& accel) const = 0;
};

}  // namespace tritrace
