// Registration of the shared scene flags (the rules and conversions are the library's,
// tritrace/job/job_settings.h); the help texts are the user's reference,
// so they name defaults and units.
#include "flags/scene_flags.h"

#include "flags/flag_values.h"
#include "tritrace/error.h"
#include "tritrace/scene/procedural.h"

namespace tritrace::cli {
namespace {

// The library's rule for `flag` as the option's validator.
CLI::Validator rule(const char* flag) {
  return checked(setting_check(flag));
}

}  // namespace

void add_scene_flags(CLI::App& app, JobSettings& flags) {
  app.add_option("FILE", flags.file,
                 "Scene (.json) or mesh file (.obj, .ply, .stl, .gltf, .glb, .fbx, .dae, .3ds, "
                 "... anything assimp reads); default: the built-in Cornell box")
      ->type_name("FILE");
  app.add_option("--width", flags.width,
                 "Image width in pixels, 1 to 16384 (default: the scene's, 500)")
      ->type_name("W")
      ->check(rule("--width"));
  app.add_option("--height", flags.height,
                 "Image height in pixels, 1 to 16384 (default: the scene's, 500); the built-in "
                 "scene's focal length")
      ->type_name("H")
      ->check(rule("--height"));
  app.add_option("--scene", flags.scene,
                 std::string("Built-in scene when no FILE is given: ") +
                     std::string(kBuiltinSceneHelp) + " (default cornell)")
      ->type_name("NAME")
      ->check(rule("--scene"));
  app.add_option("--accel", flags.accel,
                 "Acceleration structure: " + accel_list() +
                     " (brute is the lab's loop over all triangles)")
      ->type_name("NAME")
      ->capture_default_str()
      ->check(rule("--accel"));
  app.add_option("--kernel", flags.kernel,
                 "Ray/triangle intersection: " + kernel_list() +
                     " (default: watertight, which lets no ray through shared edges, for every "
                     "accel; Embree always uses its own)")
      ->type_name("NAME")
      ->check(rule("--kernel"));
  app.add_option(
         "--bvh-build", flags.bvh_build,
         "How bvh and bvh-single build their tree: sah (binned SAH: slower to build, "
         "fastest to trace), morton (Morton codes: 1.6-3.3x faster to build on big meshes, slower "
         "to trace) or auto (morton when the render traces fewer rays than the scene has "
         "triangles, else sah); the image is the same")
      ->type_name("NAME")
      ->capture_default_str()
      ->check(rule("--bvh-build"));
  app.add_option("--yaw", flags.yaw,
                 "Orbit the camera about the vertical axis through what it looks at, radians "
                 "(default 0)")
      ->type_name("RAD")
      ->check(rule("--yaw"));
  app.add_option("--distance", flags.distance,
                 "Camera distance from the point it looks at, moving it along its line of sight "
                 "(default: the scene's; the built-in scenes' is 3)")
      ->type_name("D")
      ->check(rule("--distance"));
  app.add_option("--light", flags.light,
                 "Position of the (first) point light (default: the scene's; the built-in's is "
                 "0,-0.5,-0.7)")
      ->type_name("X,Y,Z")
      ->check(rule("--light"));
  app.add_option("--aperture", flags.aperture,
                 "Thin-lens depth of field for path and bdpt: the lens radius in world units "
                 "(default: the scene's, 0, a pinhole)")
      ->type_name("R")
      ->check(rule("--aperture"));
  app.add_option("--focus", flags.focus,
                 "Distance of the plane in focus, along the view direction, with a lens "
                 "(default: the scene's, else the distance to the point the camera looks at)")
      ->type_name("D")
      ->check(rule("--focus"));
  app.add_option("--camera", flags.camera,
                 "Which of a glTF file's cameras to render from: an index in scene-graph order "
                 "(tritrace info lists them) or a node or camera name (default: the first; a "
                 "file without cameras is framed on its bounds)")
      ->type_name("N|NAME")
      ->check(rule("--camera"));
  app.add_option("--threads", flags.threads, "Worker threads (default: all cores)")
      ->type_name("N")
      ->check(rule("--threads"));
  app.add_option("--integrator", flags.integrator,
                 "lab (the lab's shading: direct light, a shadow ray and a constant indirect term, "
                 "one ray through each pixel corner), path (unbiased path tracing with "
                 "next-event estimation and MIS) or bdpt (bidirectional path tracing with light "
                 "tracing, for caustics; docs/BDPT.md); default: the scene's (lab for cornell and "
                 "terrain:*, path for cornell-area, mesh files and scene files that do not say)")
      ->type_name("NAME")
      ->check(rule("--integrator"));
  app.add_option("--spp", flags.spp,
                 "Samples per pixel for path, 1 to 16777216 (default: the scene's, 64)")
      ->type_name("N")
      ->check(rule("--spp"));
  app.add_option("--seed", flags.seed,
                 "Seed of the random numbers for path, 0 to 2^63-1 (default: the scene's, 0)")
      ->type_name("N")
      ->check(rule("--seed"));
  app.add_option("--sampler", flags.sampler,
                 "Random numbers for path: sobol (stratified: Owen-scrambled Sobol points, less "
                 "noise at the same spp) or independent (plain Monte Carlo); default: the scene's, "
                 "sobol")
      ->type_name("NAME")
      ->check(rule("--sampler"));
  app.add_option("--max-depth", flags.max_depth,
                 "Most bounces of a path, 0 to 65536 (0: only emitters the camera sees, 1: direct "
                 "light only; default: the scene's, 1024, so that Russian roulette ends paths)")
      ->type_name("N")
      ->check(rule("--max-depth"));
  app.add_option("--clamp", flags.clamp,
                 "Clamp for path, as Cycles' \"clamp indirect\" (default: off): each sample's "
                 "indirect light (all but emitters and the environment seen directly and the light "
                 "reaching the first hit straight from them) is scaled, keeping its colour, so "
                 "that no channel exceeds VALUE; fewer fireflies, but BIASED: the image loses the "
                 "energy clamped away")
      ->type_name("VALUE")
      ->check(rule("--clamp"));
  app.add_option("--light-paths", flags.light_paths,
                 "Share of bdpt's samples that also trace a light subpath, greater than 0 and at "
                 "most 1 (default: the scene's, auto): the others keep the camera subpath, its "
                 "emitter hits and next-event estimation; the rest is divided by the share, so "
                 "the image stays unbiased; auto: a pilot of 16384 samples chooses it for the "
                 "scene among 1, 1/2, 1/4, ..., 1/64 by estimated variance x counted work, "
                 "the same for every part, thread count and pass of the render (docs/BDPT.md)")
      ->type_name("F|auto")
      ->check(rule("--light-paths"));
  app.add_option("--filter", flags.filter,
                 "Pixel filter for path: box (one pixel), gaussian or blackman-harris (radius 1.5 "
                 "pixels)")
      ->type_name("NAME")
      ->capture_default_str()
      ->check(rule("--filter"));
}

}  // namespace tritrace::cli
