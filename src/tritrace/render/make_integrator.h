// Choosing an integrator from a scene's settings: the one factory that render, bench and the viewer
// call, so every front end shades alike.
#pragma once

#include <memory>
#include <string_view>

#include "tritrace/render/integrator.h"
#include "tritrace/scene/io/loaded_scene.h"

namespace tritrace {

std::string_view integrator_name(IntegratorSpec::Kind kind);  // "lab", "path"

// The integrator `spec` names for `scene`, which must outlive it (the path tracer keeps the
// scene's emitters).
std::unique_ptr<Integrator> make_integrator(const IntegratorSpec& spec, const Scene& scene);

}  // namespace tritrace
