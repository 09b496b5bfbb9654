// The native PLY reader against assimp, the oracle it replaces: on the testmodels' PLY files and on
// files written here in every layout (ASCII, both byte orders, every scalar type, extra vertex
// properties), the same triangles bit for bit, in the same order, with the same materials; and
// every file it does not take (polygons, point clouds, damage) still reads or fails as assimp
// makes it.
#include "tritrace/scene/io/ply_reader.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/scene/io/mesh_import.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;
const std::string kModels = "/usr/share/assimp/models/PLY/";

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The native reader's mesh, in the corner form for comparison (it reads into the indexed form).
std::optional<ImportedMesh> native(const std::string& path) {
  const std::string bytes = slurp(path);
  std::optional<ImportedMesh> mesh =
      read_ply_triangles(std::span<const char>(bytes.data(), bytes.size()), path);
  if (mesh) {
    EXPECT_TRUE(mesh->indexed());
    EXPECT_EQ(mesh->indices.size(), 3 * mesh->triangles());
    mesh->expand_corners();
  }
  return mesh;
}

// Float steps between a and b (both finite, same sign here).
int ulps(float a, float b) {
  return std::abs(std::bit_cast<int32_t>(a) - std::bit_cast<int32_t>(b));
}

// The same mesh; corners bit for bit, or within `max_ulps` float steps where given.
void expect_same(ImportedMesh got, ImportedMesh want, int max_ulps = 0) {
  got.expand_corners();
  want.expand_corners();
  ASSERT_EQ(got.corners.size(), want.corners.size());
  if (max_ulps == 0) {
    EXPECT_EQ(std::memcmp(got.corners.data(), want.corners.data(),
                          got.corners.size() * sizeof(glm::vec3)),
              0)
        << "corners differ";
  } else {
    int most = 0;
    for (size_t i = 0; i < got.corners.size(); ++i) {
      for (int a = 0; a < 3; ++a)
        most = std::max(most, ulps(got.corners[i][a], want.corners[i][a]));
    }
    EXPECT_LE(most, max_ulps);
  }
  // Vertex normals (nx, ny, nz) where the file has them, at the same corners.
  ASSERT_EQ(got.normals.size(), want.normals.size());
  for (size_t i = 0; i < got.normals.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      const float g = got.normals[i][a], w = want.normals[i][a];
      EXPECT_TRUE(g == w || (std::signbit(g) == std::signbit(w) && ulps(g, w) <= max_ulps))
          << "normal " << i << ": " << g << " against " << w;
    }
  }
  EXPECT_EQ(got.material, want.material);
  ASSERT_EQ(got.materials.size(), want.materials.size());
  for (size_t i = 0; i < got.materials.size(); ++i) {
    EXPECT_EQ(got.materials[i].albedo, want.materials[i].albedo);
    EXPECT_EQ(got.materials[i].emission, want.materials[i].emission);
    EXPECT_EQ(got.materials[i].two_sided, want.materials[i].two_sided);
  }
  EXPECT_EQ(got.material_names, want.material_names);
  EXPECT_EQ(got.meshes, want.meshes);
}

// ASCII numbers are rounded correctly by the native reader, while assimp's own decimal parser is
// off by a float step or two on some (919 of Wuson.ply's 33,588 coordinates): ASCII files are
// compared with assimp to two steps, and exactly with `exact` (the text's numbers through strtof).
void expect_native_equals_assimp(const std::string& path, const ImportedMesh* exact = nullptr) {
  SCOPED_TRACE(path);
  const std::optional<ImportedMesh> mine = native(path);
  ASSERT_TRUE(mine.has_value()) << "the native reader left it to assimp";
  expect_same(*mine, import_mesh_file_with_assimp(path), exact ? 2 : 0);
  if (exact) expect_same(*mine, *exact);
  expect_same(import_mesh_file(path), *mine);  // and import_mesh_file takes the native path
}

// An ASCII PLY's triangles by an independent route: the vertex lines' three numbers from x_column
// through strtof (strtoll for integer properties), and the normal's three from nx_column (none when
// negative), faces as (a, c, b) as tritrace stores model files' triangles.
ImportedMesh ascii_by_strtof(const std::string& path, int x_column, bool integers = false,
                             int nx_column = -1) {
  std::istringstream in(slurp(path));
  size_t vertices = 0, faces = 0;
  for (std::string line; std::getline(in, line) && line.rfind("end_header", 0) != 0;) {
    std::istringstream w(line);
    std::string a, b;
    size_t n = 0;
    if (w >> a >> b >> n && a == "element") (b == "vertex" ? vertices : faces) = n;
  }
  std::vector<glm::vec3> points, normals;
  std::string line;
  for (size_t i = 0; i < vertices && std::getline(in, line); ++i) {
    std::istringstream w(line);
    std::vector<std::string> tokens;
    for (std::string t; w >> t;) tokens.push_back(t);
    glm::vec3 p;
    for (int a = 0; a < 3; ++a) {
      const std::string& t = tokens.at(static_cast<size_t>(x_column + a));
      // Integer properties are integers first ("-0" is 0).
      p[a] = integers ? static_cast<float>(std::strtoll(t.c_str(), nullptr, 10))
                      : std::strtof(t.c_str(), nullptr);
    }
    points.push_back(p);
    if (nx_column >= 0) {
      glm::vec3 n;
      for (int a = 0; a < 3; ++a) {
        n[a] = std::strtof(tokens.at(static_cast<size_t>(nx_column + a)).c_str(), nullptr);
      }
      normals.push_back(n);
    }
  }
  ImportedMesh m;
  for (size_t f = 0; f < faces && std::getline(in, line); ++f) {
    std::istringstream w(line);
    size_t n = 0, a = 0, b = 0, c = 0;
    w >> n >> a >> b >> c;
    m.corners.insert(m.corners.end(), {points.at(a), points.at(c), points.at(b)});
    if (nx_column >= 0) m.normals.insert(m.normals.end(), {normals[a], normals[c], normals[b]});
    m.material.push_back(0);
  }
  m.materials = {Material{.albedo = glm::vec3(1.0f), .two_sided = true}};
  m.material_names = {""};
  m.meshes = 1;
  return m;
}

TEST(PlyReader, TestModelsReadAsAssimpReadsThem) {
  expect_native_equals_assimp(kModels + "cube_binary.ply");  // binary little-endian
  // ASCII, a free-text header line, normals and UVs beside xyz:
  const ImportedMesh wuson = ascii_by_strtof(kModels + "Wuson.ply", 0, false, 3);
  expect_native_equals_assimp(kModels + "Wuson.ply", &wuson);
  const ImportedMesh colour = ascii_by_strtof(kModels + "float-color.ply", 0);
  expect_native_equals_assimp(kModels + "float-color.ply", &colour);  // ASCII, float colours
}

TEST(PlyReader, PolygonsAndPointCloudsAreLeftToAssimp) {
  EXPECT_FALSE(native(kModels + "cube.ply").has_value());      // quads
  EXPECT_FALSE(native(kModels + "pond.0.ply").has_value());    // no faces
  EXPECT_FALSE(native(kModels + "issue623.ply").has_value());  // a list among vertex properties
  expect_same(import_mesh_file(kModels + "cube.ply"),
              import_mesh_file_with_assimp(kModels + "cube.ply"));
  EXPECT_THROW(import_mesh_file(kModels + "pond.0.ply"), Error);
}

// A PLY writer of its own for the layouts below.
struct Property {
  std::string type, name;
};

void put(std::string& out, const std::string& type, double v, bool big_endian) {
  auto raw = [&](auto x) {
    auto bytes = std::bit_cast<std::array<char, sizeof(x)>>(x);
    if (big_endian) std::reverse(bytes.begin(), bytes.end());
    out.append(bytes.data(), bytes.size());
  };
  if (type == "char") raw(static_cast<int8_t>(v));
  if (type == "uchar") raw(static_cast<uint8_t>(v));
  if (type == "short") raw(static_cast<int16_t>(v));
  if (type == "ushort") raw(static_cast<uint16_t>(v));
  if (type == "int") raw(static_cast<int32_t>(v));
  if (type == "uint") raw(static_cast<uint32_t>(v));
  if (type == "float") raw(static_cast<float>(v));
  if (type == "double") raw(v);
}

// Vertices get every property (xyz from `points`, the rest i + 0.25, or i mod 100 for integer
// types); faces are triangles.
std::string write_ply(const std::string& format, const std::vector<Property>& vertex_props,
                      const std::string& count_type, const std::string& index_type,
                      const std::vector<std::array<double, 3>>& points,
                      const std::vector<std::array<int64_t, 3>>& faces) {
  std::ostringstream header;
  header << "ply\nformat " << format << " 1.0\ncomment written by ply_reader_test\n";
  header << "element vertex " << points.size() << "\n";
  for (const Property& p : vertex_props) header << "property " << p.type << " " << p.name << "\n";
  header << "element face " << faces.size() << "\nproperty list " << count_type << " " << index_type
         << " vertex_indices\nend_header\n";
  std::string out = header.str();
  const bool ascii = format == "ascii", big = format == "binary_big_endian";
  for (size_t i = 0; i < points.size(); ++i) {
    for (size_t k = 0; k < vertex_props.size(); ++k) {
      const std::string& n = vertex_props[k].name;
      const std::string& type = vertex_props[k].type;
      // Other properties: values every type holds exactly (a float-to-integer conversion out of
      // range would be undefined behaviour).
      const double other = type == "float" || type == "double" ? double(i) + 0.25 : double(i % 100);
      const double v = n == "x"   ? points[i][0]
                       : n == "y" ? points[i][1]
                       : n == "z" ? points[i][2]
                                  : other;
      if (ascii) {
        std::ostringstream s;
        s.precision(17);
        s << v;
        if (k) out += ' ';
        out += s.str();
      } else {
        put(out, vertex_props[k].type, v, big);
      }
    }
    if (ascii) out += "\n";
  }
  for (const auto& f : faces) {
    if (ascii) {
      std::ostringstream line;
      line << "3 " << f[0] << " " << f[1] << " " << f[2] << "\n";
      out += line.str();
    } else {
      put(out, count_type, 3, big);
      for (int64_t i : f) put(out, index_type, static_cast<double>(i), big);
    }
  }
  return out;
}

class PlyFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("tritrace-ply-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name, const std::string& bytes) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  fs::path dir_;
};

// A random mesh: n triangles over n / 2 + 3 points with coordinates of every magnitude.
void random_mesh(size_t n, uint32_t seed, std::vector<std::array<double, 3>>& points,
                 std::vector<std::array<int64_t, 3>>& faces, bool integers = false) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  points.resize(n / 2 + 3);
  for (auto& p : points) {
    for (double& c : p)
      c = integers ? std::round(100.0 * u(rng)) : u(rng) * std::exp2(20.0 * u(rng));
  }
  std::uniform_int_distribution<int64_t> pick(0, static_cast<int64_t>(points.size()) - 1);
  faces.resize(n);
  for (auto& f : faces) f = {pick(rng), pick(rng), pick(rng)};
}

TEST_F(PlyFiles, EveryLayoutReadsAsAssimpReadsIt) {
  std::vector<std::array<double, 3>> points, int_points;
  std::vector<std::array<int64_t, 3>> faces, int_faces;
  random_mesh(40000, 7, points, faces);  // big enough for parallel chunks
  random_mesh(300, 8, int_points, int_faces, true);
  const std::vector<Property> plain{{"float", "x"}, {"float", "y"}, {"float", "z"}};
  const std::vector<Property> mixed{{"uchar", "red"},  {"double", "z"},  {"float", "nx"},
                                    {"double", "x"},   {"ushort", "id"}, {"double", "y"},
                                    {"char", "flags"}, {"uint", "tag"}};
  const std::vector<Property> ints{{"int", "x"}, {"short", "y"}, {"char", "z"}};
  int n = 0;
  for (const std::string format : {"binary_little_endian", "binary_big_endian", "ascii"}) {
    SCOPED_TRACE(format);
    const bool ascii = format == "ascii";
    auto check = [&](const std::vector<Property>& props, const char* count, const char* index,
                     const auto& p, const auto& f, bool integers) {
      const std::string path =
          file(std::to_string(n++) + ".ply", write_ply(format, props, count, index, p, f));
      if (!ascii) return expect_native_equals_assimp(path);
      const ImportedMesh exact = ascii_by_strtof(path, 0, integers);
      expect_native_equals_assimp(path, &exact);
    };
    check(plain, "uchar", "int", points, faces, false);
    check(ints, "int", "ushort", int_points, int_faces, true);
    if (!ascii)
      check(mixed, "ushort", "uint", points, faces, false);  // xyz out of order: binary only
  }
}

// ASCII bodies are read in parallel chunks of 4 MiB, each parsing the lines that start in it: a
// file of several chunks (lines across every boundary), with Windows line ends, no line break at
// the end, or lines after the last element, reads exactly as the text's numbers through strtof.
TEST_F(PlyFiles, AsciiFilesOfManyChunksReadExactly) {
  std::vector<std::array<double, 3>> points;
  std::vector<std::array<int64_t, 3>> faces;
  random_mesh(400000, 12, points, faces);
  const std::string text = write_ply("ascii", {{"float", "x"}, {"float", "y"}, {"float", "z"}},
                                     "uchar", "int", points, faces);
  ASSERT_GT(text.size(), size_t{12} << 20);
  std::string crlf;
  for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  // A line break as the last byte of the first chunk, so that the second starts with a line.
  std::string on_boundary = text;
  const size_t body = on_boundary.find("end_header\n") + 11;
  const size_t last_byte = body + (size_t{4} << 20) - 1;
  const size_t before = on_boundary.rfind('\n', last_byte);
  on_boundary.insert(before, last_byte - before, ' ');  // spaces at a line's end are separators
  ASSERT_EQ(on_boundary[last_byte], '\n');
  std::string no_final_break = text;
  ASSERT_EQ(no_final_break.back(), '\n');
  no_final_break.pop_back();
  for (const auto& [name, bytes] : {std::pair{"plain", text}, std::pair{"crlf", crlf},
                                    std::pair{"unterminated", no_final_break},
                                    std::pair{"trailing", text + "junk after the faces\n\n"},
                                    std::pair{"boundary", on_boundary}}) {
    SCOPED_TRACE(name);
    const std::string path = file(std::string(name) + ".ply", bytes);
    const std::optional<ImportedMesh> mine = native(path);
    ASSERT_TRUE(mine.has_value());
    expect_same(*mine, ascii_by_strtof(path, 0));
  }
  // One face line short: the text ends before the last element, and assimp gets the file.
  std::string short_text = no_final_break.substr(0, no_final_break.rfind('\n'));
  EXPECT_FALSE(native(file("short.ply", short_text)).has_value());
}

// Negative zeros: the assimp path's identity node transform turns -0 into +0 (x + 0), and the
// native reader must give the same bits (found on the 10M-triangle sphere, 9,483 such coordinates).
TEST_F(PlyFiles, NegativeZerosComeOutAsAssimpGivesThem) {
  const std::vector<std::array<double, 3>> points{
      {-0.0, 0.0, 1.0}, {1.0, -0.0, -0.0}, {0.0, 1.0, -0.0}, {-0.0, -0.0, -0.0}};
  const std::vector<std::array<int64_t, 3>> faces{{0, 1, 2}, {3, 1, 2}};
  const std::vector<Property> with_normals{{"float", "x"},  {"float", "y"},  {"float", "z"},
                                           {"float", "nx"}, {"float", "ny"}, {"float", "nz"}};
  for (const std::string format : {"binary_little_endian", "ascii"}) {
    SCOPED_TRACE(format);
    const std::string path =
        file(format + ".ply", write_ply(format, with_normals, "uchar", "int", points, faces));
    const std::optional<ImportedMesh> mine = native(path);
    ASSERT_TRUE(mine.has_value());
    const ImportedMesh want = import_mesh_file_with_assimp(path);
    ASSERT_EQ(mine->corners.size(), want.corners.size());
    EXPECT_EQ(std::memcmp(mine->corners.data(), want.corners.data(),
                          want.corners.size() * sizeof(glm::vec3)),
              0);
    ASSERT_EQ(mine->normals.size(), want.normals.size());
    for (size_t i = 0; i < want.normals.size(); ++i) {
      for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(std::signbit(mine->normals[i][a]), std::signbit(want.normals[i][a])) << i;
      }
    }
  }
}

TEST_F(PlyFiles, DamagedFilesAreLeftToAssimpAndStillFail) {
  std::vector<std::array<double, 3>> points;
  std::vector<std::array<int64_t, 3>> faces;
  random_mesh(50, 3, points, faces);
  const std::vector<Property> plain{{"float", "x"}, {"float", "y"}, {"float", "z"}};
  const std::string good = write_ply("binary_little_endian", plain, "uchar", "int", points, faces);
  const std::string truncated = good.substr(0, good.size() - 5);
  auto out_of_range = faces;
  out_of_range[17][1] = static_cast<int64_t>(points.size());
  auto negative = faces;
  negative[3][2] = -1;
  std::vector<std::pair<std::string, std::string>> damaged{
      {"truncated", truncated},
      {"index past the vertices",
       write_ply("binary_little_endian", plain, "uchar", "int", points, out_of_range)},
      {"negative index",
       write_ply("binary_little_endian", plain, "uchar", "int", points, negative)},
      {"ascii index past the vertices",
       write_ply("ascii", plain, "uchar", "int", points, out_of_range)},
  };
  // Counts far beyond the file's size, in both formats: damage for the native reader, not a huge
  // allocation. (Only the native reader is asked here: assimp, given such a header, tries the
  // allocation, which takes minutes under AddressSanitizer.)
  for (const std::string format : {"ascii", "binary_little_endian"}) {
    std::string huge = write_ply(format, plain, "uchar", "int", points, faces);
    huge.replace(huge.find("element vertex"), 17, "element vertex 999999999999999");
    EXPECT_FALSE(native(file("huge.ply", huge)).has_value()) << format;
    std::string many = write_ply(format, plain, "uchar", "int", points, faces);
    many.replace(many.find("element face 50"), 15, "element face 99999999999");
    EXPECT_FALSE(native(file("many.ply", many)).has_value()) << format;
  }
  for (const auto& [name, bytes] : damaged) {
    SCOPED_TRACE(name);
    const std::string path = file("damaged.ply", bytes);
    EXPECT_FALSE(native(path).has_value());
    EXPECT_THROW(import_mesh_file(path), Error);
  }
}

TEST_F(PlyFiles, HeadersItDoesNotTakeAreLeftToAssimp) {
  std::vector<std::array<double, 3>> points;
  std::vector<std::array<int64_t, 3>> faces;
  random_mesh(10, 4, points, faces);
  const std::vector<Property> plain{{"float", "x"}, {"float", "y"}, {"float", "z"}};
  std::string quad = write_ply("ascii", plain, "uchar", "int", points, faces);
  quad.replace(quad.rfind("3 "), 2, "4 0 ");  // the last face gets a fourth corner
  std::string face_extra = write_ply("ascii", plain, "uchar", "int", points, faces);
  face_extra.replace(face_extra.find("end_header"), 10, "property uchar flags\nend_header");
  std::string no_z = write_ply("ascii", plain, "uchar", "int", points, faces);
  no_z.replace(no_z.find("property float z"), 16, "property float w");
  for (const std::string& bytes : {quad, face_extra, no_z}) {
    EXPECT_FALSE(native(file("odd.ply", bytes)).has_value());
  }
  // The quad file is a fine file: assimp reads it, fan-triangulating the quad.
  const std::string quad_path = file("quad.ply", quad);
  EXPECT_EQ(import_mesh_file(quad_path).triangles(), faces.size() + 1);
}

}  // namespace
}  // namespace tritrace
