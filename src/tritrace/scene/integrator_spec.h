// How a scene asks to be rendered: a scene file's "integrator" object, or a built-in scene's own
// choice (the lab's scenes the lab integrator, the others the path tracer). Like the camera, it is
// part of what a scene says; a render job applies the user's settings over it.
#pragma once

#include <cstdint>

#include "tritrace/math/random.h"

namespace tritrace {

inline constexpr uint32_t kDefaultSpp = 64;
inline constexpr uint32_t kMaxSpp = 1u << 24;
inline constexpr int kDefaultMaxDepth = 1024;
inline constexpr int kMaxMaxDepth = 1 << 16;

struct IntegratorSpec {
  // kBdpt: the bidirectional path tracer (render/bdpt_integrator.h), physically based like kPath.
  enum class Kind { kLab, kPath, kBdpt };
  Kind kind = Kind::kPath;
  uint32_t spp = kDefaultSpp;
  int max_depth = kDefaultMaxDepth;
  uint64_t seed = 0;
  SamplerKind sampler = SamplerKind::kSobol;
  // The path tracer's clamp on each sample's indirect light (PathSettings::clamp_indirect); 0: off.
  float clamp = 0.0f;
  // bdpt's share of camera samples that also trace a light subpath (BdptSettings::light_paths),
  // in (0, 1]; 1: every sample.
  float light_paths = 1.0f;
  // `--light-paths auto`, bdpt's default: the render job runs a pilot (render/bdpt_pilot.h) that
  // chooses light_paths for the scene before it renders; false: light_paths as set.
  bool light_paths_auto = true;
};

}  // namespace tritrace
