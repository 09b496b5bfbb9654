// glTF cameras: assimp's test model Cameras.gltf (a unit square turned about x, a perspective and
// an orthographic camera at (0.5, 0.5, 3)), with where its corner projects worked out by hand from
// the file's numbers, and a small hand-written file for names, hierarchy and scene-graph order.
#include "tritrace/scene/io/gltf_cameras.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>

#include "tritrace/error.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;

const std::string kCameras = "/usr/share/assimp/models/glTF2/cameras/Cameras.gltf";

template <typename F>
Error error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no Error thrown";
  return Error("", "");
}

// The square's corner (1, 1, 0) after node 0's rotation, the quaternion (x, 0, 0, w) =
// (-0.383, 0, 0, 0.92375) normalised: a turn about x by theta = 2 atan2(x, w) takes (1, 1, 0) to
// (1, cos theta, sin theta).
glm::dvec3 turned_corner() {
  const double theta = 2.0 * std::atan2(-0.383, 0.92375);
  return {1.0, std::cos(theta), std::sin(theta)};
}

TEST(GltfCameras, ReadsBothCamerasOfAssimpsTestModelInSceneGraphOrder) {
  if (!fs::exists(kCameras)) GTEST_SKIP() << kCameras << " not installed";
  const std::vector<GltfCamera> cameras = read_gltf_cameras(kCameras);
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_FALSE(cameras[0].orthographic);
  EXPECT_DOUBLE_EQ(cameras[0].yfov, 0.7);
  EXPECT_DOUBLE_EQ(*cameras[0].aspect_ratio, 1.0);
  EXPECT_TRUE(cameras[1].orthographic);
  EXPECT_DOUBLE_EQ(cameras[1].ymag, 1.0);
  EXPECT_EQ(glm::dvec3(cameras[0].world[3]), glm::dvec3(0.5, 0.5, 3.0));
}

TEST(GltfCameras, ReadsTheJsonChunkOfABinaryGltf) {
  // Khronos' 2CylinderEngine sample as a .glb: one perspective camera on root node 81, whose
  // matrix's columns are the camera's axes and position (numbers from the file's JSON chunk).
  const std::string engine =
      "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  if (!fs::exists(engine)) GTEST_SKIP() << engine << " not installed";
  const std::vector<GltfCamera> cameras = read_gltf_cameras(engine);
  ASSERT_EQ(cameras.size(), 1u);
  EXPECT_DOUBLE_EQ(cameras[0].yfov, 0.3143463730812073);
  EXPECT_NEAR(cameras[0].world[3][0], 1005.9874267578125, 1e-9);
  EXPECT_NEAR(cameras[0].world[3][1], 766.3170776367188, 1e-9);
  EXPECT_NEAR(cameras[0].world[3][2], 953.3455810546875, 1e-9);
  CameraSpec spec;
  set_gltf_view(cameras[0], Bounds3{glm::vec3(-1.0f), glm::vec3(1.0f)}, &spec);
  // The view direction is minus the matrix's third column, normalised.
  const glm::vec3 forward = glm::normalize(spec.look_at - spec.position);
  EXPECT_NEAR(forward.x, -0.6246951818466187, 1e-5);
  EXPECT_NEAR(forward.y, -0.4685211479663849, 1e-5);
  EXPECT_NEAR(forward.z, -0.6246950030326843, 1e-5);
  EXPECT_NEAR(spec.up.y, 0.883452296257019, 1e-6);
}

TEST(GltfCameras, PerspectiveCameraSeesTheCornerWhereTheFileSaysItIs) {
  if (!fs::exists(kCameras)) GTEST_SKIP() << kCameras << " not installed";
  const LoadedScene loaded = load_scene(kCameras);
  ASSERT_EQ(loaded.cameras.size(), 2u);
  EXPECT_EQ(loaded.camera_index, 0);
  // assimp turned the square as the node says: its bounds reach the corner's y and z (to 1e-5:
  // assimp does not normalise the quaternion, whose length is 1 + 1.5e-6).
  const glm::dvec3 v = turned_corner();
  EXPECT_NEAR(loaded.scene.mesh.bounds().hi.y, v.y, 1e-5);
  EXPECT_NEAR(loaded.scene.mesh.bounds().lo.z, v.z, 1e-5);
  // By hand: the camera at (0.5, 0.5, 3) looks along -z with +y up, so image right is +x and
  // image down is -y; a 500 x 500 image with yfov 0.7 has f = 250 / tan(0.35) pixels, and a point
  // at depth 3 - z appears at (250 + f (x - 0.5) / (3 - z), 250 - f (y - 0.5) / (3 - z)).
  const Camera& cam = loaded.scene.camera;
  ASSERT_EQ(cam.width(), 500);
  ASSERT_FALSE(cam.is_orthographic());
  const double f = 250.0 / std::tan(0.35), depth = 3.0 - v.z;
  const double px = 250.0 + f * (v.x - 0.5) / depth, py = 250.0 - f * (v.y - 0.5) / depth;
  const Ray r = cam.ray_through(static_cast<float>(px), static_cast<float>(py));
  EXPECT_EQ(r.origin, glm::vec3(0.5f, 0.5f, 3.0f));
  const glm::dvec3 to_corner = glm::normalize(v - glm::dvec3(0.5, 0.5, 3.0));
  EXPECT_LT(glm::length(glm::cross(glm::dvec3(r.dir), to_corner)), 2e-6);
  EXPECT_GT(glm::dot(glm::dvec3(r.dir), to_corner), 0.0);
}

TEST(GltfCameras, OrthographicCameraByIndexShowsTwiceYmagTopToBottom) {
  if (!fs::exists(kCameras)) GTEST_SKIP() << kCameras << " not installed";
  SceneOverrides o;
  o.camera = "1";
  o.width = 400;
  o.height = 200;
  const LoadedScene loaded = load_scene(kCameras, o);
  EXPECT_EQ(loaded.camera_index, 1);
  const Camera& cam = loaded.scene.camera;
  ASSERT_TRUE(cam.is_orthographic());
  // ymag 1 over 200 rows: 0.01 units per pixel, the same across (fit by ymag, as the perspective
  // camera keeps yfov). The corner appears 0.5 / 0.01 = 50 pixels right of the centre and
  // (cos theta - 0.5) / 0.01 pixels above it.
  const glm::dvec3 v = turned_corner();
  const double px = 200.0 + (v.x - 0.5) / 0.01, py = 100.0 - (v.y - 0.5) / 0.01;
  const Ray r = cam.ray_through(static_cast<float>(px), static_cast<float>(py));
  EXPECT_EQ(r.dir, glm::vec3(0.0f, 0.0f, -1.0f));
  EXPECT_NEAR(r.origin.x, v.x, 1e-5);
  EXPECT_NEAR(r.origin.y, v.y, 1e-5);
  EXPECT_EQ(r.origin.z, 3.0f);
}

TEST(GltfCameras, AMissingCameraIsAUsageErrorNamingTheFlagAndTheChoices) {
  if (!fs::exists(kCameras)) GTEST_SKIP() << kCameras << " not installed";
  for (const char* selection : {"2", "front"}) {
    SceneOverrides o;
    o.camera = selection;
    const Error e = error_of([&] { load_scene(kCameras, o); });
    EXPECT_EQ(e.subject(), "--camera");
    EXPECT_EQ(e.exit_code(), ExitCode::kUsage);
    EXPECT_NE(e.reason().find("(it has 0, 1)"), std::string::npos) << e.reason();
  }
}

TEST(GltfCameras, FilesWithoutCamerasKeepTheFramingAndRefuseTheFlag) {
  const std::string box = "/usr/share/assimp/models/glTF2/BoxTextured-glTF/BoxTextured.gltf";
  if (!fs::exists(box)) GTEST_SKIP() << box << " not installed";
  const LoadedScene loaded = load_scene(box);
  EXPECT_TRUE(loaded.cameras.empty());
  EXPECT_EQ(loaded.camera_index, -1);
  EXPECT_EQ(loaded.camera.vertical_fov_degrees, kFramingFovDegrees);
  SceneOverrides o;
  o.camera = "0";
  EXPECT_EQ(error_of([&] { load_scene(box, o); }).subject(), "--camera");
  EXPECT_EQ(error_of([&] { load_builtin_scene("cornell", o); }).subject(), "--camera");
}

class HandWrittenGltf : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("tritrace-gltf-cameras-" +
            std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    // Scene roots [2, 0]: node 2 (unnamed, orthographic camera "ortho cam") comes first, then the
    // rig (translated to (1, 2, 3), turned 90 degrees about y) and its child "front" 5 units
    // along the rig's z. Node 3 is in no scene.
    std::ofstream(dir_ / "rig.gltf") << R"({
      "asset": {"version": "2.0"}, "scene": 0,
      "scenes": [{"nodes": [2, 0]}],
      "nodes": [
        {"name": "rig", "translation": [1, 2, 3],
         "rotation": [0, 0.70710678118654752, 0, 0.70710678118654752], "children": [1]},
        {"name": "front", "translation": [0, 0, 5], "camera": 0},
        {"camera": 1, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,20,1]},
        {"name": "unused", "camera": 0}],
      "cameras": [
        {"type": "perspective", "name": "persp", "perspective": {"yfov": 0.5, "znear": 0.1}},
        {"type": "orthographic", "name": "ortho cam",
         "orthographic": {"xmag": 3, "ymag": 2, "znear": 0.1, "zfar": 50}}]})";
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(HandWrittenGltf, CamerasComeInSceneGraphOrderWithTheirWorldTransforms) {
  const std::vector<GltfCamera> cameras = read_gltf_cameras((dir_ / "rig.gltf").string());
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0].name, "ortho cam");  // no node name: the camera's
  EXPECT_EQ(cameras[1].name, "front");      // the node's name first
  EXPECT_FALSE(cameras[1].aspect_ratio.has_value());
  // front: (1, 2, 3) + R_y(90 degrees) (0, 0, 5) = (1, 2, 3) + (5, 0, 0), looking along
  // R_y(90) (0, 0, -1) = (-1, 0, 0).
  CameraSpec spec;
  Bounds3 bounds{glm::vec3(-10.0f, 0.0f, 0.0f), glm::vec3(-8.0f, 4.0f, 6.0f)};  // centre (-9, 2, 3)
  set_gltf_view(cameras[1], bounds, &spec);
  EXPECT_NEAR(spec.position.x, 6.0f, 1e-6f);
  EXPECT_NEAR(spec.position.y, 2.0f, 1e-6f);
  EXPECT_NEAR(spec.position.z, 3.0f, 1e-6f);
  // look_at: on the axis at the bounds' centre's depth, 15 units ahead.
  EXPECT_NEAR(spec.look_at.x, -9.0f, 1e-5f);
  EXPECT_NEAR(spec.look_at.y, 2.0f, 1e-5f);
  EXPECT_NEAR(spec.look_at.z, 3.0f, 1e-5f);
  EXPECT_NEAR(spec.up.y, 1.0f, 1e-6f);
  EXPECT_FALSE(spec.mirror_x);
  EXPECT_NEAR(*spec.vertical_fov_degrees, 0.5 * 180.0 / 3.14159265358979323846, 1e-9);
  set_gltf_view(cameras[0], bounds, &spec);
  EXPECT_EQ(spec.position, glm::vec3(0.0f, 0.0f, 20.0f));
  EXPECT_EQ(*spec.ortho_half_height, 2.0f);
  EXPECT_FALSE(spec.vertical_fov_degrees.has_value());
}

TEST_F(HandWrittenGltf, CameraIsChosenByIndexOrName) {
  const std::string path = (dir_ / "rig.gltf").string();
  const std::vector<GltfCamera> cameras = read_gltf_cameras(path);
  EXPECT_EQ(choose_camera(cameras, "", path), 0u);
  EXPECT_EQ(choose_camera(cameras, "1", path), 1u);
  EXPECT_EQ(choose_camera(cameras, "front", path), 1u);
  EXPECT_EQ(choose_camera(cameras, "ortho cam", path), 0u);
  const Error e = error_of([&] { choose_camera(cameras, "unused", path); });
  EXPECT_EQ(e.subject(), "--camera");
  EXPECT_NE(e.reason().find("(it has 0 'ortho cam', 1 'front')"), std::string::npos) << e.reason();
}

TEST_F(HandWrittenGltf, MalformedCamerasAreOneLineErrorsNamingTheFile) {
  const std::pair<const char*, const char*> cases[] = {
      {R"({"type": "perspective", "perspective": {"yfov": -1}})",
       "cameras[0].perspective: \"yfov\" must be between 0 and pi radians"},
      {R"({"type": "orthographic", "orthographic": {"xmag": 1}})",
       "cameras[0].orthographic: \"ymag\" must be a number"},
      {R"({"type": "fisheye"})",
       "cameras[0]: \"type\" must be \"perspective\" or \"orthographic\""},
  };
  const std::string path = (dir_ / "bad.gltf").string();
  for (const auto& [camera, reason] : cases) {
    std::ofstream(path) << R"({"asset": {"version": "2.0"}, "nodes": [{"camera": 0}],
        "cameras": [)" << camera
                        << "]}";
    const Error e = error_of([&] { read_gltf_cameras(path); });
    EXPECT_EQ(e.subject(), path);
    EXPECT_EQ(e.reason(), reason);
    EXPECT_EQ(e.reason().find('\n'), std::string::npos);
  }
}

}  // namespace
}  // namespace tritrace
