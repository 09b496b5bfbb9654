// The info subcommand: one "key: value" line per fact, so that people and scripts can read it.
#include "info_command.h"

#include <cmath>
#include <cstdio>
#include <numbers>

#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/render/make_integrator.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace::cli {
namespace {

std::string vec(glm::vec3 v) {
  char text[96];
  std::snprintf(text, sizeof text, "(%g, %g, %g)", v.x, v.y, v.z);
  return text;
}

}  // namespace

CLI::App* add_info_command(CLI::App& app, InfoArgs& args) {
  CLI::App* sub =
      app.add_subcommand("info",
                         "Load a scene (.json or .pbrt) or mesh file as render would and print "
                         "what it holds; for a partial film (.exr from render --spp-range / "
                         "--tile) print its render and part");
  sub->add_option("FILE", args.file,
                  "Scene (.json or .pbrt), mesh file (any format assimp reads) or partial film "
                  "(.exr); default: built-in cornell")
      ->type_name("FILE");
  return sub;
}

int run_info(const InfoArgs& args) {
  // A partial film (render --spp-range / --tile) prints its metadata: which render, which part.
  if (args.file.size() > 4 && args.file.compare(args.file.size() - 4, 4, ".exr") == 0) {
    const PartInfo info = read_part_info(args.file);
    std::printf("file: %s\n%s", args.file.c_str(), describe_part(info).c_str());
    return 0;
  }
  const LoadedScene loaded =
      args.file.empty() ? load_builtin_scene("cornell") : load_scene(args.file);
  for (const std::string& w : loaded.warnings) std::fprintf(stderr, "tritrace: %s\n", w.c_str());
  const Scene& s = loaded.scene;
  const Bounds3 b = scene_bounds(s);
  std::printf("file: %s\n", args.file.empty() ? "(built-in cornell)" : args.file.c_str());
  std::printf("triangles: %llu\n", static_cast<unsigned long long>(s.drawn_triangles()));
  if (s.has_instances()) {
    // Drawn counts every placement; stored counts each prototype once (what memory holds).
    std::printf("instances: %zu of %zu instanced meshes\n", s.instances.size(),
                s.prototypes.size());
    std::printf("triangles stored: %llu\n", static_cast<unsigned long long>(s.stored_triangles()));
  }
  std::printf("meshes: %zu\n", loaded.stats.meshes);
  std::printf("materials: %zu\n", s.materials.size());
  std::printf("bounds: %s to %s\n", vec(b.lo).c_str(), vec(b.hi).c_str());
  std::printf("lights: %zu\n",
              s.lights.size() + s.spot_lights.size() + s.directional_lights.size());
  for (const PointLight& l : s.lights) {
    std::printf("  light at %s, power %s\n", vec(l.position).c_str(), vec(l.power).c_str());
  }
  for (const SpotLight& l : s.spot_lights) {
    std::printf("  spot light at %s towards %s, intensity %s, cone %g to %g degrees\n",
                vec(l.position).c_str(), vec(l.direction).c_str(), vec(l.intensity).c_str(),
                std::acos(static_cast<double>(l.cos_inner)) * 180.0 / std::numbers::pi,
                std::acos(static_cast<double>(l.cos_outer)) * 180.0 / std::numbers::pi);
  }
  for (const DirectionalLight& l : s.directional_lights) {
    std::printf("  directional light towards %s, irradiance %s\n", vec(l.direction).c_str(),
                vec(l.irradiance).c_str());
  }
  auto emissive_in = [&](const TriangleMesh& m) {
    unsigned long long n = 0;
    for (size_t i = 0; i < m.size(); ++i) n += s.materials[m.material()[i]].emits();
    return n;
  };
  unsigned long long emissive = emissive_in(s.mesh);
  for (const Instance& inst : s.instances) emissive += emissive_in(s.prototypes[inst.prototype]);
  std::printf("emissive triangles: %llu\n", emissive);
  std::printf("ambient: %s\n", vec(s.ambient).c_str());
  const IntegratorSpec& spec = loaded.integrator;
  if (spec.kind == IntegratorSpec::Kind::kLab) {
    std::printf("integrator: lab\n");
  } else {
    std::printf("integrator: %s, %u spp, max depth %d, %s sampler, seed %llu\n",
                std::string(integrator_name(spec.kind)).c_str(), spec.spp, spec.max_depth,
                std::string(sampler_name(spec.sampler)).c_str(),
                static_cast<unsigned long long>(spec.seed));
  }
  const Camera& c = s.camera;
  if (c.is_orthographic()) {
    std::printf("camera: %dx%d at %s, orthographic, %g units per pixel", c.width(), c.height(),
                vec(c.position()).c_str(), c.ortho_scale());
  } else {
    std::printf("camera: %dx%d at %s, focal length %g px", c.width(), c.height(),
                vec(c.position()).c_str(), c.focal_px());
  }
  if (c.has_lens()) {
    std::printf(", lens radius %g focused at %g", c.lens_radius(), c.focus_distance());
  }
  std::printf("\n");
  // A glTF file's own cameras, the one rendered by default marked.
  for (size_t i = 0; i < loaded.cameras.size(); ++i) {
    const FileCamera& fc = loaded.cameras[i];
    std::printf("camera %zu%s%s%s: %s%s\n", i, fc.name.empty() ? "" : " '", fc.name.c_str(),
                fc.name.empty() ? "" : "'", fc.description.c_str(),
                static_cast<int>(i) == loaded.camera_index ? " (rendered)" : "");
  }
  std::printf("dropped: %zu degenerate, %zu non-finite triangles\n",
              loaded.stats.dropped_degenerate, loaded.stats.dropped_non_finite);
  if (!loaded.output.empty()) std::printf("output: %s\n", loaded.output.c_str());
  return 0;
}

}  // namespace tritrace::cli
