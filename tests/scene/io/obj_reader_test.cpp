// The native OBJ reader against assimp, the oracle it stands in for: on the testmodels' OBJ files
// and on generated ones (triangles, convex and concave quads, objects, groups, materials from an
// MTL with a texture, negative indices, faces without normals or texture coordinates), the same
// triangles in the same order with the same normals, coordinates and materials; files it declines
// still read or fail as assimp makes them. Coordinates are compared with an independent oracle
// too: numbers printed with 9 digits read back exactly by a correctly rounding parser.
#include "tritrace/scene/io/obj_reader.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/scene/io/mesh_import.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The native reader's mesh, in the corner form for comparison (it reads into the indexed form).
std::optional<ImportedMesh> native(const std::string& path) {
  const std::string bytes = slurp(path);
  const std::string folder = fs::path(path).parent_path().string();
  std::optional<ImportedMesh> mesh = read_obj_triangles(
      std::span<const char>(bytes.data(), bytes.size()), path, folder.empty() ? "." : folder);
  if (mesh) {
    EXPECT_TRUE(mesh->indexed());
    EXPECT_EQ(mesh->indices.size(), 3 * mesh->triangles());
    mesh->expand_corners();
  }
  return mesh;
}

int ulps(float a, float b) {
  if (a == b) return 0;
  if (std::signbit(a) != std::signbit(b)) return 1 << 30;
  return std::abs(std::bit_cast<int32_t>(a) - std::bit_cast<int32_t>(b));
}

// Float steps by which two arrays of float vectors differ at most (their sizes must match).
template <typename Got, typename Want>
int most_ulps(const Got& got, const Want& want, size_t* differing = nullptr) {
  using V = typename Got::value_type;
  int most = 0;
  for (size_t i = 0; i < got.size() && i < want.size(); ++i) {
    for (int a = 0; a < V::length(); ++a) {
      const int d = ulps(got[i][a], want[i][a]);
      most = std::max(most, d);
      if (differing && d > 0) ++*differing;
    }
  }
  return most;
}

void expect_same_material(const Material& g, const Material& w) {
  EXPECT_EQ(g.albedo, w.albedo);
  EXPECT_EQ(g.emission, w.emission);
  EXPECT_EQ(g.two_sided, w.two_sided);
  EXPECT_EQ(g.type, w.type);
  EXPECT_EQ(std::bit_cast<uint32_t>(g.roughness), std::bit_cast<uint32_t>(w.roughness));
  EXPECT_EQ(g.ior, w.ior);
  EXPECT_EQ(g.metallic, w.metallic);
  EXPECT_EQ(g.transmission, w.transmission);
  EXPECT_EQ(g.albedo_texture.index, w.albedo_texture.index);
  EXPECT_EQ(g.albedo_texture.wrap_s, w.albedo_texture.wrap_s);
  EXPECT_EQ(g.albedo_texture.wrap_t, w.albedo_texture.wrap_t);
  EXPECT_EQ(g.emission_texture.index, w.emission_texture.index);
}

// Everything equal; the float arrays bit for bit, or within `max_ulps` float steps where given
// (assimp's decimal parser is not correctly rounded).
void expect_same(ImportedMesh got, ImportedMesh want, int max_ulps = 0) {
  got.expand_corners();
  want.expand_corners();
  ASSERT_EQ(got.corners.size(), want.corners.size());
  ASSERT_EQ(got.normals.size(), want.normals.size());
  ASSERT_EQ(got.uvs.size(), want.uvs.size());
  EXPECT_LE(most_ulps(got.corners, want.corners), max_ulps);
  EXPECT_LE(most_ulps(got.normals, want.normals), max_ulps);
  EXPECT_LE(most_ulps(got.uvs, want.uvs), max_ulps);
  if (max_ulps == 0) {
    EXPECT_EQ(std::memcmp(got.corners.data(), want.corners.data(),
                          got.corners.size() * sizeof(glm::vec3)),
              0);
  }
  EXPECT_EQ(got.material, want.material);
  ASSERT_EQ(got.materials.size(), want.materials.size());
  for (size_t i = 0; i < got.materials.size(); ++i) {
    SCOPED_TRACE("material " + std::to_string(i));
    expect_same_material(got.materials[i], want.materials[i]);
  }
  EXPECT_EQ(got.material_names, want.material_names);
  EXPECT_EQ(got.meshes, want.meshes);
  ASSERT_EQ(got.textures.size(), want.textures.size());
  for (size_t i = 0; i < got.textures.size(); ++i) {
    EXPECT_EQ(got.textures[i].width, want.textures[i].width);
    EXPECT_EQ(got.textures[i].rgb, want.textures[i].rgb);
  }
}

// The files of assimp's test set that the native reader leaves to assimp, and why.
const std::map<std::string, std::string> kDeclined = {
    {"box_UTF16BE.obj", "UTF-16 text (assimp converts it; tinyobjloader reads bytes)"},
    {"box_longline.obj", "polygons of more than four corners (assimp's ear clipping)"},
    {"box_mat_with_spaces.obj", "an MTL material name with spaces"},
    {"concave_polygon.obj", "polygons of more than four corners"},
    {"cube_mtllib_after_g.obj",
     "its mtllib names a missing file (assimp then tries the OBJ's "
     "own name with .mtl)"},
    {"cube_with_vertexcolors.obj", "vertex colours: 'v x y z r g b' (tinyobjloader reads r as w)"},
    {"cube_with_vertexcolors_uni.obj", "vertex colours, as above"},
    {"empty_mat.obj", "usemtl and newmtl without a name"},
    {"point_cloud.obj", "no faces (assimp makes a point mesh)"},
    {"space_in_material_name.obj", "material names with spaces"},
    {"testline.obj", "'l' line statements, which tinyobjloader's callbacks skip"},
    {"testmixed.obj", "'l' and 'p' statements among the faces"},
    {"testpoints.obj", "'p' point statements, as above"},
};

// The file's `v` lines through strtof (correctly rounded), each as its bit pattern with -0 as +0
// (the assimp path's identity transform adds +0).
std::set<std::array<uint32_t, 3>> vertices_by_strtof(const std::string& path) {
  std::set<std::array<uint32_t, 3>> out;
  std::istringstream in(slurp(path));
  for (std::string line; std::getline(in, line);) {
    std::istringstream w(line);
    std::string tag, x, y, z;
    if (!(w >> tag >> x >> y >> z) || tag != "v") continue;
    std::array<uint32_t, 3> bits;
    const std::string* t[3] = {&x, &y, &z};
    for (int a = 0; a < 3; ++a) {
      bits[a] = std::bit_cast<uint32_t>(std::strtof(t[a]->c_str(), nullptr) + 0.0f);
    }
    out.insert(bits);
  }
  return out;
}

// How many of the corners are not among `vertices`.
size_t corners_not_in(const ImportedMesh& m, const std::set<std::array<uint32_t, 3>>& vertices) {
  size_t missing = 0;
  for (const glm::vec3& c : m.corners) {
    const std::array<uint32_t, 3> bits = {
        std::bit_cast<uint32_t>(c.x), std::bit_cast<uint32_t>(c.y), std::bit_cast<uint32_t>(c.z)};
    missing += vertices.count(bits) == 0;
  }
  return missing;
}

std::vector<std::string> test_models() {
  std::vector<std::string> files;
  for (const char* dir : {"/usr/share/assimp/models/OBJ", "/usr/share/assimp/models-nonbsd/OBJ"}) {
    if (!fs::is_directory(dir)) continue;
    for (const auto& e : fs::directory_iterator(dir)) {
      if (e.path().extension() == ".obj") files.push_back(e.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(ObjReader, MatchesAssimpOnEveryTestModelItReads) {
  if (!native_obj_reader_built()) GTEST_SKIP() << "built without tinyobjloader";
  const std::vector<std::string> files = test_models();
  if (files.empty()) GTEST_SKIP() << "assimp-testmodels is not installed";
  size_t read = 0;
  for (const std::string& path : files) {
    SCOPED_TRACE(path);
    const std::string name = fs::path(path).filename().string();
    std::optional<ImportedMesh> mine;
    try {
      mine = native(path);
    } catch (const Error& e) {
      ADD_FAILURE() << "native reader threw " << e.what();
      continue;
    }
    std::optional<ImportedMesh> theirs;
    std::string their_error;
    try {
      theirs = import_mesh_file_with_assimp(path);
    } catch (const Error& e) {
      their_error = e.what();
    }
    if (!mine) {
      EXPECT_TRUE(kDeclined.count(name)) << "declined but not listed";
      continue;
    }
    EXPECT_FALSE(kDeclined.count(name)) << "listed as declined but read";
    ASSERT_TRUE(theirs.has_value()) << "assimp fails (" << their_error << ") where native reads";
    size_t differing = 0;
    const int most = most_ulps(mine->corners, theirs->corners, &differing);
    std::printf(
        "%s: %zu triangles, %zu of %zu coordinates differ from assimp's (at most %d "
        "float steps)\n",
        name.c_str(), mine->triangles(), differing, 3 * mine->corners.size(), most);
    // Where the two differ, the native reader's coordinates are the text's numbers correctly
    // rounded (strtof), assimp's a float step off.
    const auto exact = vertices_by_strtof(path);
    EXPECT_EQ(corners_not_in(*mine, exact), 0u);
    std::printf("  assimp's corners not the text's numbers correctly rounded: %zu of %zu\n",
                corners_not_in(*theirs, exact), theirs->corners.size());
    expect_same(*mine, *theirs, 2);
    expect_same(import_mesh_file(path), *mine);  // import_mesh_file takes the native path
    ++read;
  }
  EXPECT_GE(read, 9u);
}

// A float printed so that it reads back exactly.
std::string print(float f) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.9g", static_cast<double>(f));
  return text;
}

std::string decimals(float f) {
  char text[48];
  std::snprintf(text, sizeof(text), "%.6f", static_cast<double>(f));
  return text;
}

struct Generated {
  std::string obj;
  std::vector<glm::vec3> positions;  // the floats the text's vertex lines print
};

// A few thousand triangles: vertices on a jittered grid, faces of three and four corners (about a
// quarter of the quads folded concave), objects, groups, materials switched mid-object, a material
// the MTL lacks, faces with and without normals and texture coordinates, negative indices.
Generated generate(uint32_t seed, bool exact_numbers) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.3f, 0.3f);
  std::uniform_int_distribution<int> coin(0, 3);
  Generated g;
  std::ostringstream o;
  o << "# generated for obj_reader_test\nmtllib materials.mtl\n";
  const int n = 40;
  // exact_numbers: multiples of 1/1024, whose short decimals every parser reads exactly.
  const auto value = [&](float v) { return exact_numbers ? std::round(v * 1024.0f) / 1024.0f : v; };
  for (int y = 0; y <= n; ++y) {
    for (int x = 0; x <= n; ++x) {
      const glm::vec3 p(value(static_cast<float>(x) + jitter(rng)),
                        value(static_cast<float>(y) + jitter(rng)), value(jitter(rng) * 3.0f));
      // Otherwise the text as exporters write it (six decimals, every second vertex scaled up
      // to a few hundred), the expected floats the text's numbers through strtof.
      std::string text[3];
      for (int a = 0; a < 3; ++a) {
        text[a] = exact_numbers ? print(p[a]) : decimals(p[a] * ((x + y) % 2 ? 37.0f : 1.0f));
      }
      g.positions.emplace_back(std::strtof(text[0].c_str(), nullptr),
                               std::strtof(text[1].c_str(), nullptr),
                               std::strtof(text[2].c_str(), nullptr));
      o << "v " << text[0] << ' ' << text[1] << ' ' << text[2] << '\n';
      if ((x + y) % 5 == 0) o << "vn " << print(value(jitter(rng))) << " 0.5 1\n";
      if ((x + y) % 3 == 0) o << "vt " << print(value(jitter(rng))) << ' ' << print(0.25f) << '\n';
    }
  }
  const int vertices = (n + 1) * (n + 1);
  const auto id = [&](int x, int y) { return y * (n + 1) + x + 1; };
  const char* materials[] = {"red", "glass", "lamp", "missing", "textured"};
  int faces = 0;
  for (int y = 0; y < n; ++y) {
    if (y % 9 == 0) o << "o part" << y << '\n';
    if (y % 7 == 3) o << "g group" << y % 2 << '\n';
    for (int x = 0; x < n; ++x) {
      if ((x + 3 * y) % 11 == 0) o << "usemtl " << materials[(x + y) % 5] << '\n';
      int c[4] = {id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)};
      if (coin(rng) == 0) std::swap(c[1], c[2]);  // a folded (concave or crossed) quad
      const int kind = (x + y) % 4;               // which optional parts the face has
      const bool negative = (x * y) % 5 == 1;
      const auto corner = [&](int v) {
        std::string s = std::to_string(negative ? v - vertices - 1 : v);
        if (kind == 1) s += "/" + std::to_string(1 + v % 50);
        if (kind == 2) s += "//" + std::to_string(1 + v % 40);
        if (kind == 3) s += "/" + std::to_string(1 + v % 50) + "/" + std::to_string(1 + v % 40);
        return s;
      };
      if (coin(rng) == 1) {
        o << "f " << corner(c[0]) << ' ' << corner(c[1]) << ' ' << corner(c[2]) << '\n';
        o << "f " << corner(c[0]) << ' ' << corner(c[2]) << ' ' << corner(c[3]) << '\n';
        faces += 2;
      } else {
        o << "f " << corner(c[0]) << ' ' << corner(c[1]) << ' ' << corner(c[2]) << ' '
          << corner(c[3]) << '\n';
        ++faces;
      }
    }
  }
  g.obj = o.str();
  return g;
}

const char* kMtl =
    "# generated\nnewmtl red\nKd 0.8 0.1 0.1\nKs 0 0 0\nNs 10\n"
    "newmtl glass\nKd 1 1 1\nKs 0.5 0.5 0.5\nNs 200\nNi 1.45\nd 0.2\n"
    "newmtl lamp\nKd 0.1 0.1 0.1\nKe 4 3.5 2\n"
    "newmtl textured\nKd 1 1 1\nmap_Kd tex.jpg\n\tKs 0.04 0.04 0.04\nillum 2\n"
    "newmtl unused\nKd 0 0 0\nKs 0.9 0.8 0.7\nNs 50\n";

struct TempDir {
  TempDir() {
    path = fs::temp_directory_path() /
           ("tritrace_obj_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string write(const std::string& name, const std::string& text) const {
    const fs::path p = path / name;
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }
  fs::path path;
  static inline int counter = 0;
};

std::string with_texture(const TempDir& dir) {
  fs::copy_file("/usr/share/assimp/models/OBJ/SpiderTex.jpg", dir.path / "tex.jpg");
  return dir.write("materials.mtl", kMtl);
}

TEST(ObjReader, GeneratedMeshMatchesAssimpBitForBit) {
  if (!native_obj_reader_built()) GTEST_SKIP() << "built without tinyobjloader";
  if (!fs::exists("/usr/share/assimp/models/OBJ/SpiderTex.jpg")) GTEST_SKIP() << "no testmodels";
  TempDir dir;
  with_texture(dir);
  const std::string path = dir.write("mesh.obj", generate(7, true).obj);
  const std::optional<ImportedMesh> mine = native(path);
  ASSERT_TRUE(mine.has_value()) << "the native reader left it to assimp";
  const ImportedMesh theirs = import_mesh_file_with_assimp(path);
  EXPECT_GT(mine->triangles(), 2500u);
  EXPECT_GT(mine->meshes, 20u);
  EXPECT_EQ(mine->textures.size(), 1u);
  EXPECT_EQ(mine->materials.size(), 7u);  // DefaultMaterial, the MTL's five, "missing"
  expect_same(*mine, theirs);
  EXPECT_EQ(std::memcmp(mine->normals.data(), theirs.normals.data(),
                        mine->normals.size() * sizeof(glm::vec3)),
            0);
  EXPECT_EQ(std::memcmp(mine->uvs.data(), theirs.uvs.data(), mine->uvs.size() * sizeof(glm::vec2)),
            0);
  expect_same(import_mesh_file(path), *mine);
  // Cut into pieces of a few hundred bytes, read in parallel: statements, negative indices and
  // materials across the cuts come out the same.
  const std::string bytes = slurp(path);
  for (const size_t piece : {size_t{1}, size_t{300}, size_t{4096}}) {
    SCOPED_TRACE(piece);
    const std::optional<ImportedMesh> cut = read_obj_triangles(
        std::span<const char>(bytes.data(), bytes.size()), path, dir.path.string(), piece);
    ASSERT_TRUE(cut.has_value());
    expect_same(*cut, *mine);
    EXPECT_EQ(std::memcmp(cut->normals.data(), mine->normals.data(),
                          mine->normals.size() * sizeof(glm::vec3)),
              0);
    EXPECT_EQ(std::memcmp(cut->uvs.data(), mine->uvs.data(), mine->uvs.size() * sizeof(glm::vec2)),
              0);
  }
}

// Coordinates written with six decimals read as the text's numbers correctly rounded (strtof, an
// independent parser); assimp's are within two float steps of them.
TEST(ObjReader, CoordinatesAreTheNumbersThePrintedTextMeans) {
  if (!native_obj_reader_built()) GTEST_SKIP() << "built without tinyobjloader";
  TempDir dir;
  with_texture(dir);
  const Generated g = generate(11, false);
  // Triangles over consecutive vertex triples, so that the expected corners follow directly.
  std::string obj = g.obj.substr(0, g.obj.find("\nf ") + 1);
  obj = obj.substr(0, obj.rfind("\no ") + 1);
  std::vector<glm::vec3> want;
  for (size_t i = 0; i + 2 < g.positions.size(); i += 3) {
    obj += "f " + std::to_string(i + 1) + " " + std::to_string(i + 2) + " " +
           std::to_string(i + 3) + "\n";
    want.insert(want.end(), {g.positions[i], g.positions[i + 2], g.positions[i + 1]});
  }
  const std::string path = dir.write("numbers.obj", obj);
  const std::optional<ImportedMesh> mine = native(path);
  ASSERT_TRUE(mine.has_value());
  ASSERT_EQ(mine->corners.size(), want.size());
  EXPECT_EQ(std::memcmp(mine->corners.data(), want.data(), want.size() * sizeof(glm::vec3)), 0);
  size_t differing = 0;
  const ImportedMesh theirs = import_mesh_file_with_assimp(path);
  const int most = most_ulps(theirs.corners, want, &differing);
  std::printf("assimp: %zu of %zu coordinates off by up to %d float steps\n", differing,
              3 * want.size(), most);
  EXPECT_LE(most, 2);
  expect_same(import_mesh_file(path), *mine);
}

// Files the native reader leaves to assimp read exactly as assimp reads them.
TEST(ObjReader, DeclinedFilesReadThroughAssimp) {
  TempDir dir;
  const std::string pentagon = dir.write(
      "pentagon.obj", "v 0 0 0\nv 1 0 0\nv 1.5 1 0\nv 0.5 0.5 0\nv -0.5 1 0\nf 1 2 3 4 5\n");
  const std::string colours =
      dir.write("colours.obj", "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n");
  const std::string lines = dir.write("lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nf 1 2 3\n");
  for (const std::string& path : {pentagon, colours, lines}) {
    SCOPED_TRACE(path);
    EXPECT_FALSE(native(path).has_value());
    expect_same(import_mesh_file(path), import_mesh_file_with_assimp(path));
  }
}

// From memory there is no folder: a file naming a material library is left to assimp, others are
// read natively, as assimp reads them from a file.
TEST(ObjReader, FromMemory) {
  if (!native_obj_reader_built()) GTEST_SKIP() << "built without tinyobjloader";
  TempDir dir;
  const std::string text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl a\nf 1 2 3 4\n";
  const std::string path = dir.write("plain.obj", text);
  const auto bytes = std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size());
  const std::optional<ImportedMesh> mine =
      read_obj_triangles(std::span<const char>(text.data(), text.size()), "memory", "");
  ASSERT_TRUE(mine.has_value());
  expect_same(*mine, import_mesh_file_with_assimp(path));
  expect_same(import_mesh_memory(bytes, "obj", "memory"), *mine);
  const std::string with_lib = "mtllib m.mtl\n" + text;
  EXPECT_FALSE(
      read_obj_triangles(std::span<const char>(with_lib.data(), with_lib.size()), "memory", ""));
}

// Broken files fail with assimp's messages: the native reader declines them.
TEST(ObjReader, MalformedFilesGiveAssimpsErrors) {
  TempDir dir;
  const std::vector<std::string> bad = {
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",     // index past the vertices
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",     // index 0
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n",  // relative index before the first vertex
      "v 0 0 0\nv 1 0 0\nv 0 1 0\n# no faces\n",  // no triangles
      "# only a comment, long enough\n",
  };
  for (size_t i = 0; i < bad.size(); ++i) {
    SCOPED_TRACE(bad[i]);
    const std::string path = dir.write("bad" + std::to_string(i) + ".obj", bad[i]);
    EXPECT_FALSE(native(path).has_value());
    std::string want, got;
    try {
      import_mesh_file_with_assimp(path);
    } catch (const Error& e) {
      want = e.what();
    }
    try {
      import_mesh_file(path);
    } catch (const Error& e) {
      got = e.what();
    }
    EXPECT_EQ(got, want);
  }
}

}  // namespace
}  // namespace tritrace
