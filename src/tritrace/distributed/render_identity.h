// The identity of a render: a hash of everything that changes its pixels (the scene's data, every
// pixel-changing setting and the build), so that parts of different renders never merge.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "tritrace/render/film.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/integrator_spec.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// Two parts merge only when their identities are equal.
struct RenderIdentity {
  std::string hash;      // 16 hex digits over the scene's data, `settings` and `build`
  std::string settings;  // "integrator=path spp=64 ...", every pixel-changing setting
  std::string build;     // build_text(): version, commit and SIMD width
  std::string integrator;
  uint64_t seed = 0;
  uint32_t spp = 1;  // the render's total samples per pixel (1 for the lab integrator)
  int width = 0;
  int height = 0;
  AovSet aovs;

  bool operator==(const RenderIdentity& o) const {
    return hash == o.hash && settings == o.settings && build == o.build && aovs == o.aovs;
  }
};

// What decides which triangle a ray hits: the kernel for the accels tritrace implements (brute,
// bvh and bvh-single report the same hits with one kernel, so their images are byte-identical
// and their parts merge), Embree's own intersection (named by its accel) otherwise.
std::string hit_rule(std::string_view accel, std::string_view kernel);

// The identity of rendering `scene` with `spec` and `options` through the named accel and kernel
// in this build.
RenderIdentity render_identity(const Scene& scene, const IntegratorSpec& spec,
                               const RenderOptions& options, std::string_view accel,
                               std::string_view kernel, const AovSet& aovs);

// "albedo,normal" (empty for none): the AOVs as partial films and messages name them.
std::string aov_list(const AovSet& aovs);

// What differs between two identities, for messages: "build version=... commit=..." or
// "settings ..." or "scene data (render 1f..., not 32...)"; empty when they are equal.
std::string identity_difference(const RenderIdentity& a, const RenderIdentity& b);

}  // namespace tritrace
