// The settings of one render as a user gives them: texts, as flag values or as the Python module's
// arguments written the way the flag would be, empty when not given. Each setting has one checker
// here, which the CLI installs as its flag's validator and the Python module runs on its
// arguments, so that every front end accepts the same values and refuses the others with the same
// reason; the conversions below read the checked texts.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "tritrace/accel/make_accel.h"
#include "tritrace/geometry/intersect.h"
#include "tritrace/render/film.h"
#include "tritrace/scene/integrator_spec.h"
#include "tritrace/scene/io/loaded_scene.h"

namespace tritrace {

struct JobSettings {
  // The scene and its view.
  std::string file;   // a scene or mesh file; empty: a built-in scene
  std::string scene;  // a built-in scene's name; empty: cornell
  std::string width;
  std::string height;
  std::string yaw;
  std::string distance;
  std::string light;
  std::string aperture;  // the thin lens's radius in world units; empty: the scene's (a pinhole)
  std::string focus;     // the distance of the plane in focus; empty: the scene's, else look_at's
  std::string camera;    // which of a glTF file's cameras: an index or a name; empty: the first
  // How to trace.
  std::string accel = "bvh";
  std::string kernel;  // empty: the accel's default kernel
  std::string bvh_build = "auto";
  std::string threads;  // empty: all cores
  // How to render (empty: the scene's own choice, see IntegratorSpec).
  std::string integrator;
  std::string spp;
  std::string seed;
  std::string sampler;
  std::string max_depth;
  std::string clamp;        // the path tracer's clamp on each sample's indirect light; empty: off
  std::string light_paths;  // bdpt's share of samples with a light subpath; empty: the scene's
  std::string filter = "box";
  std::string time_limit;  // seconds: whole passes of samples until the time is up
  bool denoise = false;    // the feature-guided denoiser on the path tracer's image
  // Adaptive sampling: a pixel stops when the relative error of its mean is below this (0 < T < 1)
  std::string noise_threshold;
  // What to write.
  std::string output;         // empty: the scene file's output, else <file stem>.png
  bool output_given = false;  // the caller named an output (its value may still be empty)
  std::string aovs;           // "albedo,normal,depth,variance,spp" or a subset
  bool exr_half = false;
  std::string exposure;   // stops, for the path tracer's 8-bit outputs
  std::string spp_range;  // "A:B": samples [A, B) of every pixel, as a partial film
  std::string tile;       // "I/N": tile part I of N, as a partial film
};

// One setting's flag name ("--spp"), its text in JobSettings, and its checker ("" when the text
// is fine, else the reason). Every text setting of JobSettings is in the table.
struct SettingRule {
  const char* flag;
  std::string JobSettings::*text;
  std::string (*check)(const std::string& text);
};
std::span<const SettingRule> setting_rules();
// The checker of `flag` ("--spp"); nullptr for a flag with no rule.
auto setting_check(std::string_view flag) -> std::string (*)(const std::string&);

// Runs every rule on the settings given (non-empty texts); throws Error(flag, reason, kUsage) at
// the first that fails. The CLI's validators have already run them; the Python module calls this.
void check_settings(const JobSettings& settings);

// The conversions, for checked settings.
SceneOverrides scene_overrides(const JobSettings& settings);
AccelKind accel_kind(const JobSettings& settings);
Kernel kernel_choice(const JobSettings& settings);
// --bvh-build: sah or morton as given; auto: bvh_build_for(triangles, rays).
bvh::BuildMethod bvh_build_choice(const JobSettings& settings, size_t triangles, double rays);
int thread_count(const JobSettings& settings);  // 0: all cores
// The scene's integrator settings with the settings given applied over them.
IntegratorSpec integrator_spec(const JobSettings& settings, const IntegratorSpec& scene_spec);
FilterKind filter_choice(const JobSettings& settings);
AovSet aov_set(const JobSettings& settings);
std::optional<float> exposure_stops(const JobSettings& settings);
std::optional<double> time_limit_seconds(const JobSettings& settings);
// --noise-threshold's value; 0 when not given (adaptive sampling off).
float noise_threshold(const JobSettings& settings);

// Adds the AOV `name` (albedo, normal, depth, variance or spp) to `set`; false for any other name.
bool add_aov(std::string_view name, AovSet* set);
// "albedo,normal,depth,variance,spp" or any subset, in any order; a name given twice counts once.
// nullopt with the reason in `why` for an empty list, an empty name or an unknown one.
std::optional<AovSet> parse_aovs(const std::string& text, std::string* why);

// What the CLI's phase line and the viewer's loading window say while the scene loads ("making
// cornell", "loading model.ply") and while its accel builds ("building bvh over 1000000
// triangles").
std::string loading_phase(const JobSettings& settings);
std::string building_phase(AccelKind kind, size_t triangles);

// The built-in scene or the file with the view settings applied. Throws Error (usage) when both a
// file and a built-in scene are given, and whatever load_scene throws.
LoadedScene load_job_scene(const JobSettings& settings);

}  // namespace tritrace
