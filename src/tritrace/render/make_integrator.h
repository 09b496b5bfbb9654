// Choosing an integrator from a scene's settings: the one factory that render, bench and the viewer
// call, so every front end shades alike.
#pragma once

#include <cstdint>
#include <memory>
#include <string_view>

#include "tritrace/render/integrator.h"
#include "tritrace/scene/integrator_spec.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

std::string_view integrator_name(IntegratorSpec::Kind kind);  // "lab", "path", "bdpt"

// The integrator `spec` names for `scene`, which must outlive it (the path tracer keeps the
// scene's emitters).
std::unique_ptr<Integrator> make_integrator(const IntegratorSpec& spec, const Scene& scene);

// About how many rays a render of `pixels` pixels with `spec` traces: the lab's primary and
// shadow ray per pixel; for the path tracer a camera ray and on average about two bounces with a
// shadow ray each per sample (kPathRaysPerSample, measured on the example scenes). An estimate for
// choices that trade set-up time for tracing speed, never a limit.
inline constexpr double kPathRaysPerSample = 5.0;
double expected_rays(const IntegratorSpec& spec, uint64_t pixels);

}  // namespace tritrace
