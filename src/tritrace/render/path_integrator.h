// PathIntegrator: unbiased path tracing of scenes lit by point, spot and directional lights,
// emissive triangles and an environment (a constant colour, or a map sampled as a light). At every
// vertex: next-event estimation (one light chosen by power, one shadow ray) and a bounce sampled
// from the surface's BSDF (cosine-sampled for diffuse), the two combined by multiple importance
// sampling with the power heuristic (Veach 1997) where both can find the light; Russian roulette
// after a few bounces.
// Unbiased unless PathSettings::clamp_indirect is set. The paths of a batch advance together, one
// bounce at a time, so each bounce is one batch query to the accel (traced ray by ray: bounce rays
// are incoherent).
#pragma once

#include <cstdint>
#include <vector>

#include "tritrace/math/offset_ray.h"
#include "tritrace/render/integrator.h"
#include "tritrace/render/light_sampler.h"

namespace tritrace {

struct PathSettings {
  // Path vertices after the camera's: 1 is direct light only (emitters seen by the camera, and
  // light reaching the first hit directly). High by default, so that Russian roulette, not
  // truncation, ends paths: the energy a depth of 1024 drops is below albedo^1024.
  int max_depth = 1024;
  // Bounces before Russian roulette may end a path; after them a path continues with probability
  // min(1, sqrt(max component of its throughput)) and is reweighted by its inverse.
  int roulette_depth = 3;
  // Which strategies find emissive triangles: both, combined by MIS (the default), or one alone
  // (for tests: each alone is unbiased too).
  enum class Strategy { kMis, kLightOnly, kBsdfOnly };
  Strategy strategy = Strategy::kMis;
  // Cycles' "clamp indirect" (0: off). Light is direct when its path scattered at most once, at
  // the first hit: emitters and the environment the camera sees, and light reaching the first hit
  // straight from an emitter (its shadow ray, or its bounce meeting an emitter or escaping to the
  // environment). All else is indirect, through any number of further vertices, specular ones
  // included (so caustics seen on a diffuse surface are indirect). Each sample's indirect sum is
  // scaled down, colour kept, so that its largest channel is at most clamp_indirect. Biased: it
  // removes energy, most of it where fireflies were.
  float clamp_indirect = 0.0f;
};

class PathIntegrator final : public Integrator {
 public:
  // Keeps a reference to the scene's emitters (built here): the scene must outlive it.
  PathIntegrator(const Scene& scene, const PathSettings& settings = {},
                 const RayOffsetParams& offset = {});

  uint64_t radiance(const SampleBatch& batch, const SampleOutput& out, const Scene& scene,
                    const Accel& accel) const override;

  const PathSettings& settings() const { return settings_; }

 private:
  // The path tracer for the scene's kind: kPlainDiffuse leaves out what diffuse scenes without
  // textures, vertex normals or instances never take (the branches cost a few percent per vertex).
  template <bool kPlainDiffuse>
  uint64_t trace(const SampleBatch& batch, const SampleOutput& out, const Scene& scene,
                 const Accel& accel) const;

  PathSettings settings_;
  RayOffsetParams offset_;
  LightSampler lights_;
  bool plain_diffuse_ = false;  // every material diffuse and untextured, flat shading, no instances
  // Per material: whether every lobe of its BSDF is a delta lobe (a perfect mirror, smooth glass),
  // which the albedo and normal AOVs look through.
  std::vector<uint8_t> specular_;
  // A constant environment that emits (no map): light-sampled uniformly over the sphere at every
  // vertex, beside the light the light sampler chooses.
  bool uniform_environment_ = false;
};

}  // namespace tritrace
