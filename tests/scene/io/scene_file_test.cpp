// JSON scene files: the lab scene written out loads bit for bit like the built-in one, and each
// kind of mistake gets its own message, with the location computed by hand from the test's text.
#include "tritrace/scene/io/scene_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <utility>

#include "tritrace/error.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/io/scene_loader.h"
#include "tritrace/scene/io/transform.h"
#include "tritrace/scene/io/triangle_filter.h"
#include "tritrace/scene/procedural.h"

#ifndef TRITRACE_SOURCE_DIR
#error "TRITRACE_SOURCE_DIR must name the source tree"
#endif

namespace tritrace {
namespace {

const std::string kCornellJson = std::string(TRITRACE_SOURCE_DIR) + "/scenes/cornell.json";

// A valid scene with one inline triangle, for tests that change one thing.
constexpr char kOneTriangle[] =
    R"("meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]]}])";

LoadedScene parse(const std::string& text) {
  LoadedScene s = parse_scene_json(text, "test.json");
  apply_overrides(s, {});
  return s;
}

// The reason of the Error parsing `text` throws.
std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "test.json");
    EXPECT_EQ(e.reason().find('\n'), std::string::npos);
    return e.reason();
  }
  ADD_FAILURE() << "no error for: " << text;
  return "";
}

// The reason of the Error parsing a scene of one triangle and the single material `material`
// (a JSON object) throws.
std::string material_error(const std::string& material) {
  return error_of(R"({"materials": [)" + material + "], " + std::string(kOneTriangle) + "}");
}

void expect_bits_equal(const HugePageVector<glm::vec3>& a, const HugePageVector<glm::vec3>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(std::memcmp(&a[i], &b[i], sizeof(glm::vec3)), 0) << "triangle " << i;
  }
}

// A mesh file's triangles as the importer gives them: a grid of quads with two materials, vertex
// normals (some zero) and texture coordinates, some triangles degenerate and some non-finite.
ImportedMesh grid_mesh(size_t side) {
  ImportedMesh m;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (size_t i = 0; i < side; ++i) {
    for (size_t j = 0; j < side; ++j) {
      const float x = static_cast<float>(i) * 0.01f, z = static_cast<float>(j) * 0.01f;
      const float y = std::sin(x * 7.0f) * std::cos(z * 5.0f);
      glm::vec3 p[3] = {{x, y, z}, {x + 0.01f, y, z}, {x, y * 0.5f, z + 0.01f}};
      if ((i * side + j) % 97 == 0) p[2] = p[0];
      if ((i * side + j) % 89 == 0) p[1].x = nan;
      for (int k = 0; k < 3; ++k) {
        m.corners.push_back(p[k]);
        m.normals.push_back((i + j + k) % 13 == 0 ? glm::vec3(0.0f) : glm::vec3(y, 1.0f, x - z));
        m.uvs.push_back(glm::vec2(x, z + static_cast<float>(k)));
      }
      m.material.push_back(static_cast<uint32_t>((i + j) % 2));
    }
  }
  m.materials = {Material{.albedo = glm::vec3(0.2f)}, Material{.albedo = glm::vec3(0.7f)}};
  m.material_names = {"a", "b"};
  m.meshes = 1;
  return m;
}

// The scene file's mesh files are added in parallel (add_all_checked); the oracle here adds them
// triangle by triangle with add_checked, after the generator's triangles in the scene's mesh and
// into an instanced mesh's prototype, moved and renumbered as the file asks.
TEST(SceneFile, MeshFilesAddAsTriangleByTriangle) {
  const ImportedMesh file = grid_mesh(300);  // 90000 triangles: more than one parallel chunk
  SceneFileOptions options;
  options.read_mesh = [&](const std::string&) { return file; };
  const LoadedScene loaded = parse_scene_json(R"({"materials": [{"name": "m", "albedo": [1, 0, 0]}],
    "meshes": [{"generator": "cornell"},
      {"file": "a.ply", "transform": {"translate": [1, 2, 3], "scale": [2, -0.5, 1]}},
      {"file": "b.ply", "material": "m", "transform": {"scale": 3},
       "instances": [{}, {"translate": [0, 0, 4]}]}]})",
                                              "test.json", options);
  const Scene cornell = make_builtin_scene("cornell");
  const auto one_by_one = [&](TriangleMesh& mesh, const Transform& t,
                              std::optional<uint32_t> material, uint32_t offset, LoadStats& stats) {
    for (size_t k = 0; k < file.triangles(); ++k) {
      glm::vec3 v[3], n[3];
      for (size_t i = 0; i < 3; ++i) {
        v[i] = t.apply(file.corners[3 * k + i]);
        n[i] = t.apply_normal(file.normals[3 * k + i]);
      }
      add_checked(mesh, v[0], v[1], v[2], material ? *material : offset + file.material[k], n,
                  &file.uvs[3 * k], stats);
    }
  };
  TriangleMesh want, prototype;
  want.append(cornell.mesh, 1);
  LoadStats stats;
  Transform moved;
  moved.translate = glm::vec3(1, 2, 3);
  moved.scale = glm::vec3(2, -0.5f, 1);
  const uint32_t offset = static_cast<uint32_t>(1 + cornell.materials.size());
  one_by_one(want, moved, std::nullopt, offset, stats);
  Transform scaled;
  scaled.scale = glm::vec3(3.0f);
  one_by_one(prototype, scaled, 0u, 0, stats);

  const Scene& got = loaded.scene;
  EXPECT_EQ(got.materials.size(), offset + file.materials.size());
  EXPECT_EQ(loaded.stats.dropped_degenerate, stats.dropped_degenerate);
  EXPECT_EQ(loaded.stats.dropped_non_finite, stats.dropped_non_finite);
  ASSERT_GT(stats.dropped_degenerate, 0u);
  ASSERT_GT(stats.dropped_non_finite, 0u);
  ASSERT_EQ(got.prototypes.size(), 1u);
  EXPECT_EQ(got.instances.size(), 2u);
  for (const auto& [g, w] :
       {std::pair(&got.mesh, &want), std::pair(&got.prototypes[0], &prototype)}) {
    ASSERT_EQ(g->size(), w->size());
    expect_bits_equal(g->v0(), w->v0());
    expect_bits_equal(g->v1(), w->v1());
    expect_bits_equal(g->v2(), w->v2());
    expect_bits_equal(g->normal(), w->normal());
    expect_bits_equal(g->corner_normals(), w->corner_normals());
    EXPECT_EQ(g->material(), w->material());
    ASSERT_EQ(g->corner_uvs().size(), w->corner_uvs().size());
    EXPECT_EQ(std::memcmp(g->corner_uvs().data(), w->corner_uvs().data(),
                          w->corner_uvs().size() * sizeof(glm::vec2)),
              0);
  }
}

TEST(SceneFile, CornellJsonIsTheBuiltInSceneBitForBit) {
  const LoadedScene loaded = load_scene(kCornellJson);
  const Scene built_in = make_cornell_box();
  const Scene& s = loaded.scene;
  ASSERT_EQ(s.mesh.size(), 30u);
  expect_bits_equal(s.mesh.v0(), built_in.mesh.v0());
  expect_bits_equal(s.mesh.v1(), built_in.mesh.v1());
  expect_bits_equal(s.mesh.v2(), built_in.mesh.v2());
  expect_bits_equal(s.mesh.normal(), built_in.mesh.normal());
  for (size_t i = 0; i < 30; ++i) {
    EXPECT_EQ(s.materials[s.mesh.material()[i]].albedo,
              built_in.materials[built_in.mesh.material()[i]].albedo)
        << "triangle " << i;
  }
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].position, kLabLightPosition);
  EXPECT_EQ(s.lights[0].power, kLabLightPower);
  EXPECT_EQ(s.ambient, kLabAmbient);
  for (int y = 0; y < 500; y += 7) {
    for (int x = 0; x < 500; x += 7) {
      const Ray a = s.camera.primary_ray(x, y), b = built_in.camera.primary_ray(x, y);
      ASSERT_EQ(a.origin, b.origin);
      ASSERT_EQ(a.dir, b.dir) << x << "," << y;
    }
  }
  EXPECT_EQ(loaded.output, "cornell.png");
}

TEST(SceneFile, CornellGeneratorCopiesTheBuiltInTriangles) {
  const LoadedScene s = parse(R"({"meshes": [{"generator": "cornell"}]})");
  const Scene built_in = make_cornell_box();
  expect_bits_equal(s.scene.mesh.v0(), built_in.mesh.v0());
  expect_bits_equal(s.scene.mesh.v1(), built_in.mesh.v1());
  expect_bits_equal(s.scene.mesh.v2(), built_in.mesh.v2());
}

TEST(SceneFile, DefaultsAreTheLabsCameraAndAmbient) {
  const LoadedScene s = parse(std::string("{") + kOneTriangle + "}");
  EXPECT_EQ(s.scene.camera.width(), 500);
  EXPECT_EQ(s.scene.camera.focal_px(), 500.0f);
  EXPECT_EQ(s.scene.camera.position(), glm::vec3(0, 0, -3));
  EXPECT_EQ(s.scene.ambient, kLabAmbient);
  EXPECT_TRUE(s.scene.lights.empty());
  ASSERT_EQ(s.scene.materials.size(), 1u);  // the neutral grey default
  EXPECT_EQ(s.scene.materials[0].albedo, kNeutralGrey);
}

TEST(SceneFile, VerticalFovSetsTheFocalLength) {
  // 90 degrees over 400 rows: f = 200 / tan(45 degrees) = 200.
  const LoadedScene s = parse(std::string(R"({"camera": {"vertical_fov": 90, "height": 400}, )") +
                              kOneTriangle + "}");
  EXPECT_NEAR(s.scene.camera.focal_px(), 200.0f, 1e-3f);
}

TEST(SceneFile, LookAtCameraPointsAtTheTarget) {
  const LoadedScene s =
      parse(std::string(R"({"camera": {"position": [5, 0, 0], "look_at": [0, 0, 0], "up": [0, 1, 0],
                     "width": 100, "height": 100}, )") +
            kOneTriangle + "}");
  const Ray centre = s.scene.camera.primary_ray(50, 50);
  EXPECT_EQ(centre.origin, glm::vec3(5, 0, 0));
  EXPECT_NEAR(centre.dir.x, -1.0f, 1e-6f);
  // Up is +y, so the top row looks upward.
  EXPECT_GT(s.scene.camera.primary_ray(50, 0).dir.y, 0.0f);
}

TEST(SceneFile, TransformScalesRotatesThenTranslates) {
  // (1,0,0) scaled by 2 -> (2,0,0), rotated 90 degrees about z -> (0,2,0), translated -> (1,2,3).
  const LoadedScene s = parse(R"({"meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]],
      "triangles": [[0,1,2]],
      "transform": {"scale": 2, "rotate": [0, 0, 90], "translate": [1, 0, 3]}}]})");
  const glm::vec3 v0 = s.scene.mesh.vertex(0, 0), v1 = s.scene.mesh.vertex(0, 1);
  EXPECT_NEAR(v0.x, 1.0f, 1e-6f);
  EXPECT_NEAR(v0.z, 3.0f, 1e-6f);
  EXPECT_NEAR(v1.x, 1.0f, 1e-6f);
  EXPECT_NEAR(v1.y, 2.0f, 1e-6f);
  EXPECT_NEAR(v1.z, 3.0f, 1e-6f);
}

TEST(SceneFile, MaterialsAreFoundByName) {
  const LoadedScene s = parse(R"({"materials": [{"name": "a", "albedo": [1, 0, 0]},
      {"name": "b", "albedo": [0, 1, 0]}],
      "meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]], "material": "b"}]})");
  EXPECT_EQ(s.scene.materials[s.scene.mesh.material()[0]].albedo, glm::vec3(0, 1, 0));
}

TEST(SceneFile, DegenerateAndNonFiniteTrianglesAreDroppedAndCounted) {
  // Triangle 1 repeats a vertex; triangle 2 spans 3e38 to -3e38, whose edge overflows a float.
  const LoadedScene s = parse(R"({"meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0],
      [3e38,0,0],[-3e38,0,0]], "triangles": [[0,1,2],[0,1,1],[3,4,2]]}]})");
  EXPECT_EQ(s.scene.mesh.size(), 1u);
  EXPECT_EQ(s.stats.dropped_degenerate, 1u);
  EXPECT_EQ(s.stats.dropped_non_finite, 1u);
}

TEST(SceneFileErrors, MalformedJsonReportsLineAndColumn) {
  // The stray comma is on line 3, column 14 (1-based).
  const std::string reason = error_of("{\n  \"meshes\": [\n    {\"file\": ,}\n  ]\n}");
  EXPECT_NE(reason.find("invalid JSON at line 3, column 14"), std::string::npos) << reason;
}

TEST(SceneFileErrors, OverflowingNumberReportsItsPosition) {
  const std::string reason = error_of("{\"ambient\": [1, 1e999, 1]}");
  EXPECT_NE(reason.find("line 1, column 17"), std::string::npos) << reason;
  EXPECT_NE(reason.find("1e999 is out of range"), std::string::npos) << reason;
}

TEST(SceneFileErrors, UnknownKeySuggestsTheNearestKnownKey) {
  EXPECT_EQ(error_of("{\"camra\": {}}"), "/: unknown key 'camra' (did you mean 'camera'?)");
  EXPECT_EQ(error_of("{\"camera\": {\"lookat\": [0,0,0]}}"),
            "/camera: unknown key 'lookat' (did you mean 'look_at'?)");
}

TEST(SceneFileErrors, EachRuleHasItsMessage) {
  const std::string tri = kOneTriangle;
  EXPECT_EQ(error_of("[1, 2]"), "a scene must be a JSON object, got an array");
  EXPECT_EQ(error_of("{\"ambient\": \"bright\", " + tri + "}"),
            "/ambient: must be an array of 3 numbers, got 'bright'");
  EXPECT_EQ(error_of("{\"ambient\": [1, true, 1], " + tri + "}"),
            "/ambient/1: must be a number, got true");
  EXPECT_EQ(error_of("{\"ambient\": [1, -1, 1], " + tri + "}"), "/ambient/1: must not be negative");
  EXPECT_EQ(error_of("{\"ambient\": [1, 1e39, 1], " + tri + "}"),
            "/ambient/1: is out of range for a 32-bit float, got 1e+39");
  EXPECT_EQ(error_of("{\"camera\": {\"width\": -5}, " + tri + "}"),
            "/camera/width: must be an integer from 1 to 16384, got -5");
  EXPECT_EQ(error_of("{\"camera\": {\"height\": 2.5}, " + tri + "}"),
            "/camera/height: must be an integer from 1 to 16384, got 2.5");
  EXPECT_EQ(error_of("{\"camera\": {\"vertical_fov\": 180}, " + tri + "}"),
            "/camera/vertical_fov: must be between 0 and 180 degrees (exclusive), got 180");
  EXPECT_EQ(error_of("{\"camera\": {\"look_at\": [0, 0, -3]}, " + tri + "}"),
            "/camera: position and look_at must differ, and up must not be parallel to the "
            "viewing direction");
  EXPECT_EQ(error_of("{\"lights\": [{\"position\": [0,0,0], \"power\": [1,-2,1]}], " + tri + "}"),
            "/lights/0/power/1: must not be negative");
  EXPECT_EQ(error_of("{}"), "no geometry: the scene has no \"meshes\"");
  EXPECT_EQ(error_of("{\"meshes\": []}"), "/meshes: no geometry: the list is empty");
  EXPECT_EQ(error_of(R"({"meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": []}]})"),
            "/meshes/0/triangles: mesh has no triangles");
  EXPECT_EQ(
      error_of(R"({"meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,3]]}]})"),
      "/meshes/0/triangles/0/2: index 3 out of range (0 to 2)");
  EXPECT_EQ(
      error_of(R"({"meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,1]]}]})"),
      "no geometry: every triangle was degenerate or non-finite (1 degenerate, 0 non-finite)");
  EXPECT_EQ(error_of(R"({"meshes": [{"generator": "terrian"}]})"),
            "/meshes/0/generator: unknown generator 'terrian' (use " +
                std::string(kBuiltinSceneHelp) + ")");
  EXPECT_EQ(error_of(R"({"materials": [{"name": "red", "albedo": [1,0,0]}],
      "meshes": [{"generator": "cornell", "material": "rde"}]})"),
            "/meshes/0/material: unknown material 'rde' (did you mean 'red'?)");
  EXPECT_EQ(error_of(R"({"meshes": [{"generator": "cornell", "file": "x.obj"}]})"),
            "/meshes/0: needs exactly one source: \"file\", \"generator\", or \"positions\" with "
            "\"triangles\"");
  EXPECT_EQ(error_of(R"({"meshes": [{"file": "other.json"}]})"),
            "/meshes/0/file: 'other.json' is a scene file; a scene cannot include another "
            "scene, only mesh files");
  EXPECT_EQ(error_of(R"({"output": {"file": "x.jpg"}, )" + tri + "}"),
            "/output/file: 'x.jpg' has an unknown extension (use .png, .ppm, .pfm or .exr)");
}

TEST(SceneFileErrors, MissingMeshFileNamesTheFileAndTheScene) {
  try {
    parse_scene_json(R"({"meshes": [{"file": "gone.obj"}]})", "dir/test.json");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "dir/gone.obj");
    EXPECT_EQ(e.reason(), "file not found (referenced by dir/test.json at /meshes/0/file)");
  }
}

TEST(EditDistance, CountsInsertionsDeletionsAndSubstitutions) {
  EXPECT_EQ(edit_distance("", ""), 0u);
  EXPECT_EQ(edit_distance("camra", "camera"), 1u);
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(edit_distance("abc", ""), 3u);
}

}  // namespace
}  // namespace tritrace

namespace tritrace {
namespace {

// One triangle placed three times: stored once, drawn three times, each copy where "transform"
// would have put it.
TEST(SceneFileInstances, PlaceTheMeshOncePerTransformWithoutCopying) {
  const LoadedScene s = parse(R"({"meshes": [
      {"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]]},
      {"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]],
       "instances": [{}, {"translate": [2, 0, 0]}, {"scale": [2, -1, 1], "translate": [0, 0, 5]}]}]})");
  const Scene& scene = s.scene;
  EXPECT_EQ(scene.mesh.size(), 1u);
  ASSERT_EQ(scene.prototypes.size(), 1u);
  EXPECT_EQ(scene.prototypes[0].size(), 1u);
  ASSERT_EQ(scene.instances.size(), 3u);
  EXPECT_EQ(scene.drawn_triangles(), 4u);
  EXPECT_EQ(scene.stored_triangles(), 2u);
  const Scene flat = flattened(scene);
  ASSERT_EQ(flat.mesh.size(), 4u);
  EXPECT_EQ(flat.mesh.vertex(2, 1), glm::vec3(3, 0, 0));
  EXPECT_EQ(flat.mesh.vertex(3, 1), glm::vec3(2, 0, 5));
  EXPECT_EQ(flat.mesh.vertex(3, 2), glm::vec3(0, -1, 5));
  // The third copy is mirrored (scale -1 in y): normalize(cross(e2, e1)) of its moved vertices,
  // by hand (0, -1, 0) x (2, 0, 0) = (0, 0, 2), so +z where the unmirrored copy faces -z: the
  // inverse transpose's -z flipped by the negative determinant.
  EXPECT_EQ(scene.triangle(3).normal, -scene.triangle(1).normal);
  EXPECT_EQ(scene.triangle(3).normal, flat.mesh.normal()[3]);
}

TEST(SceneFileInstances, AGeneratedMeshCanBeInstancedAndTransformedFirst) {
  const LoadedScene s = parse(R"({"meshes": [{"generator": "cornell",
      "transform": {"scale": 0.5}, "instances": [{"translate": [-1, 0, 0]}, {"translate": [1, 0, 0]}]}]})");
  EXPECT_TRUE(s.scene.mesh.empty());
  ASSERT_EQ(s.scene.prototypes.size(), 1u);
  EXPECT_EQ(s.scene.instances.size(), 2u);
  const Bounds3 b = scene_bounds(s.scene);
  EXPECT_FLOAT_EQ(b.lo.x, -1.5f);
  EXPECT_FLOAT_EQ(b.hi.x, 1.5f);
}

TEST(SceneFileErrors, InstancesRulesHaveTheirMessages) {
  const std::string mesh =
      R"({"meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]], "instances": )";
  EXPECT_EQ(error_of(mesh + "5}]}"), "/meshes/0/instances: must be a list of transforms, got 5");
  EXPECT_EQ(error_of(mesh + "[]}]}"),
            "/meshes/0/instances: must list at least one transform (an empty list draws nothing)");
  EXPECT_EQ(error_of(mesh + R"([{}, {}, {}, {"scale": 0}]}]})"),
            "/meshes/0/instances/3/scale: must not be zero");
  EXPECT_EQ(error_of(mesh + R"([{}, {"translate": [1, 2]}]}]})"),
            "/meshes/0/instances/1/translate: must be an array of 3 numbers, got 2 elements");
  EXPECT_EQ(error_of(mesh + R"([{"scale": 1e-39}]}]})"),
            "/meshes/0/instances/0: the transform is not invertible");
}

TEST(SceneFileMaterials, ReadsTypesAndTheirKeys) {
  const std::string tri = kOneTriangle;
  const LoadedScene s = parse(R"({"materials": [
      {"name": "d", "albedo": [0.5, 0.5, 0.5]},
      {"name": "gold", "type": "conductor", "albedo": [1, 0.8, 0.3], "roughness": 0.25},
      {"name": "glass", "type": "dielectric", "ior": 1.33},
      {"name": "p", "type": "principled", "albedo": [0.2, 0.3, 0.4], "metallic": 0.5,
       "roughness": 0.7, "ior": 1.45, "transmission": 0.25}], )" +
                              tri + "}");
  ASSERT_GE(s.scene.materials.size(), 4u);  // then the inline mesh's default grey
  const Material& d = s.scene.materials[0];
  EXPECT_EQ(d.type, MaterialType::kDiffuse);
  const Material& gold = s.scene.materials[1];
  EXPECT_EQ(gold.type, MaterialType::kConductor);
  EXPECT_EQ(gold.albedo, glm::vec3(1.0f, 0.8f, 0.3f));
  EXPECT_EQ(gold.roughness, 0.25f);
  const Material& glass = s.scene.materials[2];
  EXPECT_EQ(glass.type, MaterialType::kDielectric);
  EXPECT_EQ(glass.ior, 1.33f);
  EXPECT_EQ(glass.albedo, glm::vec3(1.0f));  // clear by default
  EXPECT_EQ(glass.roughness, 0.0f);
  const Material& p = s.scene.materials[3];
  EXPECT_EQ(p.type, MaterialType::kPrincipled);
  EXPECT_EQ(p.metallic, 0.5f);
  EXPECT_EQ(p.roughness, 0.7f);
  EXPECT_EQ(p.ior, 1.45f);
  EXPECT_EQ(p.transmission, 0.25f);
}

TEST(SceneFileMaterials, ConductorTakesAComplexIndex) {
  const LoadedScene s = parse(R"({"materials": [{"name": "gold", "type": "conductor",
      "eta": [0.18, 0.42, 1.37], "k": [3.4, 2.35, 1.85], "roughness": 0.2}], )" +
                              std::string(kOneTriangle) + "}");
  const Material& gold = s.scene.materials[0];
  EXPECT_EQ(gold.type, MaterialType::kConductor);
  EXPECT_TRUE(gold.has_complex_ior());
  EXPECT_EQ(gold.conductor_eta, glm::vec3(0.18f, 0.42f, 1.37f));
  EXPECT_EQ(gold.conductor_k, glm::vec3(3.4f, 2.35f, 1.85f));
  // albedo becomes the reflectance at normal incidence: ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
  EXPECT_NEAR(gold.albedo.x, (0.82 * 0.82 + 3.4 * 3.4) / (1.18 * 1.18 + 3.4 * 3.4), 1e-6);
  const auto with = material_error;
  EXPECT_EQ(with(R"({"name": "m", "type": "conductor", "eta": [1, 1, 1]})"),
            "/materials/0: missing \"k\" (a complex index needs both eta and k)");
  EXPECT_EQ(with(R"({"name": "m", "type": "conductor", "k": [1, 1, 1]})"),
            "/materials/0: missing \"eta\" (a complex index needs both eta and k)");
  EXPECT_EQ(with(R"({"name": "m", "type": "conductor", "albedo": [1, 1, 1], "eta": [1, 1, 1],
                     "k": [1, 1, 1]})"),
            "/materials/0/albedo: a conductor takes albedo or eta and k, not both");
  EXPECT_EQ(with(R"({"name": "m", "albedo": [1, 1, 1], "eta": [1, 1, 1], "k": [1, 1, 1]})"),
            "/materials/0/eta: only conductor materials have it");
  EXPECT_EQ(with(R"({"name": "m", "type": "conductor", "eta": [0, 1, 1], "k": [1, 1, 1]})"),
            "/materials/0/eta/0: must be from 0.01 to 10, got 0");
  EXPECT_EQ(with(R"({"name": "m", "type": "conductor", "eta": [1, 1, 1], "k": [1, -1, 1]})"),
            "/materials/0/k/1: must not be negative");
  EXPECT_EQ(with(R"({"name": "m", "type": "conductor", "eta": [1, 1, 1], "k": [1, 1, 200]})"),
            "/materials/0/k/2: must be from 0 to 100, got 200");
}

TEST(SceneFileMaterials, EachRuleHasItsMessage) {
  const auto with = material_error;
  EXPECT_EQ(with(R"({"name": "m", "type": "metal", "albedo": [1,1,1]})"),
            "/materials/0/type: unknown material type 'metal' (use diffuse, conductor, dielectric "
            "or principled)");
  EXPECT_EQ(with(R"({"name": "m", "type": 3, "albedo": [1,1,1]})"),
            "/materials/0/type: must be a string, got 3");
  EXPECT_EQ(with(R"({"name": "m", "type": "conductor"})"), "/materials/0: missing \"albedo\"");
  EXPECT_EQ(with(R"({"name": "m", "albedo": [1,1,1], "roughness": 0.5})"),
            "/materials/0/roughness: only conductor, dielectric and principled materials have it");
  EXPECT_EQ(with(R"({"name": "m", "type": "conductor", "albedo": [1,1,1], "ior": 1.5})"),
            "/materials/0/ior: only dielectric and principled materials have it");
  EXPECT_EQ(with(R"({"name": "m", "type": "dielectric", "metallic": 1})"),
            "/materials/0/metallic: only principled materials have it");
  EXPECT_EQ(with(R"({"name": "m", "type": "conductor", "albedo": [1,1,1], "roughness": 1.5})"),
            "/materials/0/roughness: must be from 0 to 1, got 1.5");
  EXPECT_EQ(with(R"({"name": "m", "type": "principled", "albedo": [1,1,1], "metallic": -0.1})"),
            "/materials/0/metallic: must be from 0 to 1, got -0.1");
  EXPECT_EQ(with(R"({"name": "m", "type": "dielectric", "ior": 0})"),
            "/materials/0/ior: must be from 0.1 to 10, got 0");
  // Within 0.0001 of 1 (but not 1) the BSDFs cannot refract: a rough interface's half vector
  // cancels to rounding (bsdf.cpp); 1 itself is an invisible interface.
  EXPECT_EQ(with(R"({"name": "m", "type": "dielectric", "roughness": 0.5, "ior": 1.00001})"),
            "/materials/0/ior: must be 1 or differ from 1 by at least 0.0001 (closer to 1, a rough "
            "surface's refraction is lost to float rounding), got 1.00001");
  EXPECT_EQ(with(R"({"name": "m", "type": "principled", "albedo": [1,1,1], "ior": 0.99995})"),
            "/materials/0/ior: must be 1 or differ from 1 by at least 0.0001 (closer to 1, a rough "
            "surface's refraction is lost to float rounding), got 0.99995");
  for (const char* ior : {"1", "1.0001", "0.9999"}) {
    EXPECT_NO_THROW(parse(R"({"materials": [{"name": "m", "type": "dielectric", "ior": )" +
                          std::string(ior) + "}], " + std::string(kOneTriangle) + "}"))
        << ior;
  }
  EXPECT_EQ(with(R"({"name": "m", "type": "dielectric", "ior": "glass"})"),
            "/materials/0/ior: must be a number, got 'glass'");
  EXPECT_EQ(with(R"({"name": "m", "type": "dielectric", "albedo": [1, 2, 1]})"),
            "/materials/0/albedo/1: must be at most 1");
}

}  // namespace
}  // namespace tritrace
