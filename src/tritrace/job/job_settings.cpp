// The settings' rules and conversions: the one place that says which texts a render accepts.
#include "tritrace/job/job_settings.h"

#include <limits>

#include "tritrace/error.h"
#include "tritrace/job/setting_values.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/make_integrator.h"
#include "tritrace/scene/io/scene_loader.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

std::string check_side(const std::string& s) {
  return check_integer_in(s, 1, kMaxImageSide);
}
std::string check_threads(const std::string& s) {
  return check_integer_in(s, 1, kMaxThreads);
}
std::string check_spp(const std::string& s) {
  return check_integer_in(s, 1, kMaxSpp);
}
std::string check_seed(const std::string& s) {
  return check_integer_in(s, 0, std::numeric_limits<long long>::max());
}
std::string check_max_depth(const std::string& s) {
  return check_integer_in(s, 0, kMaxMaxDepth);
}
std::string check_bvh_build_or_auto(const std::string& s) {
  return s == "auto" || parse_bvh_build(s)
             ? std::string()
             : "unknown BVH build '" + s + "' (use auto, sah or morton)";
}
std::string check_integrator(const std::string& s) {
  return s == "lab" || s == "path" || s == "bdpt"
             ? std::string()
             : "unknown integrator '" + s + "' (use lab, path or bdpt)";
}
std::string check_sampler(const std::string& s) {
  return parse_sampler(s) ? std::string()
                          : "unknown sampler '" + s + "' (use sobol or independent)";
}
std::string check_filter(const std::string& s) {
  return parse_filter(s) ? std::string()
                         : "unknown filter '" + s + "' (use box, gaussian or blackman-harris)";
}
std::string check_aovs(const std::string& s) {
  std::string why;
  return parse_aovs(s, &why) ? std::string() : why;
}
std::string check_exposure(const std::string& s) {
  return parse_float(s) ? std::string() : "must be a finite number, got '" + s + "'";
}

// A year: any longer is a mistake, and the seconds stay exact as a double's milliseconds.
constexpr double kMaxTimeLimitSeconds = 365.0 * 24 * 3600;
std::string check_time_limit(const std::string& s) {
  const std::optional<double> t = parse_finite(s);
  if (t && *t > 0.0 && *t <= kMaxTimeLimitSeconds) return "";
  return "must be a number of seconds greater than 0 and at most " +
         format_double(kMaxTimeLimitSeconds) + ", got '" + s + "'";
}

std::string check_aperture(const std::string& s) {
  const std::optional<float> v = parse_float(s);
  return v && *v >= 0.0f ? std::string()
                         : "must be a lens radius, a finite number of at least 0, got '" + s + "'";
}
std::string check_camera(const std::string& s) {
  return s.empty() ? "must be a camera's index or name" : std::string();
}

std::string check_clamp(const std::string& s) {
  const std::optional<float> v = parse_float(s);
  return v && *v > 0.0f ? std::string() : "must be a finite number greater than 0, got '" + s + "'";
}

std::string check_light_paths_text(const std::string& s) {
  if (s == "auto") return "";
  const std::optional<float> v = parse_float(s);
  return v && *v > 0.0f && *v <= 1.0f && check_light_paths(*v).empty()
             ? std::string()
             : "must be auto or the share of samples that trace a light subpath, greater than 0 "
               "(at least 1e-6) and at most 1, got '" +
                   s + "'";
}

// A relative error: above 0, and below 1 (an error of 100% or more stops every pixel at the
// first check, which is not what anyone means).
std::string check_noise_threshold(const std::string& s) {
  const std::optional<double> t = parse_finite(s);
  if (t && *t > 0.0 && *t < 1.0 && static_cast<float>(*t) > 0.0f) return "";
  return "must be a relative error greater than 0 and less than 1 (for example 0.01), got '" + s +
         "'";
}

constexpr SettingRule kRules[] = {
    {"--scene", &JobSettings::scene, check_builtin_scene},
    {"--width", &JobSettings::width, check_side},
    {"--height", &JobSettings::height, check_side},
    {"--yaw", &JobSettings::yaw, check_finite},
    {"--distance", &JobSettings::distance, check_distance},
    {"--light", &JobSettings::light, check_vec3},
    {"--aperture", &JobSettings::aperture, check_aperture},
    {"--focus", &JobSettings::focus, check_distance},
    {"--camera", &JobSettings::camera, check_camera},
    {"--accel", &JobSettings::accel, check_accel},
    {"--kernel", &JobSettings::kernel, check_kernel},
    {"--bvh-build", &JobSettings::bvh_build, check_bvh_build_or_auto},
    {"--threads", &JobSettings::threads, check_threads},
    {"--integrator", &JobSettings::integrator, check_integrator},
    {"--spp", &JobSettings::spp, check_spp},
    {"--seed", &JobSettings::seed, check_seed},
    {"--sampler", &JobSettings::sampler, check_sampler},
    {"--max-depth", &JobSettings::max_depth, check_max_depth},
    {"--clamp", &JobSettings::clamp, check_clamp},
    {"--light-paths", &JobSettings::light_paths, check_light_paths_text},
    {"--filter", &JobSettings::filter, check_filter},
    {"--time-limit", &JobSettings::time_limit, check_time_limit},
    {"--noise-threshold", &JobSettings::noise_threshold, check_noise_threshold},
    {"--aovs", &JobSettings::aovs, check_aovs},
    {"--exposure", &JobSettings::exposure, check_exposure},
};

}  // namespace

std::span<const SettingRule> setting_rules() {
  return kRules;
}

auto setting_check(std::string_view flag) -> std::string (*)(const std::string&) {
  for (const SettingRule& rule : kRules) {
    if (flag == rule.flag) return rule.check;
  }
  return nullptr;
}

void check_settings(const JobSettings& settings) {
  for (const SettingRule& rule : kRules) {
    const std::string& text = settings.*rule.text;
    if (text.empty()) continue;
    const std::string why = rule.check(text);
    if (!why.empty()) throw Error(rule.flag, why, ExitCode::kUsage);
  }
}

bool add_aov(std::string_view name, AovSet* set) {
  if (name == "albedo") {
    set->albedo = true;
  } else if (name == "normal") {
    set->normal = true;
  } else if (name == "depth") {
    set->depth = true;
  } else if (name == "variance") {
    set->variance = true;
  } else if (name == "spp") {
    set->spp = true;
  } else {
    return false;
  }
  return true;
}

std::optional<AovSet> parse_aovs(const std::string& text, std::string* why) {
  AovSet set;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    const std::string name =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (!add_aov(name, &set)) {
      *why = (name.empty() ? std::string("empty AOV name") : "unknown AOV '" + name + "'") +
             " in '" + text +
             "' (use a comma-separated list of albedo, normal, depth, variance, spp)";
      return std::nullopt;
    }
    if (comma == std::string::npos) return set;
    start = comma + 1;
  }
}

SceneOverrides scene_overrides(const JobSettings& settings) {
  SceneOverrides o;
  if (!settings.width.empty()) o.width = static_cast<int>(*parse_integer(settings.width));
  if (!settings.height.empty()) o.height = static_cast<int>(*parse_integer(settings.height));
  if (!settings.yaw.empty()) o.yaw = *parse_finite(settings.yaw);
  if (!settings.distance.empty()) o.distance = *parse_float(settings.distance);
  if (!settings.light.empty()) o.light = *parse_vec3(settings.light);
  if (!settings.aperture.empty()) o.aperture = *parse_float(settings.aperture);
  if (!settings.focus.empty()) o.focus = *parse_float(settings.focus);
  o.camera = settings.camera;
  return o;
}

AccelKind accel_kind(const JobSettings& settings) {
  return *parse_accel(settings.accel);
}

Kernel kernel_choice(const JobSettings& settings) {
  return settings.kernel.empty() ? default_kernel_for(accel_kind(settings))
                                 : *parse_kernel(settings.kernel);
}

bvh::BuildMethod bvh_build_choice(const JobSettings& settings, size_t triangles, double rays) {
  if (settings.bvh_build == "auto") return bvh_build_for(triangles, rays);
  return *parse_bvh_build(settings.bvh_build);
}

int thread_count(const JobSettings& settings) {
  return settings.threads.empty() ? 0 : static_cast<int>(*parse_integer(settings.threads));
}

IntegratorSpec integrator_spec(const JobSettings& settings, const IntegratorSpec& scene_spec) {
  IntegratorSpec spec = scene_spec;
  if (!settings.integrator.empty()) {
    spec.kind = settings.integrator == "lab"    ? IntegratorSpec::Kind::kLab
                : settings.integrator == "bdpt" ? IntegratorSpec::Kind::kBdpt
                                                : IntegratorSpec::Kind::kPath;
  }
  if (!settings.spp.empty()) spec.spp = static_cast<uint32_t>(*parse_integer(settings.spp));
  if (!settings.seed.empty()) spec.seed = static_cast<uint64_t>(*parse_integer(settings.seed));
  if (!settings.sampler.empty()) spec.sampler = *parse_sampler(settings.sampler);
  if (!settings.max_depth.empty()) {
    spec.max_depth = static_cast<int>(*parse_integer(settings.max_depth));
  }
  if (!settings.clamp.empty()) spec.clamp = *parse_float(settings.clamp);
  if (settings.light_paths == "auto") {
    spec.light_paths = 1.0f;
    spec.light_paths_auto = true;
  } else if (!settings.light_paths.empty()) {
    spec.light_paths = *parse_float(settings.light_paths);
    spec.light_paths_auto = false;
  }
  return spec;
}

FilterKind filter_choice(const JobSettings& settings) {
  return parse_filter(settings.filter).value_or(FilterKind::kBox);
}

AovSet aov_set(const JobSettings& settings) {
  if (settings.aovs.empty()) return {};
  std::string why;
  return parse_aovs(settings.aovs, &why).value_or(AovSet{});
}

std::optional<float> exposure_stops(const JobSettings& settings) {
  if (settings.exposure.empty()) return std::nullopt;
  return parse_float(settings.exposure);
}

std::optional<double> time_limit_seconds(const JobSettings& settings) {
  if (settings.time_limit.empty()) return std::nullopt;
  return parse_finite(settings.time_limit);
}

float noise_threshold(const JobSettings& settings) {
  if (settings.noise_threshold.empty()) return 0.0f;
  return static_cast<float>(parse_finite(settings.noise_threshold).value_or(0.0));
}

std::string loading_phase(const JobSettings& settings) {
  if (!settings.file.empty()) return "loading " + settings.file;
  return "making " + (settings.scene.empty() ? std::string("cornell") : settings.scene);
}

std::string building_phase(AccelKind kind, size_t triangles) {
  return "building " + std::string(accel_name(kind)) + " over " + std::to_string(triangles) +
         " triangles";
}

LoadedScene load_job_scene(const JobSettings& settings) {
  if (!settings.file.empty() && !settings.scene.empty()) {
    throw Error("--scene", "give either a FILE or --scene, not both", ExitCode::kUsage);
  }
  const SceneOverrides overrides = scene_overrides(settings);
  if (settings.file.empty()) {
    return load_builtin_scene(settings.scene.empty() ? "cornell" : settings.scene, overrides);
  }
  return load_scene(settings.file, overrides);
}

}  // namespace tritrace
