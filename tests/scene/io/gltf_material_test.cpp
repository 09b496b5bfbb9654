// glTF materials as Blender's importer reads them: metallic-roughness and transmission textures,
// KHR_materials_ior and emissive_strength, normal maps (computed and file tangents), texture
// transforms with a second coordinate set, vertex colours, and the MikkTSpace-style tangents.
// The files are written by tests/data/gltf/make_material_tests.py; every expected value below is
// computed here from the numbers that script writes (texel bytes, the sRGB curve, the glTF
// specification's formulas), not by the code under test.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/geometric.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "stb_image.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/error.h"
#include "tritrace/image/image.h"
#include "tritrace/job/render_job.h"
#include "tritrace/render/shading_normal.h"
#include "tritrace/scene/io/gltf_materials.h"
#include "tritrace/scene/io/mesh_import.h"
#include "tritrace/scene/io/scene_loader.h"
#include "tritrace/scene/io/tangents.h"

namespace tritrace {
namespace {

const std::string kGltf = std::string(TRITRACE_SOURCE_DIR) + "/tests/data/gltf/";
constexpr double kPi = std::numbers::pi;

double deg(double d) {
  return d * kPi / 180.0;
}

LoadedScene load(const std::string& name) {
  SceneOverrides view;
  view.width = 32;
  view.height = 24;
  return load_scene(kGltf + name, view);
}

// Where a ray straight down onto the quad (y = 0) at (x, z) hits it.
Hit hit_at(const Scene& scene, double x, double z) {
  const BruteForceAccel accel(scene.mesh, Kernel::kWatertight);
  Ray ray;
  ray.origin = glm::vec3(static_cast<float>(x), 1.0f, static_cast<float>(z));
  ray.dir = glm::vec3(0.0f, -1.0f, 0.0f);
  const Hit hit = accel.intersect(ray);
  EXPECT_TRUE(hit.found()) << x << " " << z;
  return hit;
}

// material_params.gltf: metallic 0.8 and roughness 0.5 times a 2 x 1 data texture whose left
// texel is (255, 200, 50) and right (51, 100, 250) (glTF: roughness in G, metalness in B),
// transmission 0.6 times the same texture's R, read as bytes / 255 (no sRGB curve), at the texel
// centres u = 1/4 (x = -1/2) and u = 3/4 (x = 1/2).
TEST(GltfMaterials, MetallicRoughnessAndTransmissionTexturesScaleTheFactors) {
  const Scene scene = load("material_params.gltf").scene;
  ASSERT_FALSE(scene.materials.empty());
  const Material& m = scene.materials[0];
  EXPECT_EQ(m.type, MaterialType::kPrincipled);
  EXPECT_TRUE(m.metallic_roughness_texture.present());
  EXPECT_TRUE(m.transmission_texture.present());
  struct Case {
    double x;
    double r, g, b;
  };
  for (const Case& c : {Case{-0.5, 255, 200, 50}, Case{0.5, 51, 100, 250}}) {
    const Hit h = hit_at(scene, c.x, 0.0);
    const Material at = material_at(scene, m, h.prim, h.u, h.v);
    EXPECT_NEAR(at.metallic, 0.8 * c.b / 255.0, 1e-5) << c.x;
    EXPECT_NEAR(at.roughness, 0.5 * c.g / 255.0, 1e-5) << c.x;
    EXPECT_NEAR(at.transmission, 0.6 * c.r / 255.0, 1e-5) << c.x;
  }
}

// emissiveFactor (0.2, 0.4, 0.8) times KHR_materials_emissive_strength 5; KHR_materials_ior 1.7.
TEST(GltfMaterials, EmissiveStrengthScalesEmissionAndIorIsRead) {
  const Scene scene = load("material_params.gltf").scene;
  const Material& m = scene.materials[0];
  EXPECT_FLOAT_EQ(m.emission.x, 0.2f * 5.0f);
  EXPECT_FLOAT_EQ(m.emission.y, 0.4f * 5.0f);
  EXPECT_FLOAT_EQ(m.emission.z, 0.8f * 5.0f);
  EXPECT_FLOAT_EQ(m.ior, 1.7f);
}

// The radiance of the quad, made Lambertian with albedo 1/2 and keeping its normal map, under the
// file's sun of 683 lux (1 W/m^2) from unit direction `to_light`, where the map gives the tangent
// space normal `m` (the texel bytes decoded as 2 b / 255 - 1, normalised) in the frame
// (tangent, bitangent, normal) written out by hand: albedo / pi * E * max(0, n . l).
void expect_normal_mapped_radiance(const std::string& file, glm::dvec3 tangent,
                                   glm::dvec3 bitangent, glm::dvec3 to_light,
                                   glm::dvec3 texel_bytes) {
  LoadedScene loaded = load(file);
  ASSERT_EQ(loaded.scene.directional_lights.size(), 1u);
  // The file's material (assimp appends a default one after it).
  ASSERT_TRUE(loaded.scene.materials.at(0).normal_texture.present());
  for (Material& m : loaded.scene.materials) {
    m.type = MaterialType::kDiffuse;
    m.albedo = glm::vec3(0.5f);
  }
  JobSettings settings;
  settings.threads = "2";
  settings.spp = "1";
  RenderJob job(settings, std::move(loaded));
  job.prepare();
  const Image image = job.render().image;
  const glm::dvec3 m = glm::normalize(2.0 * texel_bytes / 255.0 - 1.0);
  const glm::dvec3 n = m.x * tangent + m.y * bitangent + m.z * glm::dvec3(0, 1, 0);
  const double want = 0.5 / kPi * std::max(0.0, glm::dot(n, to_light));
  const glm::vec3 centre = image.at(16, 12);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(centre[c], want, 2e-4) << file << " channel " << c;
}

// The quad's texture coordinates grow in u along +x and in glTF's v along +z, so the computed
// tangent is +x and the bitangent (the image's up, +y of the normal map) is -z. A normal tilted
// 30 degrees towards +u under a sun 40 degrees from the vertical on that side is 10 degrees from
// the light (cos 70 degrees if the tangent pointed the other way).
TEST(GltfMaterials, NormalMapTiltsTowardsTheComputedTangent) {
  const double a = deg(30.0), b = deg(40.0);
  const double r = std::round(255 * (std::sin(a) + 1) / 2),
               z = std::round(255 * (std::cos(a) + 1) / 2);
  expect_normal_mapped_radiance("normal_map_u.gltf", {1, 0, 0}, {0, 0, -1},
                                {std::sin(b), std::cos(b), 0}, {r, 128, z});
}

// The green channel below 128 tilts the normal 30 degrees away from the image's up (-z), towards
// +z (the side the default camera sees the quad from: a normal turned away from the viewer would
// fall back to the vertex normal under the shading-normal rule). Under a sun 40 degrees from the
// vertical towards +z it is 10 degrees from the light (70 if the bitangent had the other sign).
TEST(GltfMaterials, NormalMapGreenTiltsAlongTheImagesUp) {
  const double a = deg(30.0), b = deg(40.0);
  const double g = std::round(255 * (1 - std::sin(a)) / 2);
  const double z = std::round(255 * (std::cos(a) + 1) / 2);
  expect_normal_mapped_radiance("normal_map_v.gltf", {1, 0, 0}, {0, 0, -1},
                                {0, std::cos(b), std::sin(b)}, {128, g, z});
}

// TANGENT (0, 0, 1, -1) in the file: tangent +z, bitangent -(+y x +z) = -x; the red tilt now
// leans towards +z.
TEST(GltfMaterials, NormalMapUsesTheFilesTangents) {
  const double a = deg(30.0), b = deg(40.0);
  const double r = std::round(255 * (std::sin(a) + 1) / 2),
               z = std::round(255 * (std::cos(a) + 1) / 2);
  expect_normal_mapped_radiance("normal_map_tangents.gltf", {0, 0, 1}, {-1, 0, 0},
                                {0, std::cos(b), std::sin(b)}, {r, 128, z});
}

double srgb(double byte) {
  const double c = byte / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// texture_transform.gltf: the base colour texture (a 2 x 2 checker, rows from the top (255, 0,
// 0) (0, 255, 0) / (0, 0, 255) (255, 255, 255)) is read through TEXCOORD_1 = (0.3 + 0.2 x,
// 0.6 - 0.1 z) moved by KHR_texture_transform offset (0.25, 0.1), rotation 0.3, scale (2, 0.5)
// (uv' = offset + R S uv with R = [[cos, sin], [-sin, cos]], the matrix of glTF issue 1563 that
// Blender, Babylon.js and three.js use), filtered bilinearly in glTF's texture space (v down,
// repeat), times baseColorFactor (0.8, 0.6, 1) and COLOR_0 = (0.5 + x / 4, 0.5 + z / 4, 1).
TEST(GltfMaterials, TextureTransformSecondCoordinateSetAndVertexColours) {
  const Scene scene = load("texture_transform.gltf").scene;
  const Material& m = scene.materials[0];
  ASSERT_TRUE(m.albedo_texture.present());
  EXPECT_EQ(m.albedo_texture.texcoord, 1);
  const int texels[2][2][3] = {{{255, 0, 0}, {0, 255, 0}}, {{0, 0, 255}, {255, 255, 255}}};
  const auto texel = [&](int i, int j, int c) {
    i = ((i % 2) + 2) % 2;
    j = ((j % 2) + 2) % 2;
    return srgb(texels[j][i][c]);
  };
  const double rot = 0.3, cr = std::cos(rot), sr = std::sin(rot);
  for (const auto& [x, z] : std::vector<std::pair<double, double>>{
           {-0.6, -0.3}, {0.1, 0.7}, {0.55, -0.8}, {0.9, 0.2}, {-0.2, 0.45}}) {
    const double u = 0.3 + 0.2 * x, v = 0.6 - 0.1 * z;
    const double su = 2.0 * u, sv = 0.5 * v;
    const double tu = cr * su + sr * sv + 0.25, tv = -sr * su + cr * sv + 0.1;
    const double px = tu * 2 - 0.5, py = tv * 2 - 0.5;
    const int i = static_cast<int>(std::floor(px)), j = static_cast<int>(std::floor(py));
    const double fx = px - i, fy = py - j;
    const double factor[3] = {0.8, 0.6, 1.0};
    const double colour[3] = {0.5 + 0.25 * x, 0.5 + 0.25 * z, 1.0};
    const Hit h = hit_at(scene, x, z);
    const glm::vec3 got = surface_albedo(scene, m, h.prim, h.u, h.v);
    for (int c = 0; c < 3; ++c) {
      const double t = (1 - fx) * (1 - fy) * texel(i, j, c) + fx * (1 - fy) * texel(i + 1, j, c) +
                       (1 - fx) * fy * texel(i, j + 1, c) + fx * fy * texel(i + 1, j + 1, c);
      EXPECT_NEAR(got[c], factor[c] * t * colour[c], 2e-5) << x << " " << z << " channel " << c;
    }
  }
}

// assimp numbers a glTF file's materials and images in the order its lazy loader meets them, not
// the file's: in Khronos' TextureTransformTest (in assimp-testmodels; CC0) the marker materials
// (Correct, NotSupported, Error) are met, as children of the "Rotation" node, before the arrows'
// materials. Each material must get its own texture and transform: its image's bytes are the PNG
// the JSON names (decoded here by stb_image), and an offset (ox, oy) alone is, with tritrace's v =
// 1 - glTF's, the translation (ox, -oy).
TEST(GltfMaterials, KhronosTextureTransformTestMaterialsKeepTheirOwnTexturesAndTransforms) {
  const std::string dir = "/usr/share/assimp/models/glTF2/textureTransform/";
  if (!std::filesystem::exists(dir + "TextureTransformTest.gltf")) {
    GTEST_SKIP() << "assimp-testmodels not installed";
  }
  const ImportedMesh mesh = import_mesh_file(dir + "TextureTransformTest.gltf");
  const auto image_of = [&](const std::string& png) {
    int w = 0, h = 0, n = 0;
    uint8_t* data = stbi_load((dir + png).c_str(), &w, &h, &n, 3);
    EXPECT_NE(data, nullptr) << png;
    std::vector<uint8_t> bytes(data, data + static_cast<size_t>(w) * h * 3);
    stbi_image_free(data);
    return bytes;
  };
  struct Want {
    std::string material, png;
    float ox, oy;  // expected translation for offset-only materials
    bool moves;
  };
  const std::vector<Want> wants = {
      {"Offset U", "UV.png", 0.5f, 0.0f, true},   {"Offset V", "UV.png", 0.0f, -0.5f, true},
      {"Offset UV", "UV.png", 0.5f, -0.5f, true}, {"Rotation", "Arrow.png", 0, 0, true},
      {"Scale", "Arrow.png", 0, 0, true},         {"All", "Arrow.png", 0, 0, true},
      {"Correct", "Correct.png", 0, 0, false},    {"Error", "Error.png", 0, 0, false}};
  for (const Want& want : wants) {
    size_t k = 0;
    while (k < mesh.material_names.size() && mesh.material_names[k] != want.material) ++k;
    ASSERT_LT(k, mesh.materials.size()) << want.material;
    const TextureRef& ref = mesh.materials[k].albedo_texture;
    ASSERT_TRUE(ref.present()) << want.material;
    EXPECT_EQ(mesh.textures.at(static_cast<size_t>(ref.index)).rgb, image_of(want.png))
        << want.material;
    EXPECT_EQ(ref.moves(), want.moves) << want.material;
    if (want.material.rfind("Offset", 0) == 0) {
      EXPECT_FLOAT_EQ(ref.transform[0], 1.0f);
      EXPECT_FLOAT_EQ(ref.transform[3], 1.0f);
      EXPECT_NEAR(ref.transform[4], want.ox, 1e-6) << want.material;
      EXPECT_NEAR(ref.transform[5], want.oy, 1e-6) << want.material;
    }
  }
}

// A document whose one node draws material 0 (assimp reads only the materials drawn).
std::string drawing(const std::string& material) {
  return R"({"scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
             "meshes": [{"primitives": [{"attributes": {}, "material": 0}]}],
             "materials": [)" +
         material + "]}";
}

TEST(GltfMaterials, BadTextureReferencesAreOneLineErrorsNamingTheField) {
  try {
    parse_gltf_materials(drawing(R"({"normalTexture": {"index": 7}})"), "m.gltf");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "m.gltf");
    EXPECT_EQ(e.reason(), "/materials/0/normalTexture/index: must be an index below 0");
  }
  EXPECT_THROW(parse_gltf_materials(drawing(R"({"emissiveFactor": [1, 2]})"), "m.gltf"), Error);
  EXPECT_THROW(parse_gltf_materials("{", "m.gltf"), Error);
}

// The unit square at z = 0 with normal +z and two triangles, counter-clockwise.
const std::vector<glm::vec3> kSquare = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
const std::vector<uint32_t> kTwoTriangles = {0, 1, 2, 0, 2, 3};

void expect_tangents(const std::vector<glm::vec4>& got, glm::dvec3 want, double w) {
  ASSERT_EQ(got.size(), kTwoTriangles.size());
  for (const glm::vec4& t : got) {
    EXPECT_NEAR(t.x, want.x, 1e-6);
    EXPECT_NEAR(t.y, want.y, 1e-6);
    EXPECT_NEAR(t.z, want.z, 1e-6);
    EXPECT_EQ(t.w, w);
  }
}

// u = x, v = y: the tangent dp/du = +x, and w cross(n, t) = +y = dp/dv with w = +1.
TEST(MikktspaceTangents, FollowTheTextureCoordinates) {
  const std::vector<glm::vec3> normals(4, glm::vec3(0, 0, 1));
  const std::vector<glm::vec2> uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  expect_tangents(mikktspace_tangents(kSquare, normals, uvs, kTwoTriangles), {1, 0, 0}, 1.0);
}

// u = 1 - x (a mirrored texture): dp/du = -x, and cross(+z, -x) = -y is dp/dv's opposite: w = -1.
TEST(MikktspaceTangents, AMirroredTextureFlipsTheBitangentSign) {
  const std::vector<glm::vec3> normals(4, glm::vec3(0, 0, 1));
  const std::vector<glm::vec2> uvs = {{1, 0}, {0, 0}, {0, 1}, {1, 1}};
  expect_tangents(mikktspace_tangents(kSquare, normals, uvs, kTwoTriangles), {-1, 0, 0}, -1.0);
}

// u = x, v = x + y (a sheared map): p = (u, v - u), so dp/du = (1, -1, 0), normalised.
TEST(MikktspaceTangents, AreTheDerivativeAlongUNotTheUAxisOfTheTexture) {
  const std::vector<glm::vec3> normals(4, glm::vec3(0, 0, 1));
  std::vector<glm::vec2> uvs;
  for (const glm::vec3& p : kSquare) uvs.emplace_back(p.x, p.x + p.y);
  const double s = 1.0 / std::sqrt(2.0);
  expect_tangents(mikktspace_tangents(kSquare, normals, uvs, kTwoTriangles), {s, -s, 0}, 1.0);
}

// Vertex normals (0.6, 0, 0.8): the tangent is +x made perpendicular to them,
// (1, 0, 0) - 0.6 (0.6, 0, 0.8) = (0.64, 0, -0.48), normalised (0.8, 0, -0.6).
TEST(MikktspaceTangents, ArePerpendicularToTheVertexNormals) {
  const std::vector<glm::vec3> normals(4, glm::vec3(0.6f, 0.0f, 0.8f));
  const std::vector<glm::vec2> uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  expect_tangents(mikktspace_tangents(kSquare, normals, uvs, kTwoTriangles), {0.8, 0, -0.6}, 1.0);
}

}  // namespace
}  // namespace tritrace
