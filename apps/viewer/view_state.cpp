// Time-based motion of the view and the command line that reproduces it.
#include "view_state.h"

#include <algorithm>
#include <glm/geometric.hpp>

#include "tritrace/job/setting_values.h"
#include "tritrace/render/make_integrator.h"

namespace tritrace::view {

Motion motion_from(const HeldKeys& k) {
  Motion m;
  m.turn = int{k.left} - int{k.right};
  m.approach = int{k.up} - int{k.down};
  m.light = glm::ivec3(int{k.d} - int{k.a}, int{k.e} - int{k.q}, int{k.w} - int{k.s});
  return m;
}

MotionRates MotionRates::for_distance(float start_distance) {
  MotionRates r;
  const double scale = static_cast<double>(start_distance) / 3.0;  // the lab's camera distance
  r.distance_per_second = scale;
  r.light_per_second = scale;
  r.min_distance = start_distance / 100.0f;
  return r;
}

ViewState advance(const ViewState& state, const Motion& motion, double seconds,
                  const MotionRates& rates) {
  ViewState next = state;
  next.yaw += motion.turn * rates.yaw_per_second * seconds;
  if (motion.approach != 0) {
    const double d = state.distance - motion.approach * rates.distance_per_second * seconds;
    next.distance = std::max(static_cast<float>(d), rates.min_distance);
  }
  if (next.light && motion.light != glm::ivec3(0)) {
    const double step = rates.light_per_second * seconds;
    for (int i = 0; i < 3; ++i) {
      (*next.light)[i] = static_cast<float>((*state.light)[i] + motion.light[i] * step);
    }
  }
  return next;
}

SceneOverrides view_overrides(const ViewState& state, int width, int height) {
  SceneOverrides o;
  o.width = width;
  o.height = height;
  o.yaw = state.yaw;
  o.distance = state.distance;
  o.light = state.light;
  return o;
}

ViewState initial_view(const JobSettings& flags, const LoadedScene& loaded) {
  ViewState s;
  if (!flags.yaw.empty()) s.yaw = *parse_finite(flags.yaw);
  s.distance = flags.distance.empty() ? glm::length(loaded.camera.position - loaded.camera.look_at)
                                      : *parse_float(flags.distance);
  if (!loaded.scene.lights.empty()) s.light = loaded.scene.lights.front().position;
  return s;
}

std::string shell_quote(const std::string& text) {
  const bool safe = !text.empty() && std::all_of(text.begin(), text.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
           std::string_view("_-./:,+=@%").find(c) != std::string_view::npos;
  });
  if (safe) return text;
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

std::string render_command_line(const JobSettings& flags, const ViewState& state, int width,
                                int height, const IntegratorSpec& rendered) {
  std::string line = "tritrace render";
  if (!flags.file.empty()) line += " " + shell_quote(flags.file);
  if (!flags.scene.empty()) line += " --scene " + shell_quote(flags.scene);
  if (flags.accel != "bvh") line += " --accel " + shell_quote(flags.accel);
  if (!flags.kernel.empty()) line += " --kernel " + shell_quote(flags.kernel);
  if (!flags.camera.empty()) line += " --camera " + shell_quote(flags.camera);
  line += " --yaw " + format_double(state.yaw);
  line += " --distance " + format_float(state.distance);
  if (state.light) line += " --light " + format_vec3(*state.light);
  line += " --width " + std::to_string(width) + " --height " + std::to_string(height);
  if (rendered.kind == IntegratorSpec::Kind::kLab) {
    if (flags.integrator == "lab") line += " --integrator lab";
    return line;
  }
  // Everything the path tracer's pixels depend on besides the scene and the view. The seed is
  // printed even when it is the scene's own, so that the command says which image it is.
  line += " --integrator " + std::string(integrator_name(rendered.kind)) + " --spp " +
          std::to_string(rendered.spp);
  line += " --seed " + std::to_string(rendered.seed);
  if (!flags.sampler.empty()) line += " --sampler " + flags.sampler;
  if (!flags.aperture.empty()) line += " --aperture " + shell_quote(flags.aperture);
  if (!flags.focus.empty()) line += " --focus " + shell_quote(flags.focus);
  if (!flags.max_depth.empty()) line += " --max-depth " + std::to_string(rendered.max_depth);
  if (rendered.clamp > 0.0f) line += " --clamp " + format_float(rendered.clamp);
  if (!flags.light_paths.empty()) line += " --light-paths " + shell_quote(flags.light_paths);
  const FilterKind filter = filter_choice(flags);
  if (filter != FilterKind::kBox) line += " --filter " + std::string(filter_name(filter));
  // Adaptive sampling decides which samples each pixel takes, and the denoiser (N) is the image.
  if (!flags.noise_threshold.empty()) {
    line += " --noise-threshold " + shell_quote(flags.noise_threshold);
  }
  if (flags.denoise) line += " --denoise";
  return line;
}

}  // namespace tritrace::view
