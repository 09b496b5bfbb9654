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
#include "tritrace/scene/scene.h"

namespace tritrace {

inline constexpr size_t kMaxBatch = 256;

// The camera samples of one batch: rays[i] is sample i's camera ray, samplers[i] its random
// numbers, already past the dimensions the camera used (empty for integrators that draw none).
struct SampleBatch {
  std::span<const Ray> rays{};
  std::span<Sampler> samplers{};
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
  // image is each pixel's mean plus the light image over the samples per pixel. Such
  // contributions are estimates over every pixel's samples together, so they need every pixel to
  // take the same samples with the box filter: the renderer refuses adaptive sampling, tile parts
  // and other filters with them.
  virtual bool splats() const { return false; }

  // out.radiance.size() == batch.rays.size() <= kMaxBatch. Returns the number of rays traced
  // (camera and secondary), for the renderer's statistics.
  virtual uint64_t radiance(const SampleBatch& batch, const SampleOutput& out, const Scene& scene,
                            const Accel& accel) const = 0;
};

}  // namespace tritrace
