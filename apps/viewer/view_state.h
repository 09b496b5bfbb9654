// The viewer's view (camera yaw and distance, light position), how held keys move it over time,
// and the `tritrace render` command line that reproduces it. Plain data and arithmetic, no SDL,
// so that it is unit-tested on its own.
#pragma once

#include <glm/vec3.hpp>
#include <optional>
#include <string>

#include "flags/scene_flags.h"
#include "tritrace/scene/io/loaded_scene.h"

namespace tritrace::view {

// Exactly the values that go into the scene (SceneOverrides' types), so that printing them in a
// form that parses back exactly reproduces the image.
struct ViewState {
  double yaw = 0.0;                // orbit about the vertical through the look-at point, radians
  float distance = 3.0f;           // from the camera to its look-at point
  std::optional<glm::vec3> light;  // the first light; none when the scene has no light

  bool operator==(const ViewState&) const = default;
};

// The motion keys held down at one moment.
struct HeldKeys {
  bool left = false, right = false, up = false, down = false;
  bool w = false, s = false, a = false, d = false, q = false, e = false;
};

// Which way each key pair drives the view: -1, 0 or +1 per axis.
struct Motion {
  int turn = 0;        // +1: Left, which adds yaw (the lab's); -1: Right
  int approach = 0;    // +1: Up, forward along the view (closer); -1: Down
  glm::ivec3 light{};  // x: D - A; y: E - Q (world y points down, so Q moves up); z: W - S

  bool any() const { return turn != 0 || approach != 0 || light != glm::ivec3(0); }
};

Motion motion_from(const HeldKeys& keys);

// Speeds per second of held key, so that motion is the same at any frame rate. The lab moved
// 0.05 rad per frame (3 rad/s at 60 fps, a turn in 2 s, too fast to aim); 1.5 rad/s turns the
// box a quarter in about a second. Distances scale with the scene: the lab's camera at 3 moves
// 1 unit per second, as does its light, and comes no closer than 1% of its start distance.
struct MotionRates {
  double yaw_per_second = 1.5;
  double distance_per_second = 1.0;
  double light_per_second = 1.0;
  float min_distance = 0.03f;

  static MotionRates for_distance(float start_distance);
};

// The view after holding `motion` for `seconds`.
ViewState advance(const ViewState& state, const Motion& motion, double seconds,
                  const MotionRates& rates);

// The overrides that give `state` at `width` x `height`.
SceneOverrides view_overrides(const ViewState& state, int width, int height);

// The starting view: the flags' values, else the loaded scene's (`loaded` was loaded with the
// flags' overrides).
ViewState initial_view(const JobSettings& flags, const LoadedScene& loaded);

// The lab integrator, as the scene or the flags chose it.
inline constexpr IntegratorSpec kLabSpec{.kind = IntegratorSpec::Kind::kLab};

// `tritrace render ...` reproducing `state` at `width` x `height`: the scene's source and the
// accel and kernel when not the defaults, and every view value in a form the CLI reads back
// exactly, so that its image is the viewer's bit for bit. `rendered` is how the image was made:
// for the path tracer, `--integrator path`, its spp (the samples the image holds) and seed, and
// --max-depth, --filter and --noise-threshold when the flags gave them, and --denoise when
// flags.denoise is set (the viewer sets it when the image is denoised); for the lab integrator,
// `--integrator lab` only when the flags asked for it.
std::string render_command_line(const JobSettings& flags, const ViewState& state, int width,
                                int height, const IntegratorSpec& rendered = kLabSpec);

// `text` quoted for a POSIX shell when it holds anything but safe characters.
std::string shell_quote(const std::string& text);

}  // namespace tritrace::view
