// Mesh import against real third-party files from Debian's assimp-testmodels: triangle counts and
// bounds come from tiny independent readers of the same files (OBJ 'f' lines, the PLY header and
// face lines, the binary STL header and records, the glTF accessor table), never from assimp.
#include "tritrace/scene/io/mesh_import.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/glm.hpp>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tritrace/error.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

const std::string kModels = "/usr/share/assimp/models/";

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Polygons of n corners become n - 2 triangles.
size_t count_obj_triangles(const std::string& path) {
  std::istringstream in(slurp(path));
  size_t triangles = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("f ", 0) != 0) continue;
    std::istringstream words(line.substr(2));
    size_t corners = 0;
    for (std::string w; words >> w;) ++corners;
    triangles += corners - 2;
  }
  return triangles;
}

// ASCII PLY: the header's vertex and face counts, then each face line starts with its corner count.
size_t count_ascii_ply_triangles(const std::string& path, size_t* header_faces) {
  std::istringstream in(slurp(path));
  size_t vertices = 0, faces = 0;
  for (std::string line; std::getline(in, line) && line.rfind("end_header", 0) != 0;) {
    std::istringstream words(line);
    std::string a, b;
    size_t n = 0;
    if (words >> a >> b >> n && a == "element") (b == "vertex" ? vertices : faces) = n;
  }
  *header_faces = faces;
  std::string line;
  for (size_t i = 0; i < vertices; ++i) std::getline(in, line);
  size_t triangles = 0;
  for (size_t i = 0; i < faces && std::getline(in, line); ++i) {
    triangles += std::stoul(line) - 2;
  }
  return triangles;
}

struct StlFacts {
  uint32_t triangles = 0;
  glm::vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};
};

// Binary STL: an 80-byte header, a little-endian uint32 count, then 50-byte records (normal, three
// vertices, attribute).
StlFacts read_binary_stl(const std::string& path) {
  const std::string bytes = slurp(path);
  StlFacts facts;
  std::memcpy(&facts.triangles, bytes.data() + 80, 4);
  for (uint32_t t = 0; t < facts.triangles; ++t) {
    for (int v = 0; v < 3; ++v) {
      float p[3];
      std::memcpy(p, bytes.data() + 84 + 50 * t + 12 + 12 * v, 12);
      for (int k = 0; k < 3; ++k) {
        facts.lo[k] = std::min(facts.lo[k], p[k]);
        facts.hi[k] = std::max(facts.hi[k], p[k]);
      }
    }
  }
  return facts;
}

glm::vec3 imported_lo(const ImportedMesh& m) {
  glm::vec3 lo(std::numeric_limits<float>::max());
  for (size_t k = 0; k < 3 * m.triangles(); ++k) lo = glm::min(lo, m.corner(k));
  return lo;
}
glm::vec3 imported_hi(const ImportedMesh& m) {
  glm::vec3 hi(-std::numeric_limits<float>::max());
  for (size_t k = 0; k < 3 * m.triangles(); ++k) hi = glm::max(hi, m.corner(k));
  return hi;
}

TEST(MeshImport, ObjTriangleCountMatchesItsFaceLines) {
  for (const std::string name : {"OBJ/spider.obj", "OBJ/box.obj", "OBJ/concave_polygon.obj"}) {
    SCOPED_TRACE(name);
    const ImportedMesh m = import_mesh_file(kModels + name);
    EXPECT_EQ(m.triangles(), count_obj_triangles(kModels + name));
    EXPECT_EQ(m.corner_view().size(), 3 * m.triangles());
  }
}

// spider.mtl names its textures Windows-style (".\\SpiderTex.jpg"): found with '/' instead, each
// image once.
TEST(MeshImport, ObjTexturesWithWindowsSeparatorsAreFound) {
  const ImportedMesh m = import_mesh_file(kModels + "OBJ/spider.obj");
  EXPECT_GE(m.textures.size(), 2u);
  EXPECT_EQ(m.uvs.size(), m.corner_view().size());
  size_t textured = 0;
  for (const Material& mat : m.materials) textured += mat.albedo_texture.present();
  EXPECT_GE(textured, m.textures.size());
}

TEST(MeshImport, ObjMaterialsKeepTheirMtlDiffuseColours) {
  // Every Kd colour in spider.mtl is one of the imported albedos.
  const ImportedMesh m = import_mesh_file(kModels + "OBJ/spider.obj");
  std::istringstream mtl(slurp(kModels + "OBJ/spider.mtl"));
  size_t checked = 0;
  for (std::string line; std::getline(mtl, line);) {
    std::istringstream words(line);
    std::string key;
    glm::vec3 kd;
    if (!(words >> key) || key != "Kd" || !(words >> kd.x >> kd.y >> kd.z)) continue;
    ++checked;
    bool found = false;
    for (const Material& mat : m.materials) found |= (mat.albedo == kd);
    EXPECT_TRUE(found) << "Kd " << kd.x << " " << kd.y << " " << kd.z;
  }
  EXPECT_GT(checked, 1u);
}

TEST(MeshImport, AsciiPlyTriangleCountMatchesItsHeaderAndFaces) {
  size_t header_faces = 0;
  const size_t triangles = count_ascii_ply_triangles(kModels + "PLY/Wuson.ply", &header_faces);
  EXPECT_EQ(header_faces, 3732u);
  const ImportedMesh m = import_mesh_file(kModels + "PLY/Wuson.ply");
  EXPECT_EQ(m.triangles(), triangles);
}

TEST(MeshImport, CubePlyQuadsBecomeTwelveTriangles) {
  size_t header_faces = 0;
  EXPECT_EQ(count_ascii_ply_triangles(kModels + "PLY/cube.ply", &header_faces), 12u);
  EXPECT_EQ(header_faces, 6u);
  const ImportedMesh m = import_mesh_file(kModels + "PLY/cube.ply");
  EXPECT_EQ(m.triangles(), 12u);
  EXPECT_EQ(imported_lo(m), glm::vec3(0.0f));
  EXPECT_EQ(imported_hi(m), glm::vec3(1.0f));
}

TEST(MeshImport, BinaryStlMatchesItsHeaderCountAndVertexBounds) {
  const StlFacts facts = read_binary_stl(kModels + "STL/Spider_binary.stl");
  EXPECT_EQ(facts.triangles, 1368u);
  const ImportedMesh m = import_mesh_file(kModels + "STL/Spider_binary.stl");
  EXPECT_EQ(m.triangles(), facts.triangles);
  EXPECT_EQ(imported_lo(m), facts.lo);
  EXPECT_EQ(imported_hi(m), facts.hi);
}

TEST(MeshImport, Gltf2TriangleCountAndBoundsMatchItsAccessors) {
  const std::string path = kModels + "glTF2/BoxTextured-glTF/BoxTextured.gltf";
  const nlohmann::json gltf = nlohmann::json::parse(slurp(path));
  const auto& primitive = gltf["meshes"][0]["primitives"][0];
  const auto& indices = gltf["accessors"][primitive["indices"].get<int>()];
  const auto& position = gltf["accessors"][primitive["attributes"]["POSITION"].get<int>()];
  const ImportedMesh m = import_mesh_file(path);
  EXPECT_EQ(m.triangles(), indices["count"].get<size_t>() / 3);
  // The box's node matrix only permutes and negates axes, so its world bounds are symmetric.
  const float extent = position["max"][0].get<float>();
  EXPECT_EQ(imported_hi(m), glm::vec3(extent));
  EXPECT_EQ(imported_lo(m), glm::vec3(-extent));
}

TEST(MeshImport, BinaryGlbLoads) {
  const ImportedMesh m =
      import_mesh_file(kModels + "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb");
  EXPECT_EQ(m.triangles(), 12u);
}

void expect_import_error(const std::string& name, const std::string& reason) {
  SCOPED_TRACE(name);
  try {
    import_mesh_file(kModels + name);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), kModels + name);
    EXPECT_NE(e.reason().find(reason), std::string::npos) << e.reason();
    EXPECT_EQ(e.reason().find('\n'), std::string::npos);
  }
}

TEST(MeshImport, BrokenGltf2FilesAreErrors) {
  expect_import_error("glTF2/IndexOutOfRange/IndexOutOfRange.gltf", "out of range");
  expect_import_error("glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf", "cannot import");
  for (const std::string bad :
       {"badArray", "badExtension", "badNumber", "badObject", "badString", "badUint"}) {
    expect_import_error("glTF2/wrongTypes/" + bad + ".gltf", "was not of type");
  }
  expect_import_error("glTF2/RecursiveNodes/RecursiveNodes.gltf", "recursive");
  expect_import_error("glTF2/MissingBin/BoxTextured.gltf", "could not open");
}

TEST(MeshImport, FilesWithoutTrianglesAreErrors) {
  expect_import_error("OBJ/testline.obj", "contains no triangles");
  expect_import_error("invalid/empty.obj", "is empty");
  expect_import_error("invalid/malformed.obj", "cannot import");
}

TEST(MeshImport, InfiniteVerticesAreDroppedAndLeaveNoGeometry) {
  const std::string path = kModels + "glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb";
  const ImportedMesh m = import_mesh_file(path);
  EXPECT_EQ(m.triangles(), 12u);
  try {
    scene_from_mesh(m);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(e.reason().find("12 non-finite"), std::string::npos) << e.reason();
  }
}

TEST(MeshImport, MemoryImportMatchesFileImport) {
  const std::string path = kModels + "OBJ/box.obj";
  const std::string bytes = slurp(path);
  const ImportedMesh from_file = import_mesh_file(path);
  const ImportedMesh from_memory = import_mesh_memory(
      std::span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), "obj", "box");
  ASSERT_EQ(from_memory.corner_view().size(), from_file.corner_view().size());
  for (size_t k = 0; k < from_file.corner_view().size(); ++k) {
    EXPECT_EQ(from_memory.corner(k), from_file.corner(k)) << k;
  }
}

TEST(SceneFromMesh, FramesTheMeshInsideTheImage) {
  const ImportedMesh m = import_mesh_file(kModels + "PLY/cube.ply");
  const LoadedScene s = scene_from_mesh(m);
  const Camera& cam = s.scene.camera;
  // Every cube corner projects inside the image.
  for (int corner = 0; corner < 8; ++corner) {
    const glm::vec3 p(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
    const glm::vec3 d = p - cam.position();
    const float z = glm::dot(d, cam.forward());
    ASSERT_GT(z, 0.0f);
    const float x = glm::dot(d, cam.right()) / z * cam.focal_px() + cam.width() / 2;
    const float y = glm::dot(d, cam.down()) / z * cam.focal_px() + cam.height() / 2;
    EXPECT_GT(x, 0.0f);
    EXPECT_LT(x, cam.width());
    EXPECT_GT(y, 0.0f);
    EXPECT_LT(y, cam.height());
  }
  // y up: the image's down direction points toward -y.
  EXPECT_LT(cam.down().y, 0.0f);
  ASSERT_EQ(s.scene.lights.size(), 1u);
  EXPECT_GT(s.scene.lights[0].power.x, 0.0f);
}

}  // namespace
}  // namespace tritrace

namespace tritrace {
namespace {

// Model files wind front faces counter-clockwise; the lab's normal is cross(e2, e1). Imported
// triangles must come out with the lab's normal pointing out of the model, or the side facing the
// camera (and the light beside it) would get only the ambient term.
TEST(SceneFromMesh, OutsideOfAClosedModelFacesOutward) {
  const LoadedScene loaded = load_scene("/usr/share/assimp/models/OBJ/box.obj");
  const TriangleMesh& mesh = loaded.scene.mesh;
  ASSERT_GT(mesh.size(), 0u);
  const Bounds3 b = mesh.bounds();
  const glm::vec3 centre = b.centre();
  for (size_t i = 0; i < mesh.size(); ++i) {
    const glm::vec3 mid = (mesh.vertex(i, 0) + mesh.vertex(i, 1) + mesh.vertex(i, 2)) / 3.0f;
    EXPECT_GT(glm::dot(mesh.normal()[i], mid - centre), 0.0f) << "triangle " << i;
  }
}

}  // namespace
}  // namespace tritrace
