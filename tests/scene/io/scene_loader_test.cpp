// Command-line overrides on loaded scenes: --distance, and applying overrides again (the viewer's
// way of changing the view) giving exactly the scene that loading with them gives.
#include "tritrace/scene/io/scene_loader.h"

#include <gtest/gtest.h>

#include "tritrace/error.h"

#ifndef TRITRACE_SOURCE_DIR
#error "TRITRACE_SOURCE_DIR must name the source folder"
#endif

namespace tritrace {
namespace {

const std::string kCornellJson = std::string(TRITRACE_SOURCE_DIR) + "/scenes/cornell.json";

void ExpectSameCamera(const Camera& a, const Camera& b) {
  EXPECT_EQ(a.width(), b.width());
  EXPECT_EQ(a.height(), b.height());
  EXPECT_EQ(a.focal_px(), b.focal_px());
  EXPECT_EQ(a.position(), b.position());
  EXPECT_EQ(a.right(), b.right());
  EXPECT_EQ(a.down(), b.down());
  EXPECT_EQ(a.forward(), b.forward());
}

TEST(Distance, TheLabCameraSitsAtTheGivenDistance) {
  SceneOverrides o;
  o.distance = 2.0f;
  EXPECT_EQ(load_builtin_scene("cornell", o).scene.camera.position(), glm::vec3(0, 0, -2));
  o.yaw = 0.5;
  ExpectSameCamera(load_builtin_scene("cornell", o).scene.camera, Camera(500, 500, 0.5, 2.0f));
}

TEST(Distance, AFileCameraMovesAlongItsLineOfSight) {
  SceneOverrides o;
  o.distance = 6.0f;
  const LoadedScene s = load_scene(kCornellJson, o);
  EXPECT_EQ(s.scene.camera.position(), glm::vec3(0, 0, -6));  // (0, 0, -3) * 6 / 3
  EXPECT_EQ(s.scene.camera.forward(), glm::vec3(0, 0, 1));
}

TEST(ApplyOverrides, AgainGivesWhatLoadingWithThemGives) {
  SceneOverrides first;
  first.yaw = 0.3;
  first.distance = 2.5f;
  first.light = glm::vec3(0.1f, -0.2f, -0.3f);
  SceneOverrides second;
  second.yaw = -1.25;
  second.distance = 4.0f;
  second.light = glm::vec3(0.5f, -0.5f, 0.25f);
  second.width = 320;
  second.height = 200;
  for (const bool builtin : {true, false}) {
    SCOPED_TRACE(builtin ? "built-in" : "scenes/cornell.json");
    LoadedScene changed =
        builtin ? load_builtin_scene("cornell", first) : load_scene(kCornellJson, first);
    apply_overrides(changed, second);
    const LoadedScene direct =
        builtin ? load_builtin_scene("cornell", second) : load_scene(kCornellJson, second);
    ExpectSameCamera(changed.scene.camera, direct.scene.camera);
    ASSERT_EQ(changed.scene.lights.size(), direct.scene.lights.size());
    EXPECT_EQ(changed.scene.lights.front().position, direct.scene.lights.front().position);
  }
}

}  // namespace
}  // namespace tritrace
