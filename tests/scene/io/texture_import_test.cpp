// Texture coordinates, textures and materials from model files: an OBJ quad whose rendered pixels
// are its map_Kd texels (expected values from the texel bytes, the sRGB curve and bilinear
// interpolation written here), missing textures as errors, JSON albedo_texture, and the
// testmodels' glTF files against their own JSON (BoxTextured's texture and sampler,
// 2CylinderEngine's base colours and normals).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stb_image.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/error.h"
#include "tritrace/render/film.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/mesh_import.h"
#include "tritrace/scene/io/scene_file.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;

double srgb_closed_form(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// Bilinear interpolation of 8-bit sRGB texels (row 0 at the top, v up), repeating, from the
// definition: the texel centres around (u, v) weighted by the distances to them.
glm::dvec3 bilinear_repeat(const std::vector<uint8_t>& rgb, int w, int h, double u, double v) {
  const double x = u * w - 0.5, y = (1.0 - v) * h - 0.5;
  const int i = static_cast<int>(std::floor(x)), j = static_cast<int>(std::floor(y));
  auto texel = [&](int a, int b) {
    a = ((a % w) + w) % w;
    b = ((b % h) + h) % h;
    const size_t k = 3 * (static_cast<size_t>(b) * w + a);
    return glm::dvec3(srgb_closed_form(rgb[k] / 255.0), srgb_closed_form(rgb[k + 1] / 255.0),
                      srgb_closed_form(rgb[k + 2] / 255.0));
  };
  const double a = x - i, b = y - j;
  return (1 - a) * (1 - b) * texel(i, j) + a * (1 - b) * texel(i + 1, j) +
         (1 - a) * b * texel(i, j + 1) + a * b * texel(i + 1, j + 1);
}

class TexturedFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("tritrace-tex-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name, const std::string& bytes) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  // A binary PPM, which stb_image reads: exact bytes, no compression.
  static std::string ppm(int w, int h, const std::vector<uint8_t>& rgb) {
    return "P6\n" + std::to_string(w) + " " + std::to_string(h) + "\n255\n" +
           std::string(rgb.begin(), rgb.end());
  }
  // The quad [-1, 1]^2 at z = 0 with texture coordinates (x + 1) / 2, (y + 1) / 2 and material m.
  static std::string quad_obj(const std::string& mtl) {
    return "mtllib " + mtl +
           "\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
           "usemtl m\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
  }
  fs::path dir_;
};

// An albedo-textured diffuse quad alone in a uniform environment of radiance 1: every path
// reflects once, with weight albedo, and escapes, so a pixel is the mean of the texture over the
// part of the quad it sees, which (a texel spans eight pixels) is the bilinear value at its centre
// to within the texture's change across a pixel.
TEST_F(TexturedFiles, ObjQuadShowsItsMapKdTexels) {
  std::vector<uint8_t> rgb;
  for (int k = 0; k < 16; ++k) {
    rgb.insert(rgb.end(), {static_cast<uint8_t>(16 * k + 5), static_cast<uint8_t>(250 - 13 * k),
                           static_cast<uint8_t>(k % 3 == 0 ? 200 : 40)});
  }
  file("tex.ppm", ppm(4, 4, rgb));
  file("quad.mtl", "newmtl m\nKd 1 1 1\nmap_Kd tex.ppm\n");
  file("quad.obj", quad_obj("quad.mtl"));
  // tan(fov / 2) = 0.5 from a distance of 2: the quad fills the view.
  const std::string json = R"({"camera": {"position": [0, 0, -2], "look_at": [0, 0, 0],
      "up": [0, -1, 0], "vertical_fov": 53.13010235415598, "width": 32, "height": 32},
      "environment": {"color": [1, 1, 1]}, "meshes": [{"file": "quad.obj"}]})";
  LoadedScene loaded = parse_scene_json(json, (dir_ / "scene.json").string());
  apply_overrides(loaded, {});
  const Scene& scene = loaded.scene;
  ASSERT_EQ(scene.textures.size(), 1u);
  ASSERT_TRUE(scene.mesh.has_uvs());
  // The quad's material (assimp adds a default material to OBJ files, unused here).
  const Material& quad = scene.materials[scene.mesh.material()[0]];
  EXPECT_EQ(quad.type, MaterialType::kDiffuse);
  EXPECT_TRUE(quad.albedo_texture.present());

  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const Image image = render(scene, accel, integrator, {.spp = 16, .seed = 1});
  // The first-hit albedo AOV shows the texture too: the mean over the pixel's camera rays, so the
  // bilinear value at its centre as for the radiance, without the noise.
  Film film(32, 32, AovSet{.albedo = true});
  render_to_film(scene, accel, integrator, film, {.spp = 16, .seed = 1});
  const Image albedo = film.resolve_albedo();
  int checked = 0;
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 32; ++x) {
      const Ray r = scene.camera.ray_through(x + 0.5f, y + 0.5f);
      const double t = -static_cast<double>(r.origin.z) / r.dir.z;
      const double px = r.origin.x + t * r.dir.x, py = r.origin.y + t * r.dir.y;
      if (std::abs(px) > 0.9 || std::abs(py) > 0.9) continue;  // the quad's edge pixels
      const glm::dvec3 want = bilinear_repeat(rgb, 4, 4, (px + 1) / 2, (py + 1) / 2);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(image.at(x, y)[c], want[c], 0.02) << x << "," << y << " channel " << c;
        EXPECT_NEAR(albedo.at(x, y)[c], want[c], 0.02) << "albedo AOV " << x << "," << y;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 600);
}

// An emissive texture (MTL map_Ke) multiplies Ke: seen directly (max_depth 0) each pixel is Ke
// times the texture, bilinear at the pixel's centre to within its change across the pixel.
TEST_F(TexturedFiles, EmissionTextureMultipliesKe) {
  std::vector<uint8_t> rgb;
  for (int k = 0; k < 16; ++k) {
    rgb.insert(rgb.end(), {static_cast<uint8_t>(255 - 9 * k), static_cast<uint8_t>(40 + 11 * k),
                           static_cast<uint8_t>(k % 2 ? 220 : 30)});
  }
  file("glow.ppm", ppm(4, 4, rgb));
  file("quad.mtl", "newmtl m\nKd 0 0 0\nKe 2 2 2\nmap_Ke glow.ppm\n");
  file("quad.obj", quad_obj("quad.mtl"));
  const std::string json = R"({"camera": {"position": [0, 0, -2], "look_at": [0, 0, 0],
      "up": [0, -1, 0], "vertical_fov": 53.13010235415598, "width": 32, "height": 32},
      "meshes": [{"file": "quad.obj"}]})";
  LoadedScene loaded = parse_scene_json(json, (dir_ / "scene.json").string());
  apply_overrides(loaded, {});
  const Scene& scene = loaded.scene;
  ASSERT_TRUE(scene.materials[scene.mesh.material()[0]].emission_texture.present());
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator direct(scene, PathSettings{.max_depth = 0});
  const Image image = render(scene, accel, direct, {.spp = 16, .seed = 1});
  for (int y = 4; y < 28; y += 3) {
    for (int x = 4; x < 28; x += 3) {
      const Ray r = scene.camera.ray_through(x + 0.5f, y + 0.5f);
      const double t = -static_cast<double>(r.origin.z) / r.dir.z;
      const double px = r.origin.x + t * r.dir.x, py = r.origin.y + t * r.dir.y;
      const glm::dvec3 want = 2.0 * bilinear_repeat(rgb, 4, 4, (px + 1) / 2, (py + 1) / 2);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(image.at(x, y)[c], want[c], 0.04) << x << "," << y;
    }
  }
}

TEST_F(TexturedFiles, MissingTextureIsAnErrorNamingTheFile) {
  file("quad.mtl", "newmtl m\nKd 1 1 1\nmap_Kd missing.ppm\n");
  const std::string obj = file("quad.obj", quad_obj("quad.mtl"));
  try {
    (void)import_mesh_file(obj);
    FAIL() << "imported a model whose texture is missing";
  } catch (const Error& e) {
    EXPECT_NE(e.subject().find("missing.ppm"), std::string::npos) << e.subject();
    EXPECT_NE(e.reason().find("cannot read texture"), std::string::npos) << e.reason();
    EXPECT_EQ(e.exit_code(), ExitCode::kRuntime);
  }
  const std::string json = R"({"materials": [{"name": "m", "albedo": [1, 1, 1],
      "albedo_texture": "nope.png"}], "meshes": [{"generator": "cornell", "material": "m"}]})";
  try {
    (void)parse_scene_json(json, (dir_ / "scene.json").string());
    FAIL() << "loaded a scene whose texture is missing";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), (dir_ / "nope.png").string());
    EXPECT_NE(e.reason().find("/materials/0/albedo_texture"), std::string::npos) << e.reason();
  }
}

std::string base64(const std::string& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t n = static_cast<uint8_t>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) n |= static_cast<uint8_t>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) n |= static_cast<uint8_t>(bytes[i + 2]);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[n & 63] : '=';
  }
  return out;
}

// A PNG signature and IHDR chunk claiming 16384 x 16384 RGB texels, in 100 bytes: the header
// check refuses it (16384 bytes at least) before stb_image allocates anything.
std::string lying_png() {
  auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
  };
  const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + be32(13) + "IHDR" + be32(16384) +
                          be32(16384) + std::string("\x08\x02\x00\x00\x00", 5) + be32(0);
  return png + std::string(100 - png.size(), '\0');
}

TEST_F(TexturedFiles, GltfEmbeddedTextureWithALyingHeaderIsAnError) {
  // One triangle with texture coordinates; its base colour texture is a data URI.
  const float geometry[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1};
  const std::string buffer(reinterpret_cast<const char*>(geometry), sizeof(geometry));
  const std::string gltf = R"({"asset": {"version": "2.0"}, "scene": 0,
    "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}]}],
    "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
    "textures": [{"source": 0}],
    "images": [{"uri": "data:image/png;base64,)" +
                           base64(lying_png()) + R"("}],
    "buffers": [{"byteLength": 60, "uri": "data:application/octet-stream;base64,)" +
                           base64(buffer) + R"("}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                    {"buffer": 0, "byteOffset": 36, "byteLength": 24}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0]},
                  {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}]})";
  const std::string path = file("lying.gltf", gltf);
  try {
    (void)import_mesh_file(path);
    FAIL() << "imported a model whose embedded texture claims 16384 x 16384 texels in 100 bytes";
  } catch (const Error& e) {
    EXPECT_NE(e.subject().find("lying.gltf"), std::string::npos) << e.subject();
    EXPECT_NE(e.subject().find("embedded texture"), std::string::npos) << e.subject();
    EXPECT_NE(e.reason().find("16384 bytes"), std::string::npos) << e.reason();
    EXPECT_EQ(e.reason().find('\n'), std::string::npos) << e.reason();
  }
}

TEST_F(TexturedFiles, ObjTextureWithALyingHeaderIsAnError) {
  file("big.png", lying_png());
  file("quad.mtl", "newmtl m\nKd 1 1 1\nmap_Kd big.png\n");
  const std::string obj = file("quad.obj", quad_obj("quad.mtl"));
  try {
    (void)import_mesh_file(obj);
    FAIL() << "imported a model whose texture claims 16384 x 16384 texels in 100 bytes";
  } catch (const Error& e) {
    EXPECT_NE(e.subject().find("big.png"), std::string::npos) << e.subject();
    EXPECT_NE(e.reason().find("16384 bytes"), std::string::npos) << e.reason();
  }
}

TEST_F(TexturedFiles, JsonAlbedoTextureIsReadOnceAndShared) {
  file("t.ppm", ppm(2, 1, {255, 0, 0, 0, 0, 255}));
  const std::string json = R"({"materials": [
      {"name": "a", "albedo": [1, 1, 1], "albedo_texture": "t.ppm"},
      {"name": "b", "type": "principled", "albedo": [0.5, 0.5, 0.5], "albedo_texture": "./t.ppm"}],
      "meshes": [{"generator": "cornell", "material": "a"}]})";
  const LoadedScene loaded = parse_scene_json(json, (dir_ / "scene.json").string());
  ASSERT_EQ(loaded.scene.textures.size(), 1u);
  EXPECT_EQ(loaded.scene.materials[0].albedo_texture.index, 0);
  EXPECT_EQ(loaded.scene.materials[1].albedo_texture.index, 0);
  EXPECT_EQ(loaded.scene.textures[0].texel(0, 0), glm::vec3(1, 0, 0));
  EXPECT_EQ(loaded.scene.textures[0].texel(1, 0), glm::vec3(0, 0, 1));
  for (const char* bad : {R"("albedo_texture": 3)", R"("albedo_texture": "")"}) {
    const std::string text = std::string(R"({"materials": [{"name": "a", "albedo": [1, 1, 1], )") +
                             bad + R"(}], "meshes": [{"generator": "cornell", "material": "a"}]})";
    EXPECT_THROW((void)parse_scene_json(text, (dir_ / "scene.json").string()), Error) << bad;
  }
}

const std::string kModels = "/usr/share/assimp/models/glTF2/";

nlohmann::json glb_json(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                std::istreambuf_iterator<char>());
  uint32_t length = 0;
  std::memcpy(&length, bytes.data() + 12, 4);  // the first chunk, JSON, after the 12-byte header
  return nlohmann::json::parse(std::string(bytes.data() + 20, length));
}

// BoxTextured as .gltf (external PNG) and .glb (embedded): one texture, the PNG's texels decoded
// here by stb_image and the sRGB curve, and the sampler's wrap modes (the .gltf's are
// MIRRORED_REPEAT 33648 for s and CLAMP_TO_EDGE 33071 for t, the .glb's REPEAT).
TEST(GltfImport, BoxTexturedBringsItsTextureAndSampler) {
  const std::string png = kModels + "BoxTextured-glTF/CesiumLogoFlat.png";
  if (!fs::exists(png)) GTEST_SKIP() << "assimp-testmodels not installed";
  int w = 0, h = 0, n = 0;
  uint8_t* data = stbi_load(png.c_str(), &w, &h, &n, 3);
  ASSERT_NE(data, nullptr);
  const std::vector<uint8_t> rgb(data, data + static_cast<size_t>(w) * h * 3);
  stbi_image_free(data);
  for (const std::string& file : {kModels + "BoxTextured-glTF/BoxTextured.gltf",
                                  kModels + "BoxTextured-glTF-Binary/BoxTextured.glb"}) {
    const LoadedScene loaded = load_scene(file);
    const Scene& scene = loaded.scene;
    ASSERT_EQ(scene.textures.size(), 1u) << file;
    ASSERT_TRUE(scene.mesh.has_uvs()) << file;
    const Texture& t = scene.textures[0];
    ASSERT_EQ(t.width(), w);
    ASSERT_EQ(t.height(), h);
    for (int y = 0; y < h; y += 7) {
      for (int x = 0; x < w; x += 5) {
        const size_t k = 3 * (static_cast<size_t>(y) * w + x);
        for (int c = 0; c < 3; ++c) {
          ASSERT_NEAR(t.texel(x, y)[c], srgb_closed_form(rgb[k + c] / 255.0), 1e-6) << file;
        }
      }
    }
    const Material& m = scene.materials[scene.mesh.material()[0]];  // the box's (assimp adds one)
    EXPECT_EQ(m.type, MaterialType::kPrincipled);
    EXPECT_EQ(m.albedo_texture.index, 0);
    // The sampler's modes as the file's own JSON gives them (the .gltf and the .glb differ).
    nlohmann::json doc;
    if (file.ends_with(".glb")) {
      doc = glb_json(file);
    } else {
      doc = nlohmann::json::parse(std::ifstream(file));
    }
    const nlohmann::json& sampler = doc["samplers"][doc["textures"][0].value("sampler", 0)];
    auto mode = [](int gl) {
      return gl == 33071 ? WrapMode::kClamp : gl == 33648 ? WrapMode::kMirror : WrapMode::kRepeat;
    };
    EXPECT_EQ(m.albedo_texture.wrap_s, mode(sampler.value("wrapS", 10497))) << file;
    EXPECT_EQ(m.albedo_texture.wrap_t, mode(sampler.value("wrapT", 10497))) << file;
    EXPECT_EQ(m.metallic, 0.0f);
    EXPECT_EQ(m.roughness, 1.0f);  // glTF's default
  }
}

// 2CylinderEngine: every material's base colour, metallic and roughness factors as its JSON
// chunk says (read here with nlohmann::json), and the file's vertex normals for smooth shading.
TEST(GltfImport, TwoCylinderEngineHasTheFilesMaterialsAndNormals) {
  const std::string file = kModels + "2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  if (!fs::exists(file)) GTEST_SKIP() << "assimp-testmodels not installed";
  const nlohmann::json doc = glb_json(file);
  const ImportedMesh mesh = import_mesh_file(file);
  ASSERT_EQ(mesh.normals.size(), mesh.corners.size());
  size_t matched = 0;
  for (const nlohmann::json& m : doc["materials"]) {
    const std::string name = m.value("name", "");
    const auto it = std::find(mesh.material_names.begin(), mesh.material_names.end(), name);
    ASSERT_NE(it, mesh.material_names.end()) << name;
    const Material& got = mesh.materials[static_cast<size_t>(it - mesh.material_names.begin())];
    const nlohmann::json pbr = m.value("pbrMetallicRoughness", nlohmann::json::object());
    const std::vector<double> base =
        pbr.value("baseColorFactor", std::vector<double>{1.0, 1.0, 1.0, 1.0});
    for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(got.albedo[c], static_cast<float>(base[c])) << name;
    EXPECT_FLOAT_EQ(got.metallic, static_cast<float>(pbr.value("metallicFactor", 1.0))) << name;
    EXPECT_FLOAT_EQ(got.roughness, static_cast<float>(pbr.value("roughnessFactor", 1.0))) << name;
    EXPECT_EQ(got.type, MaterialType::kPrincipled);
    EXPECT_TRUE(got.two_sided);
    ++matched;
  }
  EXPECT_EQ(matched, 34u);
}

}  // namespace
}  // namespace tritrace
