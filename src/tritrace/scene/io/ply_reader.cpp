// The PLY header is parsed into a small layout description; binary bodies are then read with fixed
// strides (every face is checked to have three indices, so face records have one size too), which
// makes both element arrays readable in parallel chunks. ASCII bodies are read in parallel chunks
// of lines, each line's element known from a count of the line breaks before it.
#include "tritrace/scene/io/ply_reader.h"

#include <assimp/types.h>  // aiVector3D and aiMatrix4x4 with their operations
#include <tbb/blocked_range.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string_view>
#include <type_traits>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/parallel.h"
#include "tritrace/scene/io/load_progress.h"
#include "tritrace/scene/io/triangle_filter.h"

namespace tritrace {
namespace {

enum class Format { kAscii, kLittleEndian, kBigEndian };

enum class Type { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::optional<Type> parse_type(std::string_view name) {
  if (name == "char" || name == "int8") return Type::kInt8;
  if (name == "uchar" || name == "uint8") return Type::kUint8;
  if (name == "short" || name == "int16") return Type::kInt16;
  if (name == "ushort" || name == "uint16") return Type::kUint16;
  if (name == "int" || name == "int32") return Type::kInt32;
  if (name == "uint" || name == "uint32") return Type::kUint32;
  if (name == "float" || name == "float32") return Type::kFloat32;
  if (name == "double" || name == "float64") return Type::kFloat64;
  return std::nullopt;
}

size_t size_of(Type t) {
  switch (t) {
    case Type::kInt8:
    case Type::kUint8:
      return 1;
    case Type::kInt16:
    case Type::kUint16:
      return 2;
    case Type::kInt32:
    case Type::kUint32:
    case Type::kFloat32:
      return 4;
    case Type::kFloat64:
      return 8;
  }
  return 0;
}

bool is_integer(Type t) {
  return t != Type::kFloat32 && t != Type::kFloat64;
}

// What the body holds: V vertex records (x, y, z and optionally nx, ny, nz at byte offsets of
// scalar properties), then F face records of one list (count, then indices).
constexpr int kAttributes = 6;  // x, y, z, nx, ny, nz
struct Layout {
  Format format = Format::kAscii;
  size_t vertices = 0, faces = 0;
  size_t vertex_bytes = 0;  // binary: one vertex record
  size_t vertex_properties = 0;
  int xyz_property[kAttributes] = {-1, -1, -1, -1, -1, -1};  // index among the vertex properties
  size_t xyz_offset[kAttributes] = {};                       // binary: byte offset in the record
  Type xyz_type[kAttributes] = {Type::kFloat32, Type::kFloat32, Type::kFloat32,
                                Type::kFloat32, Type::kFloat32, Type::kFloat32};
  // Any of nx, ny, nz present (a missing one reads as 0, as assimp has it).
  bool normals = false;
  int attributes() const { return normals ? kAttributes : 3; }
  Type count_type = Type::kUint8, index_type = Type::kInt32;
  size_t body = 0;  // offset of the first byte after end_header's line
};

// Splits a header line into whitespace-separated words.
void split_words(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
}
std::vector<std::string_view> line_words(std::string_view line) {
  std::vector<std::string_view> out;
  split_words(line, out);
  return out;
}

bool parse_count(std::string_view text, size_t& out) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size();
}

std::optional<Layout> parse_header(std::span<const char> bytes) {
  const std::string_view all(bytes.data(), bytes.size());
  Layout layout;
  size_t pos = 0;
  bool have_format = false;
  int element = -1;  // 0 vertex, 1 face
  bool face_list = false;
  size_t line_number = 0;
  for (;;) {
    const size_t end = all.find('\n', pos);
    if (end == std::string_view::npos) return std::nullopt;
    const std::vector<std::string_view> w = line_words(all.substr(pos, end - pos));
    pos = end + 1;
    if (line_number++ == 0) {
      if (w.size() != 1 || w[0] != "ply") return std::nullopt;
      continue;
    }
    if (w.empty()) return std::nullopt;
    if (w[0] == "comment" || w[0] == "obj_info") continue;
    // Some writers put free text in the header (Blender 2.4's "Created by ..."); assimp passes
    // over such lines, and so does this reader (the tests compare with assimp on such a file).
    if (w[0] != "end_header" && w[0] != "format" && w[0] != "element" && w[0] != "property") {
      continue;
    }
    if (w[0] == "end_header") break;
    if (w[0] == "format") {
      if (w.size() != 3 || w[2] != "1.0" || have_format) return std::nullopt;
      if (w[1] == "ascii") {
        layout.format = Format::kAscii;
      } else if (w[1] == "binary_little_endian") {
        layout.format = Format::kLittleEndian;
      } else if (w[1] == "binary_big_endian") {
        layout.format = Format::kBigEndian;
      } else {
        return std::nullopt;
      }
      have_format = true;
    } else if (w[0] == "element") {
      // Exactly a vertex element, then a face element.
      if (w.size() != 3 || !have_format) return std::nullopt;
      size_t count = 0;
      if (!parse_count(w[2], count)) return std::nullopt;
      if (element == -1 && w[1] == "vertex") {
        layout.vertices = count;
      } else if (element == 0 && w[1] == "face") {
        layout.faces = count;
      } else {
        return std::nullopt;
      }
      ++element;
    } else if (w[0] == "property") {
      if (element == 0) {
        if (w.size() != 3) return std::nullopt;  // vertex lists are left to assimp
        const std::optional<Type> type = parse_type(w[1]);
        if (!type) return std::nullopt;
        constexpr std::string_view kNames[kAttributes] = {"x", "y", "z", "nx", "ny", "nz"};
        const int axis = static_cast<int>(std::find(kNames, kNames + kAttributes, w[2]) - kNames);
        if (axis < kAttributes) {
          if (layout.xyz_property[axis] >= 0) return std::nullopt;
          layout.xyz_property[axis] = static_cast<int>(layout.vertex_properties);
          layout.xyz_offset[axis] = layout.vertex_bytes;
          layout.xyz_type[axis] = *type;
        }
        ++layout.vertex_properties;
        layout.vertex_bytes += size_of(*type);
      } else if (element == 1) {
        // One index list and nothing else.
        if (face_list || w.size() != 5 || w[1] != "list") return std::nullopt;
        if (w[4] != "vertex_indices" && w[4] != "vertex_index") return std::nullopt;
        const std::optional<Type> count = parse_type(w[2]), index = parse_type(w[3]);
        if (!count || !index || !is_integer(*count) || !is_integer(*index)) return std::nullopt;
        layout.count_type = *count;
        layout.index_type = *index;
        face_list = true;
      } else {
        return std::nullopt;
      }
    } else {
      return std::nullopt;
    }
  }
  if (element != 1 || !face_list || layout.vertices == 0 || layout.faces == 0) return std::nullopt;
  for (int a = 0; a < 3; ++a) {
    if (layout.xyz_property[a] < 0) return std::nullopt;
  }
  layout.normals =
      layout.xyz_property[3] >= 0 || layout.xyz_property[4] >= 0 || layout.xyz_property[5] >= 0;
  layout.body = pos;
  return layout;
}

// A binary value of type t at p, in the file's byte order, as double (exact for every PLY type).
template <bool kSwap>
double binary_value(const char* p, Type t) {
  auto load = [p]<typename T>(T) {
    T v;
    std::memcpy(&v, p, sizeof(T));
    if constexpr (kSwap && sizeof(T) > 1) {
      using U = std::conditional_t<sizeof(T) == 2, uint16_t,
                                   std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>;
      U u = std::bit_cast<U>(v);
      if constexpr (sizeof(T) == 2) u = __builtin_bswap16(u);
      if constexpr (sizeof(T) == 4) u = __builtin_bswap32(u);
      if constexpr (sizeof(T) == 8) u = __builtin_bswap64(u);
      v = std::bit_cast<T>(u);
    }
    return v;
  };
  switch (t) {
    case Type::kInt8:
      return load(int8_t{});
    case Type::kUint8:
      return load(uint8_t{});
    case Type::kInt16:
      return load(int16_t{});
    case Type::kUint16:
      return load(uint16_t{});
    case Type::kInt32:
      return load(int32_t{});
    case Type::kUint32:
      return load(uint32_t{});
    case Type::kFloat32:
      return load(float{});
    case Type::kFloat64:
      return load(double{});
  }
  return 0.0;
}

// Model files wind front faces counter-clockwise; tritrace stores (a, c, b), as mesh_import.cpp,
// and the corners' normals in the same order.
// The assimp path moves every vertex and normal by its scene's node transform, the identity for a
// PLY file; applied here with assimp's own operations, it keeps the float results that path gives,
// signed zeros included (x + 0 turns -0 into +0).
struct NodeTransform {
  NodeTransform() { normal.Inverse().Transpose(); }
  aiMatrix4x4 point = aiMatrix4x4() * aiMatrix4x4();
  aiMatrix3x3 normal{point};
};

// Face `face`'s corners as indices into the file's vertices, in tritrace's order.
void emit(ImportedMesh& out, size_t face, const int64_t idx[3]) {
  out.indices[3 * face] = static_cast<uint32_t>(idx[0]);
  out.indices[3 * face + 1] = static_cast<uint32_t>(idx[2]);
  out.indices[3 * face + 2] = static_cast<uint32_t>(idx[1]);
}

// Once every face is emitted: the file's vertices, each moved by the node transform once (the
// assimp path moves every corner, with the same operations on the same vertex), become the mesh's
// positions, and with the file's normals each corner gets its vertex's normal, moved likewise.
void finish(HugePageVector<glm::vec3>& points, const HugePageVector<glm::vec3>& normals,
            ImportedMesh& out) {
  const NodeTransform t;
  parallel::for_range(tbb::blocked_range<size_t>(0, points.size(), 1 << 16), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const glm::vec3 q = points[i];
      const aiVector3D v = t.point * aiVector3D(q.x, q.y, q.z);
      points[i] = glm::vec3(v.x, v.y, v.z);
    }
  });
  out.positions = std::move(points);
  if (normals.empty()) return;
  out.normals.resize(out.indices.size());
  parallel::for_range(tbb::blocked_range<size_t>(0, out.indices.size(), 1 << 16),
                      [&](const auto& r) {
                        for (size_t k = r.begin(); k != r.end(); ++k) {
                          const glm::vec3 m = normals[out.indices[k]];
                          const aiVector3D w = t.normal * aiVector3D(m.x, m.y, m.z);
                          out.normals[k] = glm::vec3(w.x, w.y, w.z);
                        }
                      });
}

template <bool kSwap>
bool read_binary(std::span<const char> bytes, const Layout& l, ImportedMesh& out) {
  const size_t face_bytes = size_of(l.count_type) + 3 * size_of(l.index_type);
  const size_t available = bytes.size() - l.body;
  if (l.vertex_bytes == 0 || l.vertices > available / l.vertex_bytes) return false;
  if (l.faces > (available - l.vertices * l.vertex_bytes) / face_bytes) return false;
  const char* vertex_data = bytes.data() + l.body;
  const char* face_data = vertex_data + l.vertices * l.vertex_bytes;

  // Worker threads report to the calling thread's progress.
  LoadProgress* progress = load_progress();
  if (progress != nullptr) progress->begin("parsing", l.vertices + l.faces);
  HugePageVector<glm::vec3> points(l.vertices), normals(l.normals ? l.vertices : 0);
  parallel::for_range(tbb::blocked_range<size_t>(0, l.vertices, 1 << 14), [&](const auto& r) {
    if (progress != nullptr) progress->advance(r.size());
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const char* rec = vertex_data + i * l.vertex_bytes;
      for (int a = 0; a < l.attributes(); ++a) {
        // As a float, as assimp keeps it: every PLY type is exact in double, so one rounding.
        (a < 3 ? points : normals)[i][a % 3] =
            l.xyz_property[a] < 0
                ? 0.0f
                : static_cast<float>(binary_value<kSwap>(rec + l.xyz_offset[a], l.xyz_type[a]));
      }
    }
  });

  out.indices.resize(3 * l.faces);
  const size_t index_bytes = size_of(l.index_type), count_bytes = size_of(l.count_type);
  const bool ok = parallel::reduce(
      tbb::blocked_range<size_t>(0, l.faces, 1 << 14), true,
      [&](const auto& r, bool good) {
        if (progress != nullptr) progress->advance(r.size());
        for (size_t f = r.begin(); good && f != r.end(); ++f) {
          const char* rec = face_data + f * face_bytes;
          if (binary_value<kSwap>(rec, l.count_type) != 3.0) return false;
          int64_t idx[3];
          for (int k = 0; k < 3; ++k) {
            const double v = binary_value<kSwap>(rec + count_bytes + k * index_bytes, l.index_type);
            if (!(v >= 0.0 && v < static_cast<double>(l.vertices))) return false;
            idx[k] = static_cast<int64_t>(v);
          }
          emit(out, f, idx);
        }
        return good;
      },
      [](bool a, bool b) { return a && b; });
  if (ok) finish(points, normals, out);
  return ok;
}

// ASCII: one element per line, exactly its values. Lines are numbered by counting the line breaks
// of byte chunks in parallel; then each chunk parses the lines that start in it, a vertex or a face
// by its number, so that chunks never wait on one another.
template <typename T>
bool parse_number(std::string_view s, T& out) {
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size();
}

// Vertex i's attributes from its line's words.
bool parse_vertex(const std::vector<std::string_view>& w, const Layout& l, glm::vec3& point,
                  glm::vec3* normal) {
  if (w.size() != l.vertex_properties) return false;
  for (int a = 0; a < l.attributes(); ++a) {
    float& value = (a < 3 ? point : *normal)[a % 3];
    if (l.xyz_property[a] < 0) {
      value = 0.0f;
      continue;
    }
    const std::string_view s = w[static_cast<size_t>(l.xyz_property[a])];
    if (is_integer(l.xyz_type[a])) {
      int64_t v = 0;
      if (!parse_number(s, v)) return false;
      value = static_cast<float>(v);
    } else if (l.xyz_type[a] == Type::kFloat32) {
      if (!parse_number(s, value)) return false;
    } else {
      double v = 0.0;
      if (!parse_number(s, v)) return false;
      value = static_cast<float>(v);
    }
  }
  return true;
}

// A face line's three vertex indices, in range.
bool parse_face(const std::vector<std::string_view>& w, const Layout& l, int64_t idx[3]) {
  if (w.size() != 4 || w[0] != "3") return false;
  for (int k = 0; k < 3; ++k) {
    if (!parse_number(w[static_cast<size_t>(k) + 1], idx[k])) return false;
    if (idx[k] < 0 || static_cast<uint64_t>(idx[k]) >= l.vertices) return false;
  }
  return true;
}

bool read_ascii(std::span<const char> bytes, const Layout& l, ImportedMesh& out) {
  // A value takes two characters at least (a digit and a separator), a face line eight.
  const size_t body = bytes.size() - l.body;
  if (l.vertices > body / (2 * l.vertex_properties) || l.faces > body / 8) return false;
  const std::string_view text(bytes.data(), bytes.size());
  const size_t elements = l.vertices + l.faces;
  LoadProgress* progress = load_progress();
  if (progress != nullptr) progress->begin("parsing", 2 * body);

  // Chunk c holds the lines that start in [start(c), start(c + 1)); a line starts at the body's
  // first byte and after every line break, except at the end of the text.
  constexpr size_t kChunkBytes = size_t{1} << 22;
  const size_t chunks = (body + kChunkBytes - 1) / kChunkBytes;
  auto start = [&](size_t c) { return l.body + std::min(body, c * kChunkBytes); };
  std::vector<size_t> first_line(chunks + 1, 0);
  parallel::for_range(tbb::blocked_range<size_t>(0, chunks, 1), [&](const auto& r) {
    for (size_t c = r.begin(); c != r.end(); ++c) {
      size_t lines = c == 0 ? 1 : 0;
      // Breaks at i in [start(c) - 1, start(c + 1) - 1) start lines in chunk c (but not at the
      // end).
      const size_t from = c == 0 ? l.body : start(c) - 1, to = start(c + 1) - 1;
      for (size_t i = from; i < to; ++i) lines += text[i] == '\n' ? 1 : 0;
      first_line[c + 1] = lines;
      if (progress != nullptr) progress->advance(start(c + 1) - start(c));
    }
  });
  for (size_t c = 0; c < chunks; ++c) first_line[c + 1] += first_line[c];
  if (first_line[chunks] < elements) return false;  // the text ends before the last element

  HugePageVector<glm::vec3> points(l.vertices), normals(l.normals ? l.vertices : 0);
  out.indices.resize(3 * l.faces);
  const bool ok = parallel::reduce(
      tbb::blocked_range<size_t>(0, chunks, 1), true,
      [&](const auto& r, bool good) {
        std::vector<std::string_view> w;
        for (size_t c = r.begin(); good && c != r.end(); ++c) {
          size_t line = first_line[c];
          size_t pos = start(c);
          if (c > 0) {
            // The first line starting in this chunk starts after the first break at or after
            // start(c) - 1.
            const size_t br = text.find('\n', start(c) - 1);
            pos = br == std::string_view::npos ? text.size() : br + 1;
          }
          while (good && line < std::min(elements, first_line[c + 1]) && pos < start(c + 1)) {
            size_t end = text.find('\n', pos);
            if (end == std::string_view::npos) end = text.size();
            split_words(text.substr(pos, end - pos), w);
            if (line < l.vertices) {
              good = parse_vertex(w, l, points[line], l.normals ? &normals[line] : nullptr);
            } else {
              int64_t idx[3];
              good = parse_face(w, l, idx);
              if (good) emit(out, line - l.vertices, idx);
            }
            ++line;
            pos = end + 1;
          }
          if (progress != nullptr) progress->advance(start(c + 1) - start(c));
        }
        return good;
      },
      [](bool a, bool b) { return a && b; });
  if (!ok) return false;
  finish(points, normals, out);
  return true;
}

}  // namespace

std::optional<ImportedMesh> read_ply_triangles(std::span<const char> bytes,
                                               const std::string& subject) {
  const std::optional<Layout> layout = parse_header(bytes);
  if (!layout) return std::nullopt;
  // Every element takes at least a byte: counts beyond the file are damage, not an allocation.
  const size_t body = bytes.size() - layout->body;
  if (layout->vertices > body || layout->faces > body) return std::nullopt;
  // Corners are 32-bit indices (a file of 2^32 vertices is beyond kMaxInputBytes anyway).
  if (layout->vertices > std::numeric_limits<uint32_t>::max()) return std::nullopt;
  if (layout->faces > kMaxSceneTriangles) {
    throw Error(subject, "has more than " + std::to_string(kMaxSceneTriangles) + " triangles");
  }
  ImportedMesh out;
  bool ok = false;
  switch (layout->format) {
    case Format::kAscii:
      ok = read_ascii(bytes, *layout, out);
      break;
    case Format::kLittleEndian:
      ok = std::endian::native == std::endian::little ? read_binary<false>(bytes, *layout, out)
                                                      : read_binary<true>(bytes, *layout, out);
      break;
    case Format::kBigEndian:
      ok = std::endian::native == std::endian::big ? read_binary<false>(bytes, *layout, out)
                                                   : read_binary<true>(bytes, *layout, out);
      break;
  }
  if (!ok) return std::nullopt;
  // assimp gives a PLY file one material, unnamed, white (its default for PLY), two-sided as every
  // imported material; the tests compare.
  out.material.assign(layout->faces, 0);
  out.materials = {Material{.albedo = glm::vec3(1.0f), .two_sided = true}};
  out.material_names = {""};
  out.meshes = 1;
  return out;
}

}  // namespace tritrace
