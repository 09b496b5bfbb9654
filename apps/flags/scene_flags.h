// The flags that choose a scene and its view (FILE, --scene, --accel, --kernel, --width, --height,
// --bvh-build, --yaw, --distance, --light, --threads), shared by `tritrace render` and
// `tritrace-view` so that both accept the same values with the same messages and build the same
// Scene from them.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "tritrace/accel/make_accel.h"
#include "tritrace/geometry/intersect.h"
#include "tritrace/render/film.h"
#include "tritrace/scene/camera.h"
#include "tritrace/scene/io/loaded_scene.h"

namespace tritrace::cli {

// The raw texts, checked by the validators add_scene_flags installs; empty means not given.
struct SceneFlags {
  std::string file;  // empty: a built-in scene
  std::string width;
  std::string height;
  std::string scene;  // a built-in scene name; empty: cornell
  std::string accel = "bvh";
  std::string kernel;  // empty: the accel's default kernel
  std::string bvh_build = "auto";
  std::string yaw;
  std::string distance;
  std::string light;
  std::string threads;  // empty: all cores
  // How to render (empty: the scene's own choice, see IntegratorSpec).
  std::string integrator;
  std::string spp;
  std::string seed;
  std::string sampler;
  std::string max_depth;
  std::string filter = "box";
};

void add_scene_flags(CLI::App& app, SceneFlags& flags);

// The parsed values; call only after a successful parse (the validators have run).
SceneOverrides scene_overrides(const SceneFlags& flags);
AccelKind accel_kind(const SceneFlags& flags);
Kernel kernel_choice(const SceneFlags& flags);
// --bvh-build: sah or morton as given; auto: bvh_build_for(triangles, rays).
bvh::BuildMethod bvh_build_choice(const SceneFlags& flags, size_t triangles, double rays);
// The same for one render of `camera`'s image with `spec` (expected_rays).
bvh::BuildMethod bvh_build_choice(const SceneFlags& flags, size_t triangles,
                                  const IntegratorSpec& spec, const Camera& camera);
int thread_count(const SceneFlags& flags);  // 0: all cores
// The scene's integrator settings with the flags given applied over them.
IntegratorSpec integrator_spec(const SceneFlags& flags, const LoadedScene& loaded);
FilterKind filter_choice(const SceneFlags& flags);

// What the CLI's phase line and the viewer's loading window say while the scene loads ("making
// cornell", "loading model.ply") and while its accel builds ("building bvh over 1000000
// triangles").
std::string loading_phase(const SceneFlags& flags);
std::string building_phase(AccelKind kind, size_t triangles);

// The built-in scene or FILE with `overrides`. Throws Error (usage) when both FILE and --scene are
// given, and whatever load_scene throws.
LoadedScene load_scene_from(const SceneFlags& flags, const SceneOverrides& overrides);

}  // namespace tritrace::cli
