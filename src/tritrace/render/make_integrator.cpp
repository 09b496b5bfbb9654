// The integrator registry.
#include "tritrace/render/make_integrator.h"

#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/path_integrator.h"

namespace tritrace {

std::string_view integrator_name(IntegratorSpec::Kind kind) {
  return kind == IntegratorSpec::Kind::kLab ? "lab" : "path";
}

std::unique_ptr<Integrator> make_integrator(const IntegratorSpec& spec, const Scene& scene) {
  if (spec.kind == IntegratorSpec::Kind::kLab) return std::make_unique<LabIntegrator>();
  PathSettings settings;
  settings.max_depth = spec.max_depth;
  settings.clamp_indirect = spec.clamp;
  return std::make_unique<PathIntegrator>(scene, settings);
}

double expected_rays(const IntegratorSpec& spec, uint64_t pixels) {
  const double per_pixel =
      spec.kind == IntegratorSpec::Kind::kPath ? kPathRaysPerSample * spec.spp : 2.0;
  return per_pixel * static_cast<double>(pixels);
}

}  // namespace tritrace
