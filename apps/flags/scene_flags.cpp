// Registration and conversion of the shared scene flags; the help texts are the user's reference,
// so they name defaults and units.
#include "flags/scene_flags.h"

#include "flags/flag_values.h"

#include <limits>
#include "tritrace/error.h"
#include "tritrace/render/make_integrator.h"
#include "tritrace/scene/io/scene_loader.h"
#include "tritrace/scene/procedural.h"

namespace tritrace::cli {

void add_scene_flags(CLI::App& app, SceneFlags& flags) {
  app.add_option("FILE", flags.file,
                 "Scene (.json) or mesh file (.obj, .ply, .stl, .gltf, .glb, .fbx, .dae, .3ds, "
                 "... anything assimp reads); default: the built-in Cornell box")
      ->type_name("FILE");
  auto side = checked([](std::string& s) { return check_integer_in(s, 1, kMaxImageSide); });
  app.add_option("--width", flags.width,
                 "Image width in pixels, 1 to 16384 (default: the scene's, 500)")
      ->type_name("W")
      ->check(side);
  app.add_option("--height", flags.height,
                 "Image height in pixels, 1 to 16384 (default: the scene's, 500); the built-in "
                 "scene's focal length")
      ->type_name("H")
      ->check(side);
  app.add_option("--scene", flags.scene,
                 std::string("Built-in scene when no FILE is given: ") +
                     std::string(kBuiltinSceneHelp) + " (default cornell)")
      ->type_name("NAME")
      ->check(checked(check_builtin_scene));
  app.add_option("--accel", flags.accel,
                 "Acceleration structure: " + accel_list() +
                     " (brute is the lab's loop over all triangles)")
      ->type_name("NAME")
      ->capture_default_str()
      ->check(checked(check_accel));
  app.add_option("--kernel", flags.kernel,
                 "Ray/triangle intersection: " + kernel_list() +
                     " (default: watertight, which lets no ray through shared edges, for every "
                     "accel; Embree always uses its own)")
      ->type_name("NAME")
      ->check(checked(check_kernel));
  app.add_option(
         "--bvh-build", flags.bvh_build,
         "How bvh and bvh-single build their tree: sah (binned SAH: slower to build, "
         "fastest to trace), morton (Morton codes: 1.6-3.3x faster to build on big meshes, slower "
         "to trace) or auto (morton when the render traces fewer rays than the scene has "
         "triangles, else sah); the image is the same")
      ->type_name("NAME")
      ->capture_default_str()
      ->check(checked([](std::string& s) {
        return s == "auto" || parse_bvh_build(s)
                   ? std::string()
                   : "unknown BVH build '" + s + "' (use auto, sah or morton)";
      }));
  app.add_option("--yaw", flags.yaw,
                 "Orbit the camera about the vertical axis through what it looks at, radians "
                 "(default 0)")
      ->type_name("RAD")
      ->check(checked(check_finite));
  app.add_option("--distance", flags.distance,
                 "Camera distance from the point it looks at, moving it along its line of sight "
                 "(default: the scene's; the built-in scenes' is 3)")
      ->type_name("D")
      ->check(checked(check_distance));
  app.add_option("--light", flags.light,
                 "Position of the (first) point light (default: the scene's; the built-in's is "
                 "0,-0.5,-0.7)")
      ->type_name("X,Y,Z")
      ->check(checked(check_vec3));
  app.add_option("--threads", flags.threads, "Worker threads (default: all cores)")
      ->type_name("N")
      ->check(checked([](std::string& s) { return check_integer_in(s, 1, kMaxThreads); }));
  app.add_option("--integrator", flags.integrator,
                 "lab (the lab's shading: direct light, a shadow ray and a constant indirect term, "
                 "one ray through each pixel corner) or path (unbiased path tracing with "
                 "next-event estimation and MIS); default: the scene's (lab for cornell and "
                 "terrain:*, path for cornell-area, mesh files and scene files that do not say)")
      ->type_name("NAME")
      ->check(checked([](std::string& s) {
        return s == "lab" || s == "path" ? std::string()
                                         : "unknown integrator '" + s + "' (use lab or path)";
      }));
  app.add_option("--spp", flags.spp,
                 "Samples per pixel for path, 1 to 16777216 (default: the scene's, 64)")
      ->type_name("N")
      ->check(checked([](std::string& s) { return check_integer_in(s, 1, kMaxSpp); }));
  app.add_option("--seed", flags.seed,
                 "Seed of the random numbers for path, 0 to 2^63-1 (default: the scene's, 0)")
      ->type_name("N")
      ->check(checked([](std::string& s) {
        return check_integer_in(s, 0, std::numeric_limits<long long>::max());
      }));
  app.add_option("--sampler", flags.sampler,
                 "Random numbers for path: sobol (stratified: Owen-scrambled Sobol points, less "
                 "noise at the same spp) or independent (plain Monte Carlo); default: the scene's, "
                 "sobol")
      ->type_name("NAME")
      ->check(checked([](std::string& s) {
        return parse_sampler(s) ? std::string()
                                : "unknown sampler '" + s + "' (use sobol or independent)";
      }));
  app.add_option("--max-depth", flags.max_depth,
                 "Most bounces of a path, 0 to 65536 (0: only emitters the camera sees, 1: direct "
                 "light only; default: the scene's, 1024, so that Russian roulette ends paths)")
      ->type_name("N")
      ->check(checked([](std::string& s) { return check_integer_in(s, 0, kMaxMaxDepth); }));
  app.add_option("--filter", flags.filter,
                 "Pixel filter for path: box (one pixel), gaussian or blackman-harris (radius 1.5 "
                 "pixels)")
      ->type_name("NAME")
      ->capture_default_str()
      ->check(checked([](std::string& s) {
        return parse_filter(s)
                   ? std::string()
                   : "unknown filter '" + s + "' (use box, gaussian or blackman-harris)";
      }));
}

IntegratorSpec integrator_spec(const SceneFlags& flags, const LoadedScene& loaded) {
  IntegratorSpec spec = loaded.integrator;
  if (!flags.integrator.empty()) {
    spec.kind =
        flags.integrator == "lab" ? IntegratorSpec::Kind::kLab : IntegratorSpec::Kind::kPath;
  }
  if (!flags.spp.empty()) spec.spp = static_cast<uint32_t>(*parse_integer(flags.spp));
  if (!flags.seed.empty()) spec.seed = static_cast<uint64_t>(*parse_integer(flags.seed));
  if (!flags.sampler.empty()) spec.sampler = *parse_sampler(flags.sampler);
  if (!flags.max_depth.empty()) spec.max_depth = static_cast<int>(*parse_integer(flags.max_depth));
  return spec;
}

FilterKind filter_choice(const SceneFlags& flags) {
  return parse_filter(flags.filter).value_or(FilterKind::kBox);
}

SceneOverrides scene_overrides(const SceneFlags& flags) {
  SceneOverrides o;
  if (!flags.width.empty()) o.width = static_cast<int>(*parse_integer(flags.width));
  if (!flags.height.empty()) o.height = static_cast<int>(*parse_integer(flags.height));
  if (!flags.yaw.empty()) o.yaw = *parse_finite(flags.yaw);
  if (!flags.distance.empty()) o.distance = *parse_float(flags.distance);
  if (!flags.light.empty()) o.light = *parse_vec3(flags.light);
  return o;
}

AccelKind accel_kind(const SceneFlags& flags) {
  return *parse_accel(flags.accel);
}

Kernel kernel_choice(const SceneFlags& flags) {
  return flags.kernel.empty() ? default_kernel_for(accel_kind(flags)) : *parse_kernel(flags.kernel);
}

bvh::BuildMethod bvh_build_choice(const SceneFlags& flags, size_t triangles, double rays) {
  if (flags.bvh_build == "auto") return bvh_build_for(triangles, rays);
  return *parse_bvh_build(flags.bvh_build);
}

bvh::BuildMethod bvh_build_choice(const SceneFlags& flags, size_t triangles,
                                  const IntegratorSpec& spec, const Camera& camera) {
  const uint64_t pixels = static_cast<uint64_t>(camera.width()) * camera.height();
  return bvh_build_choice(flags, triangles, expected_rays(spec, pixels));
}

int thread_count(const SceneFlags& flags) {
  return flags.threads.empty() ? 0 : static_cast<int>(*parse_integer(flags.threads));
}

std::string loading_phase(const SceneFlags& flags) {
  if (!flags.file.empty()) return "loading " + flags.file;
  return "making " + (flags.scene.empty() ? std::string("cornell") : flags.scene);
}

std::string building_phase(AccelKind kind, size_t triangles) {
  return "building " + std::string(accel_name(kind)) + " over " + std::to_string(triangles) +
         " triangles";
}

LoadedScene load_scene_from(const SceneFlags& flags, const SceneOverrides& overrides) {
  if (!flags.file.empty() && !flags.scene.empty()) {
    throw Error("--scene", "give either a FILE or --scene, not both", ExitCode::kUsage);
  }
  if (flags.file.empty()) {
    return load_builtin_scene(flags.scene.empty() ? "cornell" : flags.scene, overrides);
  }
  return load_scene(flags.file, overrides);
}

}  // namespace tritrace::cli
