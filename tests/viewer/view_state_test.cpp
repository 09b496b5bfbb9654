// The viewer's view arithmetic and the command line it prints, with expected values worked out by
// hand from the rates documented in view_state.h.
#include "view_state.h"

#include <gtest/gtest.h>

#include "tritrace/scene/io/scene_loader.h"

namespace tritrace::view {
namespace {

TEST(Motion, KeysMapToTheLabsDirections) {
  HeldKeys k;
  EXPECT_FALSE(motion_from(k).any());
  k.left = true;
  EXPECT_EQ(motion_from(k).turn, 1);  // Left adds yaw
  k.right = true;
  EXPECT_EQ(motion_from(k).turn, 0);  // both cancel
  EXPECT_FALSE(motion_from(k).any());

  HeldKeys light;
  light.w = true;  // +z
  light.a = true;  // -x
  light.q = true;  // up, which is -y since world y points down
  EXPECT_EQ(motion_from(light).light, glm::ivec3(-1, -1, 1));
  HeldKeys other;
  other.s = other.d = other.e = other.down = true;
  EXPECT_EQ(motion_from(other).light, glm::ivec3(1, 1, -1));
  EXPECT_EQ(motion_from(other).approach, -1);
}

TEST(Motion, HoldingLeftHalfASecondTurnsPointSevenFiveRadians) {
  ViewState s;  // yaw 0, distance 3
  Motion m;
  m.turn = 1;
  const ViewState next = advance(s, m, 0.5, MotionRates{});
  EXPECT_DOUBLE_EQ(next.yaw, 0.75);  // 1.5 rad/s * 0.5 s
  EXPECT_EQ(next.distance, 3.0f);
  m.turn = -1;
  EXPECT_DOUBLE_EQ(advance(next, m, 0.25, MotionRates{}).yaw, 0.375);
}

TEST(Motion, SameTotalAtAnyFrameRate) {
  Motion m;
  m.turn = 1;
  ViewState ten_frames, one_frame;
  for (int i = 0; i < 10; ++i) ten_frames = advance(ten_frames, m, 0.1, MotionRates{});
  one_frame = advance(one_frame, m, 1.0, MotionRates{});
  EXPECT_NEAR(ten_frames.yaw, one_frame.yaw, 1e-12);
  EXPECT_NEAR(one_frame.yaw, 1.5, 1e-12);
}

TEST(Motion, UpMovesTheCameraCloserAndStopsShortOfTheTarget) {
  ViewState s;
  Motion m;
  m.approach = 1;
  EXPECT_EQ(advance(s, m, 0.5, MotionRates{}).distance, 2.5f);    // 1 unit/s for the lab
  EXPECT_EQ(advance(s, m, 10.0, MotionRates{}).distance, 0.03f);  // 1% of 3
  m.approach = -1;
  EXPECT_EQ(advance(s, m, 2.0, MotionRates{}).distance, 5.0f);
}

TEST(Motion, LightKeysMoveTheLightOneUnitPerSecond) {
  ViewState s;
  s.light = glm::vec3(0.0f, -0.5f, -0.7f);
  Motion m;
  m.light = glm::ivec3(0, 0, 1);  // W
  const ViewState w = advance(s, m, 0.25, MotionRates{});
  EXPECT_EQ(w.light->x, 0.0f);
  EXPECT_EQ(w.light->y, -0.5f);
  EXPECT_EQ(w.light->z, static_cast<float>(double{-0.7f} + 0.25));
  m.light = glm::ivec3(-1, -1, 0);  // A and Q
  const ViewState aq = advance(s, m, 0.5, MotionRates{});
  EXPECT_EQ(aq.light->x, -0.5f);
  EXPECT_EQ(aq.light->y, -1.0f);
}

TEST(Motion, LightKeysDoNothingWithoutALight) {
  ViewState s;
  Motion m;
  m.light = glm::ivec3(1, 0, 0);
  EXPECT_FALSE(advance(s, m, 1.0, MotionRates{}).light.has_value());
}

TEST(Motion, RatesScaleWithTheSceneSize) {
  const MotionRates r = MotionRates::for_distance(30.0f);
  EXPECT_DOUBLE_EQ(r.distance_per_second, 10.0);
  EXPECT_DOUBLE_EQ(r.light_per_second, 10.0);
  EXPECT_EQ(r.min_distance, 0.3f);
  EXPECT_DOUBLE_EQ(r.yaw_per_second, 1.5);
  EXPECT_DOUBLE_EQ(MotionRates::for_distance(3.0f).light_per_second, 1.0);
}

TEST(InitialView, TheLabsDefaults) {
  const JobSettings flags;
  const LoadedScene loaded = load_builtin_scene("cornell");
  const ViewState s = initial_view(flags, loaded);
  EXPECT_EQ(s.yaw, 0.0);
  EXPECT_EQ(s.distance, 3.0f);
  ASSERT_TRUE(s.light.has_value());
  EXPECT_EQ(*s.light, glm::vec3(0.0f, -0.5f, -0.7f));
}

TEST(InitialView, FlagsWin) {
  JobSettings flags;
  flags.yaw = "0.25";
  flags.distance = "2.5";
  flags.light = "1,2,3";
  SceneOverrides o;
  o.light = glm::vec3(1, 2, 3);
  const ViewState s = initial_view(flags, load_builtin_scene("cornell", o));
  EXPECT_EQ(s.yaw, 0.25);
  EXPECT_EQ(s.distance, 2.5f);
  EXPECT_EQ(*s.light, glm::vec3(1, 2, 3));
}

TEST(CommandLine, NamesEveryViewValue) {
  JobSettings flags;
  ViewState s;
  s.yaw = 0.1234;
  s.light = glm::vec3(0.0f, -0.5f, -0.7f);
  EXPECT_EQ(render_command_line(flags, s, 500, 500),
            "tritrace render --yaw 0.1234 --distance 3 --light 0,-0.5,-0.7 --width 500 "
            "--height 500");
}

TEST(CommandLine, AddsTheSceneSourceAccelAndKernelWhenGiven) {
  JobSettings flags;
  flags.file = "my scene.json";
  flags.accel = "brute";
  flags.kernel = "cramer";
  ViewState s;
  s.yaw = -0.5;
  s.distance = 2.25f;
  EXPECT_EQ(render_command_line(flags, s, 320, 240),
            "tritrace render 'my scene.json' --accel brute --kernel cramer --yaw -0.5 "
            "--distance 2.25 --width 320 --height 240");
  JobSettings terrain;
  terrain.scene = "terrain:1m";
  EXPECT_EQ(render_command_line(terrain, s, 8, 8),
            "tritrace render --scene terrain:1m --yaw -0.5 --distance 2.25 --width 8 --height 8");
}

TEST(CommandLine, ThePathTracersSamplesSeedAndChoicesGiven) {
  JobSettings flags;
  flags.scene = "cornell-area";
  ViewState s;
  IntegratorSpec path;
  path.kind = IntegratorSpec::Kind::kPath;
  path.spp = 37;  // the samples the image holds, not the scene's target
  path.seed = 5;
  path.max_depth = 9;
  EXPECT_EQ(render_command_line(flags, s, 64, 48, path),
            "tritrace render --scene cornell-area --yaw 0 --distance 3 --width 64 --height 48 "
            "--integrator path --spp 37 --seed 5");
  // --max-depth and --filter when the flags gave them (the scene's own otherwise, which the
  // command reads from the same scene).
  flags.max_depth = "9";
  flags.filter = "gaussian";
  EXPECT_EQ(render_command_line(flags, s, 64, 48, path),
            "tritrace render --scene cornell-area --yaw 0 --distance 3 --width 64 --height 48 "
            "--integrator path --spp 37 --seed 5 --max-depth 9 --filter gaussian");
  // A clamp changes the pixels: the command carries it.
  path.clamp = 2.5f;
  EXPECT_EQ(render_command_line(flags, s, 64, 48, path),
            "tritrace render --scene cornell-area --yaw 0 --distance 3 --width 64 --height 48 "
            "--integrator path --spp 37 --seed 5 --max-depth 9 --clamp 2.5 --filter gaussian");
}

TEST(CommandLine, NamesTheBidirectionalPathTracer) {
  JobSettings flags;
  flags.scene = "cornell-area";
  ViewState s;
  IntegratorSpec bdpt;
  bdpt.kind = IntegratorSpec::Kind::kBdpt;
  bdpt.spp = 12;
  bdpt.seed = 5;
  EXPECT_EQ(render_command_line(flags, s, 64, 48, bdpt),
            "tritrace render --scene cornell-area --yaw 0 --distance 3 --width 64 --height 48 "
            "--integrator bdpt --spp 12 --seed 5");
}

TEST(CommandLine, TheNoiseThresholdAndTheDenoiserChangeThePixels) {
  JobSettings flags;
  flags.scene = "cornell-area";
  flags.noise_threshold = "0.05";
  ViewState s;
  IntegratorSpec path;
  path.kind = IntegratorSpec::Kind::kPath;
  path.spp = 256;
  EXPECT_EQ(render_command_line(flags, s, 64, 48, path),
            "tritrace render --scene cornell-area --yaw 0 --distance 3 --width 64 --height 48 "
            "--integrator path --spp 256 --seed 0 --noise-threshold 0.05");
  flags.denoise = true;
  EXPECT_EQ(render_command_line(flags, s, 64, 48, path),
            "tritrace render --scene cornell-area --yaw 0 --distance 3 --width 64 --height 48 "
            "--integrator path --spp 256 --seed 0 --noise-threshold 0.05 --denoise");
}

TEST(CommandLine, TheLabIntegratorOnlyWhenAskedFor) {
  JobSettings flags;
  flags.scene = "cornell-area";  // a path tracer's scene, shown with the lab's shading
  flags.integrator = "lab";
  ViewState s;
  EXPECT_EQ(render_command_line(flags, s, 8, 8, kLabSpec),
            "tritrace render --scene cornell-area --yaw 0 --distance 3 --width 8 --height 8 "
            "--integrator lab");
}

TEST(CommandLine, ShellQuoting) {
  EXPECT_EQ(shell_quote("scenes/cornell.json"), "scenes/cornell.json");
  EXPECT_EQ(shell_quote("a b"), "'a b'");
  EXPECT_EQ(shell_quote("it's"), "'it'\\''s'");
  EXPECT_EQ(shell_quote(""), "''");
  EXPECT_EQ(shell_quote("$HOME"), "'$HOME'");
}

TEST(ViewOverrides, CarryTheWholeView) {
  ViewState s;
  s.yaw = 1.0;
  s.distance = 4.0f;
  s.light = glm::vec3(1, 2, 3);
  const SceneOverrides o = view_overrides(s, 640, 480);
  EXPECT_EQ(o.width, 640);
  EXPECT_EQ(o.height, 480);
  EXPECT_EQ(o.yaw, 1.0);
  EXPECT_EQ(o.distance, 4.0f);
  EXPECT_EQ(o.light, glm::vec3(1, 2, 3));
}

}  // namespace
}  // namespace tritrace::view
