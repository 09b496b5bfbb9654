// The integrator registry.
#include "tritrace/render/make_integrator.h"

#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/path_integrator.h"

namespace tritrace {

std::string_view integrator_name(IntegratorSpec::Kind kind) {
  switch (kind) {
    case IntegratorSpec::Kind::kLab:
      return "lab";
    case IntegratorSpec::Kind::kPath:
      return "path";
    case IntegratorSpec::Kind::kBdpt:
      return "bdpt";
  }
  return "path";
}

std::unique_ptr<Integrator> make_integrator(const IntegratorSpec& spec, const Scene& scene) {
  if (spec.kind == IntegratorSpec::Kind::kLab) return std::make_unique<LabIntegrator>();
  if (spec.kind == IntegratorSpec::Kind::kBdpt) {
    BdptSettings settings;
    settings.max_depth = spec.max_depth;
    settings.light_paths = spec.light_paths;
    return std::make_unique<BdptIntegrator>(scene, settings);
  }
  PathSettings settings;
  settings.max_depth = spec.max_depth;
  settings.clamp_indirect = spec.clamp;
  return std::make_unique<PathIntegrator>(scene, settings);
}

double expected_rays(const IntegratorSpec& spec, uint64_t pixels) {
  const double per_pixel =
      spec.kind != IntegratorSpec::Kind::kLab ? kPathRaysPerSample * spec.spp : 2.0;
  return per_pixel * static_cast<double>(pixels);
}

}  // namespace tritrace
