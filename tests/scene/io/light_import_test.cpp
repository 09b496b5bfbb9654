// Spot and directional lights from other programs' files: pbrt-v4's "spot" and "distant" light
// sources (pbrt-v4's file format documentation and its SpotLight/DistantLight definitions give
// the expectations), and glTF's KHR_lights_punctual (the extension's specification for placement
// and defaults, Blender's importer for the unit rule: candela / 683 = W/sr, lux / 683 = W/m^2),
// from hand-written files in tests/data/gltf.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <string>

#include "tritrace/error.h"
#include "tritrace/image/image.h"
#include "tritrace/job/render_job.h"
#include "tritrace/scene/io/gltf_lights.h"
#include "tritrace/scene/io/input_file.h"
#include "tritrace/scene/io/pbrt_scene.h"
#include "tritrace/scene/io/scene_loader.h"

#ifndef TRITRACE_SOURCE_DIR
#error "TRITRACE_SOURCE_DIR must name the source folder"
#endif

namespace tritrace {
namespace {

const std::string kGltf = std::string(TRITRACE_SOURCE_DIR) + "/tests/data/gltf/";
constexpr double kPi = std::numbers::pi;

double deg(double d) {
  return d * kPi / 180.0;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.subject() + ": " + e.reason();
  }
  return "(no error)";
}

LoadedScene pbrt(const std::string& world) {
  return parse_pbrt_scene("WorldBegin\n" + world, "s.pbrt");
}

// --- pbrt-v4 ---

// A spot light from (0,0,0) to (0,0,5), turned 90 degrees about y (z becomes x) and moved by
// (1, 2, 3): at (1, 2, 3) pointing along +x; I times scale; cones cos(30) and cos(30 - 10);
// pbrt's smoothstep falloff.
TEST(PbrtLights, SpotLightIsPlacedByTheCtmWithPbrtsConesAndSmoothstep) {
  const LoadedScene s = pbrt(
      "Translate 1 2 3\nRotate 90 0 1 0\n"
      "LightSource \"spot\" \"point3 from\" [0 0 0] \"point3 to\" [0 0 5] \"float coneangle\" 30 "
      "\"float conedelta\" 10 \"rgb I\" [1 2 3] \"float scale\" 2\n"
      "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 2]\n");
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  ASSERT_EQ(s.scene.spot_lights.size(), 1u);
  EXPECT_TRUE(s.scene.lights.empty());
  const SpotLight& l = s.scene.spot_lights[0];
  EXPECT_NEAR(l.position.x, 1.0f, 1e-6f);
  EXPECT_NEAR(l.position.y, 2.0f, 1e-6f);
  EXPECT_NEAR(l.position.z, 3.0f, 1e-6f);
  EXPECT_NEAR(l.direction.x, 1.0f, 1e-6f);
  EXPECT_NEAR(l.direction.y, 0.0f, 1e-6f);
  EXPECT_NEAR(l.direction.z, 0.0f, 1e-6f);
  EXPECT_EQ(l.intensity, glm::vec3(2.0f, 4.0f, 6.0f));
  EXPECT_NEAR(l.cos_outer, std::cos(deg(30.0)), 1e-7);
  EXPECT_NEAR(l.cos_inner, std::cos(deg(20.0)), 1e-7);
  EXPECT_EQ(l.falloff, SpotFalloff::kSmoothstep);
}

// pbrt-v4's defaults (from (0,0,0) to (0,0,1), coneangle 30, conedelta 5, I = 1) and its "power":
// the intensity that makes the cone's integral 2 pi (1 - cos_start + (cos_start - cos_end) / 2)
// of I equal the power.
TEST(PbrtLights, SpotDefaultsAndPower) {
  const LoadedScene s = pbrt(
      "LightSource \"spot\"\nLightSource \"spot\" \"float power\" 100\n"
      "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 2]\n");
  ASSERT_EQ(s.scene.spot_lights.size(), 2u);
  const SpotLight& d = s.scene.spot_lights[0];
  EXPECT_EQ(d.position, glm::vec3(0.0f));
  EXPECT_EQ(d.direction, glm::vec3(0.0f, 0.0f, 1.0f));
  EXPECT_EQ(d.intensity, glm::vec3(1.0f));
  EXPECT_NEAR(d.cos_outer, std::cos(deg(30.0)), 1e-7);
  EXPECT_NEAR(d.cos_inner, std::cos(deg(25.0)), 1e-7);
  const double cs = std::cos(deg(25.0)), ce = std::cos(deg(30.0));
  const double want = 100.0 / (2.0 * kPi * ((1.0 - cs) + (cs - ce) / 2.0));
  EXPECT_NEAR(s.scene.spot_lights[1].intensity.x, want, 1e-4 * want);
}

// A distant light's radiance L times scale is the irradiance it gives a surface facing it, and
// its light travels from "from" towards "to".
TEST(PbrtLights, DistantLightTravelsFromFromToToWithIrradianceLTimesScale) {
  const LoadedScene s = pbrt(
      "LightSource \"distant\" \"point3 from\" [0 4 0] \"point3 to\" [0 0 0] \"rgb L\" [1 2 3] "
      "\"float scale\" 0.5\n"
      "Scale 2 1 1\nLightSource \"distant\" \"point3 from\" [1 0 0] \"point3 to\" [0 0 1]\n"
      "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 2]\n");
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  ASSERT_EQ(s.scene.directional_lights.size(), 2u);
  EXPECT_EQ(s.scene.directional_lights[0].direction, glm::vec3(0.0f, -1.0f, 0.0f));
  EXPECT_EQ(s.scene.directional_lights[0].irradiance, glm::vec3(0.5f, 1.0f, 1.5f));
  // (to - from) = (-1, 0, 1), scaled by the CTM to (-2, 0, 1), normalised.
  const glm::vec3 d = s.scene.directional_lights[1].direction;
  EXPECT_NEAR(d.x, -2.0 / std::sqrt(5.0), 1e-6);
  EXPECT_NEAR(d.y, 0.0, 1e-6);
  EXPECT_NEAR(d.z, 1.0 / std::sqrt(5.0), 1e-6);
  EXPECT_EQ(s.scene.directional_lights[1].irradiance, glm::vec3(1.0f));
}

TEST(PbrtLights, BadConesAndDegenerateDirectionsAreErrorsWithTheirLine) {
  EXPECT_EQ(error_of([] { pbrt("LightSource \"spot\" \"float coneangle\" 0\n"); }),
            "s.pbrt:2:1: spot light \"coneangle\" must be more than 0 and at most 180 degrees");
  EXPECT_EQ(error_of([] { pbrt("LightSource \"spot\" \"float conedelta\" 40\n"); }),
            "s.pbrt:2:1: spot light \"conedelta\" must be more than 0 and at most \"coneangle\"");
  EXPECT_EQ(error_of([] { pbrt("LightSource \"distant\" \"point3 to\" [0 0 0]\n"); }),
            "s.pbrt:2:1: distant light \"from\" and \"to\" coincide");
}

// --- glTF ---

// tests/data/gltf/plane_lights.gltf: a directional light of colour (1, 0.5, 0.25) and 683 lux
// pointing down (the node's -z turned to -y), a spot light of 1366 cd at (0, 3, 0) pointing down
// with cones 0.2 and 0.6 rad, and a point light of 68.3 cd at (0, 1, 0) in a node under a parent
// translated by (1, 0, 0) and scaled by 2: at (1, 2, 0).
TEST(GltfLights, AreReadPlacedAndConvertedByBlendersRule) {
  const PunctualLights l = read_gltf_lights(kGltf + "plane_lights.gltf");
  ASSERT_EQ(l.directionals.size(), 1u);
  ASSERT_EQ(l.spots.size(), 1u);
  ASSERT_EQ(l.points.size(), 1u);
  const DirectionalLight& sun = l.directionals[0];
  EXPECT_NEAR(sun.direction.x, 0.0f, 1e-6f);
  EXPECT_NEAR(sun.direction.y, -1.0f, 1e-6f);
  EXPECT_NEAR(sun.direction.z, 0.0f, 1e-6f);
  // 683 lux / 683 lm/W = 1 W/m^2, times the colour.
  EXPECT_NEAR(sun.irradiance.x, 1.0f, 1e-6f);
  EXPECT_NEAR(sun.irradiance.y, 0.5f, 1e-6f);
  EXPECT_NEAR(sun.irradiance.z, 0.25f, 1e-6f);
  const SpotLight& spot = l.spots[0];
  EXPECT_NEAR(spot.position.y, 3.0f, 1e-6f);
  EXPECT_NEAR(spot.direction.y, -1.0f, 1e-6f);
  EXPECT_NEAR(spot.intensity.x, 2.0f, 1e-6f);  // 1366 cd / 683
  EXPECT_NEAR(spot.cos_inner, std::cos(0.2), 1e-7);
  EXPECT_NEAR(spot.cos_outer, std::cos(0.6), 1e-7);
  EXPECT_EQ(spot.falloff, SpotFalloff::kGltf);
  const PointLight& bulb = l.points[0];
  EXPECT_NEAR(bulb.position.x, 1.0f, 1e-6f);
  EXPECT_NEAR(bulb.position.y, 2.0f, 1e-6f);
  EXPECT_NEAR(bulb.position.z, 0.0f, 1e-6f);
  // 68.3 cd / 683 = 0.1 W/sr, a point light's power 4 pi times that.
  EXPECT_NEAR(bulb.power.x, 0.4 * kPi, 1e-6);
}

// A file with lights renders by them alone: no default key light, no grey environment.
TEST(GltfLights, ReplaceTheDefaultKeyLightAndEnvironment) {
  const LoadedScene with = load_scene(kGltf + "plane_lights.gltf");
  EXPECT_EQ(with.scene.lights.size(), 1u);
  EXPECT_EQ(with.scene.spot_lights.size(), 1u);
  EXPECT_EQ(with.scene.directional_lights.size(), 1u);
  EXPECT_EQ(with.scene.environment, glm::vec3(0.0f));
  EXPECT_NEAR(with.scene.lights[0].power.x, 0.4 * kPi, 1e-6);
}

// plane_sun.gltf: a grey plane facing +y under 1366 lux (2 W/m^2) arriving at 30 degrees from its
// normal (the node turned -60 degrees about x). With the plane made Lambertian (the file's
// metallic-roughness material is principled), every pixel on it has radiance
// albedo / pi * 2 cos(30 degrees), with no noise: one delta light and nothing else.
TEST(GltfLights, ADirectionalLightGivesTheHandComputedRadiance) {
  SceneOverrides view;
  view.width = 32;
  view.height = 24;
  LoadedScene loaded = load_scene(kGltf + "plane_sun.gltf", view);
  ASSERT_EQ(loaded.scene.directional_lights.size(), 1u);
  EXPECT_TRUE(loaded.scene.lights.empty());
  for (Material& m : loaded.scene.materials) m = Material{.albedo = glm::vec3(0.5f)};
  JobSettings settings;
  settings.threads = "2";
  settings.spp = "2";
  RenderJob job(settings, std::move(loaded));
  job.prepare();
  const Image image = job.render().image;
  const double want = 0.5 / kPi * 2.0 * std::cos(deg(30.0));
  const glm::vec3 centre = image.at(16, 12);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(centre[c], want, 1e-4) << c;
}

// The same lights from a .glb: its JSON chunk is read without the binary one.
TEST(GltfLights, AreReadFromAGlbsJsonChunk) {
  std::string json = read_input_file(kGltf + "plane_lights.gltf");
  while (json.size() % 4 != 0) json += ' ';
  const auto u32 = [](uint32_t v) {
    return std::string{static_cast<char>(v & 0xff), static_cast<char>((v >> 8) & 0xff),
                       static_cast<char>((v >> 16) & 0xff), static_cast<char>(v >> 24)};
  };
  const std::string glb = "glTF" + u32(2) + u32(static_cast<uint32_t>(20 + json.size())) +
                          u32(static_cast<uint32_t>(json.size())) + "JSON" + json;
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("tritrace_lights_" + std::to_string(::getpid()) + ".glb");
  std::ofstream(path, std::ios::binary) << glb;
  const PunctualLights l = read_gltf_lights(path.string());
  std::filesystem::remove(path);
  EXPECT_EQ(l.directionals.size(), 1u);
  EXPECT_EQ(l.spots.size(), 1u);
  ASSERT_EQ(l.points.size(), 1u);
  EXPECT_NEAR(l.points[0].position.y, 2.0f, 1e-6f);
}

// Defaults of the specification: colour white, intensity 1, a spot's cones 0 and pi/4; a light
// no node refers to is not placed.
TEST(GltfLights, SpecificationDefaults) {
  const PunctualLights l = parse_gltf_lights(
      R"({"extensions": {"KHR_lights_punctual": {"lights": [{"type": "spot"}, {"type": "point"}]}},
          "scenes": [{"nodes": [0]}],
          "nodes": [{"extensions": {"KHR_lights_punctual": {"light": 0}}}]})",
      "t.gltf");
  ASSERT_EQ(l.spots.size(), 1u);
  EXPECT_TRUE(l.points.empty());
  EXPECT_EQ(l.spots[0].direction, glm::vec3(0.0f, 0.0f, -1.0f));
  EXPECT_NEAR(l.spots[0].intensity.x, 1.0 / 683.0, 1e-9);
  EXPECT_EQ(l.spots[0].cos_inner, 1.0f);
  EXPECT_NEAR(l.spots[0].cos_outer, std::cos(kPi / 4.0), 1e-7);
}

// Lights come in the scene graph's order (depth first, children in their listed order), so that
// the first point light, which --light moves, is the file's first.
TEST(GltfLights, ComeInSceneGraphOrder) {
  const PunctualLights l = parse_gltf_lights(
      R"({"extensions": {"KHR_lights_punctual": {"lights": [{"type": "point"}]}},
          "scenes": [{"nodes": [0, 3]}],
          "nodes": [{"translation": [1, 0, 0], "children": [1, 2],
                     "extensions": {"KHR_lights_punctual": {"light": 0}}},
                    {"translation": [0, 1, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
                    {"translation": [0, 2, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
                    {"translation": [0, 0, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}}]})",
      "t.gltf");
  ASSERT_EQ(l.points.size(), 4u);
  EXPECT_EQ(l.points[0].position, glm::vec3(1, 0, 0));
  EXPECT_EQ(l.points[1].position, glm::vec3(1, 1, 0));
  EXPECT_EQ(l.points[2].position, glm::vec3(1, 2, 0));
  EXPECT_EQ(l.points[3].position, glm::vec3(0, 0, 3));
}

// A node that is its own ancestor is an error, not an endless walk.
TEST(GltfLights, ACycleInTheNodeGraphIsAnError) {
  EXPECT_EQ(error_of([] {
              parse_gltf_lights(
                  R"({"extensions": {"KHR_lights_punctual": {"lights": [{"type": "point"}]}},
                      "scenes": [{"nodes": [0]}],
                      "nodes": [{"children": [1]}, {"children": [0]}]})",
                  "t.gltf");
            }),
            "t.gltf: /nodes/0: is its own ancestor (the node graph has a cycle)");
}

std::string gltf_error(const std::string& light, const std::string& node_ext = "{\"light\": 0}") {
  return error_of([&] {
    parse_gltf_lights(R"({"extensions": {"KHR_lights_punctual": {"lights": [)" + light +
                          R"(]}}, "scenes": [{"nodes": [0]}], "nodes": [{"extensions":
                          {"KHR_lights_punctual": )" +
                          node_ext + "}}]}",
                      "t.gltf");
  });
}

TEST(GltfLights, BadFieldsAreOneLineErrorsNamingTheField) {
  const std::string at = "t.gltf: /extensions/KHR_lights_punctual/lights/0";
  EXPECT_EQ(gltf_error(R"({"type": "area"})"),
            at + "/type: must be \"point\", \"spot\" or \"directional\"");
  EXPECT_EQ(gltf_error(R"({"type": "point", "intensity": -1})"),
            at + "/intensity: must not be negative");
  EXPECT_EQ(gltf_error(R"({"type": "point", "color": [1, 1]})"),
            at + "/color: must be an array of 3 numbers");
  EXPECT_EQ(gltf_error(R"({"type": "spot", "spot": {"outerConeAngle": 2}})"),
            at + "/spot/outerConeAngle: must be more than 0 and at most pi/2");
  EXPECT_EQ(
      gltf_error(R"({"type": "spot", "spot": {"innerConeAngle": 0.5, "outerConeAngle": 0.5}})"),
      at + "/spot/innerConeAngle: must be at least 0 and less than outerConeAngle");
  EXPECT_EQ(gltf_error(R"({"type": "point"})", R"({"light": 3})"),
            "t.gltf: /nodes/0/extensions/KHR_lights_punctual/light: must be an index below 1");
}

}  // namespace
}  // namespace tritrace
