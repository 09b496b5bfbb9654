// tinyobjloader's callback interface reads pieces of the OBJ in parallel, noting the grouping
// statements with their place among the faces; these are then replayed in file order through a
// model of how assimp 5.2's OBJ importer groups faces into meshes (a new object at each `o` or
// changed `g`, a new mesh at a `usemtl` that changes the material of a mesh that has faces, the
// material of a mesh being the one last set on it, objects coming out last first) and how
// aiProcess_Triangulate splits quads, and the triangle arrays are filled in parallel. What the
// model does not cover is declined: a parallel pre-scan of the bytes finds the statements
// tinyobjloader skips or reads differently.
#include "tritrace/scene/io/obj_reader.h"

#if TRITRACE_HAVE_TINYOBJLOADER
#include <assimp/types.h>  // aiVector3D and aiMatrix4x4 with their operations
#include <tbb/blocked_range.h>
#include <tiny_obj_loader.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <climits>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <istream>
#include <iterator>
#include <map>
#include <mutex>
#include <set>
#include <streambuf>
#include <string_view>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/parallel.h"
#include "tritrace/scene/io/load_progress.h"
#include "tritrace/scene/io/material_mapping.h"
#include "tritrace/scene/io/triangle_filter.h"
#endif

namespace tritrace {

#if !TRITRACE_HAVE_TINYOBJLOADER

bool native_obj_reader_built() {
  return false;
}

std::optional<ImportedMesh> read_obj_triangles(std::span<const char>, const std::string&,
                                               const std::string&, size_t) {
  return std::nullopt;
}

#else

namespace {

// assimp refuses OBJ files shorter than this ("OBJ-file is too small").
constexpr size_t kObjMinSize = 16;
constexpr uint32_t kNoMaterial = ~0u;
const std::string kDefaultMaterial = "DefaultMaterial";  // assimp's AI_DEFAULT_MATERIAL_NAME

bool is_blank(char c) {
  return c == ' ' || c == '\t';
}

bool starts_with_word(std::string_view text, size_t at, std::string_view word) {
  if (text.size() - at < word.size() || text.compare(at, word.size(), word) != 0) return false;
  const size_t end = at + word.size();
  return end == text.size() || is_blank(text[end]) || text[end] == '\r' || text[end] == '\n';
}

bool lower_is(std::string_view text, size_t at, const char* two) {
  return text.size() - at > 2 && std::tolower(static_cast<unsigned char>(text[at + 1])) == two[0] &&
         std::tolower(static_cast<unsigned char>(text[at + 2])) == two[1];
}

// Whether the line from `at` holds nothing but blanks.
bool blank_line(std::string_view text, size_t at) {
  while (at < text.size() && (is_blank(text[at]) || text[at] == '\r')) ++at;
  return at == text.size() || text[at] == '\n';
}

struct PreScan {
  bool ok = true;
  std::vector<size_t> mtllib_lines;  // offsets of the `mtllib` statements
};

// Finds, in parallel, what tinyobjloader would read differently from assimp or not see at all:
// line continuations and Windows paths (backslashes, in comments too), bytes of UTF-16 or binary
// data outside comments, decimal commas (assimp reads "1,5" as 1.5), nan and inf (assimp keeps
// them, tinyobjloader reads 0), lone carriage returns, indented statements (blank lines are
// fine), lines and points (`l`, `p`), free-form geometry (`cstype`) and a byte order mark; and it
// collects the `mtllib` statements.
PreScan pre_scan(std::string_view text) {
  PreScan result;
  if (text.size() < kObjMinSize || static_cast<unsigned char>(text[0]) >= 0x80) {
    result.ok = false;
    return result;
  }
  std::atomic<bool> ok{true};
  std::mutex mutex;
  // Each task takes the lines that start in its range, whole.
  parallel::for_range(
      tbb::blocked_range<size_t>(0, text.size(), size_t{1} << 20), [&](const auto& r) {
        std::vector<size_t> mtllibs;
        bool fine = true;
        size_t i = r.begin();
        if (i > 0 && text[i - 1] != '\n') i = std::min(text.find('\n', i), text.size()) + 1;
        while (fine && i < r.end()) {
          const size_t end = std::min(text.find('\n', i), text.size());
          const std::string_view line = text.substr(i, end - i);
          if (line.empty()) {
            // nothing to check
          } else if (line[0] == '#') {
            // A comment may say anything, but a backslash at its end continues it for assimp.
            fine = line.find('\\') == std::string_view::npos;
          } else if (is_blank(line[0])) {
            fine = blank_line(text, i);
          } else {
            // Only lines starting with these letters need a word compared.
            const char c = line[0];
            if ((c == 'l' && starts_with_word(text, i, "l")) ||
                (c == 'p' && starts_with_word(text, i, "p")) ||
                (c == 'c' && starts_with_word(text, i, "cstype"))) {
              fine = false;
            }
            if (c == 'm' && starts_with_word(text, i, "mtllib")) mtllibs.push_back(i);
            for (size_t k = 0; k < line.size() && fine; ++k) {
              switch (line[k]) {
                case '\\':
                case '\0':
                case ',':
                  fine = false;
                  break;
                case '\r':
                  fine = k + 1 == line.size() && end < text.size();
                  break;
                case 'n':
                case 'N':
                  fine = !lower_is(line, k, "an");
                  break;
                case 'i':
                case 'I':
                  fine = !lower_is(line, k, "nf");
                  break;
                default:
                  break;
              }
            }
          }
          i = end + 1;
        }
        if (!fine) ok = false;
        if (!mtllibs.empty()) {
          const std::lock_guard lock(mutex);
          result.mtllib_lines.insert(result.mtllib_lines.end(), mtllibs.begin(), mtllibs.end());
        }
      });
  result.ok = ok;
  std::sort(result.mtllib_lines.begin(), result.mtllib_lines.end());
  return result;
}

std::string_view trimmed(std::string_view s) {
  while (!s.empty() && (is_blank(s.front()) || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (is_blank(s.back()) || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool has_blank(std::string_view s) {
  return std::any_of(s.begin(), s.end(), [](char c) { return is_blank(c); });
}

std::vector<std::string_view> words(std::string_view s) {
  std::vector<std::string_view> out;
  s = trimmed(s);
  while (!s.empty()) {
    size_t end = 0;
    while (end < s.size() && !is_blank(s[end])) ++end;
    out.push_back(s.substr(0, end));
    s = trimmed(s.substr(end));
  }
  return out;
}

// Which keys an MTL material states (tinyobjloader gives its defaults for the others, which are
// not assimp's), with the map names as written.
struct MtlKeys {
  std::string name;
  bool kd = false, ks = false, ke = false, ns = false, ni = false, d = false;
  std::string map_kd, map_ke;
};

// Reads `mtllib` files from the OBJ's folder for tinyobjloader, after checking that each uses only
// what both readers read alike: one-word material names given once, three numbers per colour,
// one per scalar, map_Kd and map_Ke with a plain file name and no options. Tr (which assimp 5.2
// and tinyobjloader may not invert alike) and the PBR extension's Pr and Pm are declined.
class MtlReader final : public tinyobj::MaterialReader {
 public:
  explicit MtlReader(std::string directory) : directory_(std::move(directory)) {}

  bool operator()(const std::string& name, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* map, std::string* warn, std::string* err) override {
    std::ifstream in(std::filesystem::path(directory_) / name, std::ios::binary);
    if (!in) {
      declined = true;  // assimp then tries the OBJ's own name with .mtl
      return false;
    }
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t before = materials->size();
    if (!scan(text)) {
      declined = true;
      return false;
    }
    std::istringstream stream(text);
    tinyobj::LoadMtl(map, materials, &stream, warn, err);
    // tinyobjloader hands over materials->at(0) after a successful read, so an MTL without
    // materials must not be one.
    if (materials->empty() || materials->size() - before != keys_.size() - keys_before_) {
      declined = true;
      return false;
    }
    keys_before_ = keys_.size();
    return true;
  }

  bool declined = false;
  const std::vector<MtlKeys>& keys() const { return keys_; }

 private:
  bool scan(const std::string& text) {
    std::string_view rest(text);
    std::set<std::string, std::less<> > names;
    bool in_material = false;
    while (!rest.empty()) {
      const size_t end = std::min(rest.find('\n'), rest.size());
      const std::vector<std::string_view> w = words(rest.substr(0, end));
      rest.remove_prefix(std::min(end + 1, rest.size()));
      if (w.empty() || w[0][0] == '#') continue;
      const std::string_view key = w[0];
      if (key == "newmtl") {
        if (w.size() != 2 || !names.insert(std::string(w[1])).second) return false;
        keys_.emplace_back();
        keys_.back().name = std::string(w[1]);
        in_material = true;
        continue;
      }
      const bool colour = key == "Kd" || key == "Ks" || key == "Ke";
      const bool scalar = key == "Ns" || key == "Ni" || key == "d";
      const bool map = key == "map_Kd" || key == "map_Ke";
      if (key == "Tr" || key == "Pr" || key == "Pm") return false;
      if (!colour && !scalar && !map) continue;
      if (!in_material) return false;
      if (colour && w.size() != 4) return false;
      if ((scalar || map) && w.size() != 2) return false;
      if (map && w[1][0] == '-') return false;
      MtlKeys& k = keys_.back();
      if (key == "Kd") k.kd = true;
      if (key == "Ks") k.ks = true;
      if (key == "Ke") k.ke = true;
      if (key == "Ns") k.ns = true;
      if (key == "Ni") k.ni = true;
      if (key == "d") k.d = true;
      if (key == "map_Kd") k.map_kd = std::string(w[1]);
      if (key == "map_Ke") k.map_ke = std::string(w[1]);
    }
    return true;
  }

  std::string directory_;
  std::vector<MtlKeys> keys_;
  size_t keys_before_ = 0;
};

// assimp's ObjFile::Material defaults where the MTL says nothing: grey diffuse 0.6, black
// specular and emission, Ns 0, Ni 1, d 1.
MaterialKeys default_keys() {
  MaterialKeys k;
  k.diffuse = glm::vec3(0.6f);
  k.specular = glm::vec3(0.0f);
  k.emissive = glm::vec3(0.0f);
  k.shininess = 0.0f;
  k.ior = 1.0f;
  k.opacity = 1.0f;
  return k;
}

constexpr int32_t kAbsent = INT32_MIN;

struct Corner {
  int32_t v, vt, vn;  // resolved 0-based indices (negative: out of range); kAbsent for none
};

// One of assimp's meshes: a run of consecutive faces with the material last set on it.
struct Run {
  size_t first_face;
  size_t object;  // assimp's object (node) it belongs to
  uint32_t material = kNoMaterial;
  size_t first_triangle = 0;  // where its triangles go in the output
  bool normals = false;       // a face of it has normal indices
  bool uvs = false;           // a face of it has texture coordinate indices
};

struct MaterialEntry {
  explicit MaterialEntry(std::string material_name) : name(std::move(material_name)) {}
  std::string name;
  MaterialKeys keys = default_keys();
  std::string map_kd, map_ke;
};

// A statement that changes how faces are grouped, with the number of faces before it (in its
// piece of the file).
struct Event {
  enum class Kind : uint8_t { kUsemtl, kGroup, kObject, kMtllib } kind;
  size_t face;
  std::string name;
};

// What tinyobjloader reads from one piece of the file (pieces end at line ends and are read in
// parallel): the elements, the faces with indices resolved within the piece (negative ones listed
// in `relative`, to be moved by the counts of the pieces before), and the grouping statements.
struct Piece {
  std::vector<aiVector3D> positions, normals, texcoords;
  std::vector<Corner> corners;
  std::vector<uint32_t> face_start;  // first corner of each face, in this piece
  std::vector<uint8_t> face_parts;   // bit 0: normal indices, bit 1: texture coordinate indices
  std::vector<std::pair<uint32_t, uint8_t> > relative;  // (corner, 0 v / 1 vt / 2 vn)
  std::vector<Event> events;
  bool declined = false;
  // A face with texture coordinate (normal) indices before any `vt` (`vn`) of this piece: fine
  // only if an earlier piece has some.
  bool uvs_before_vt = false, normals_before_vn = false;

  static Piece& of(void* p) { return *static_cast<Piece*>(p); }

  static void vertex(void* p, float x, float y, float z, float w) {
    Piece& r = of(p);
    if (w != 1.0f) r.declined = true;  // homogeneous w or colours: assimp reads those apart
    r.positions.emplace_back(x, y, z);
  }
  static void normal(void* p, float x, float y, float z) { of(p).normals.emplace_back(x, y, z); }
  static void texcoord(void* p, float x, float y, float z) {
    of(p).texcoords.emplace_back(x, y, z);
  }

  // An index as assimp stores it: 1-based, or negative relative to the elements read so far.
  int32_t resolve(int raw, size_t count, uint8_t field) {
    if (raw > 0) return raw - 1;
    relative.emplace_back(static_cast<uint32_t>(corners.size()), field);
    return static_cast<int32_t>(static_cast<int64_t>(count) + raw);
  }

  static void face(void* p, tinyobj::index_t* indices, int n) {
    Piece& r = of(p);
    // Points, lines, polygons of more than four corners and missing vertex indices are left to
    // assimp (its triangulation of n-gons is not reproduced here).
    if (n < 3 || n > 4 || r.declined) {
      r.declined = true;
      return;
    }
    const bool uvs = indices[0].texcoord_index != 0, normals = indices[0].normal_index != 0;
    r.face_start.push_back(static_cast<uint32_t>(r.corners.size()));
    r.face_parts.push_back(static_cast<uint8_t>((normals ? 1 : 0) | (uvs ? 2 : 0)));
    if (uvs && r.texcoords.empty()) r.uvs_before_vt = true;
    if (normals && r.normals.empty()) r.normals_before_vn = true;
    for (int k = 0; k < n; ++k) {
      const tinyobj::index_t& i = indices[k];
      // Every corner with the same parts.
      if (i.vertex_index == 0 || (i.texcoord_index != 0) != uvs ||
          (i.normal_index != 0) != normals) {
        r.declined = true;
      }
      Corner c{r.resolve(i.vertex_index, r.positions.size(), 0), kAbsent, kAbsent};
      if (uvs) c.vt = r.resolve(i.texcoord_index, r.texcoords.size(), 1);
      if (normals) c.vn = r.resolve(i.normal_index, r.normals.size(), 2);
      r.corners.push_back(c);
    }
  }

  void event(Event::Kind kind, std::string_view name) {
    events.push_back({kind, face_start.size(), std::string(name)});
  }
  static void usemtl(void* p, const char* name, int) {
    of(p).event(Event::Kind::kUsemtl, trimmed(name));
  }
  static void group(void* p, const char** names, int n) {
    if (n != 1) {
      of(p).declined = true;
      return;
    }
    of(p).event(Event::Kind::kGroup, names[0]);
  }
  static void object(void* p, const char* name) {
    of(p).event(Event::Kind::kObject, trimmed(name));
  }
};

// Notes the `mtllib` statements of a piece for the replay, which reads the libraries in order.
class MtllibRecorder final : public tinyobj::MaterialReader {
 public:
  explicit MtllibRecorder(Piece& piece) : piece_(piece) {}
  bool operator()(const std::string& name, std::vector<tinyobj::material_t>*,
                  std::map<std::string, int>*, std::string*, std::string*) override {
    piece_.event(Event::Kind::kMtllib, name);
    return false;
  }

 private:
  Piece& piece_;
};

// The statements in file order, replayed as assimp's ObjFileParser acts on them.
struct Replay {
  explicit Replay(MtlReader& mtl_reader) : mtl(mtl_reader) {
    lib.emplace_back(kDefaultMaterial);
    lib_index.emplace(kDefaultMaterial, 0);
  }

  MtlReader& mtl;
  bool declined = false;
  size_t faces = 0;  // faces so far
  // The whole file's elements and faces (filled after the replay of the statements).
  std::vector<aiVector3D> positions, normals, texcoords;
  std::vector<Corner> corners;
  std::vector<size_t> face_start;  // first corner of each face
  std::vector<Run> runs;
  bool has_mesh = false;    // assimp's mCurrentMesh is set
  bool has_object = false;  // assimp's mCurrentObject is set
  // Objects created; runs record the current one (a run made before any object belongs to none,
  // 0, and never gets faces).
  size_t objects = 0;
  std::set<std::string, std::less<> > object_names;
  std::string active_group;
  std::optional<uint32_t> current_material;
  std::vector<MaterialEntry> lib;
  std::map<std::string, uint32_t, std::less<> > lib_index;
  std::vector<tinyobj::material_t> mtl_materials;  // every library's, as tinyobjloader keeps them
  std::map<std::string, int> mtl_map;
  std::set<std::string> mtl_files;
  size_t from_libraries = 0;  // materials taken from mtl_materials

  void create_mesh() {
    runs.push_back({faces, objects});
    has_mesh = true;
  }
  void create_object(const std::string& name) {
    object_names.insert(name);
    has_object = true;
    ++objects;
    create_mesh();
    if (current_material) runs.back().material = *current_material;
  }

  // Faces [faces, end) join the current mesh; parts[i] are their bits as in Piece::face_parts.
  void add_faces(size_t end, const uint8_t* parts) {
    if (end == faces) return;
    if (!has_object) create_object("defaultobject");
    uint8_t any = 0;
    for (size_t i = 0; i < end - faces; ++i) any |= parts[i];
    runs.back().normals |= (any & 1) != 0;
    runs.back().uvs |= (any & 2) != 0;
    faces = end;
  }

  void apply(const Event& e) {
    switch (e.kind) {
      case Event::Kind::kUsemtl:
        return usemtl(e.name);
      case Event::Kind::kGroup:
        if (e.name != active_group) {
          create_object(e.name);
          active_group = e.name;
        }
        return;
      case Event::Kind::kObject:
        if (e.name.empty()) return;
        // assimp switches back to an object of the same name (faces then join another object's
        // meshes) and reads only the first word: both are left to it.
        if (has_blank(e.name) || object_names.count(e.name) != 0) {
          declined = true;
          return;
        }
        return create_object(e.name);
      case Event::Kind::kMtllib:
        return mtllib(e.name);
    }
  }

  void usemtl(const std::string& name) {
    if (name.empty()) return;
    if (has_blank(name)) {
      declined = true;
      return;
    }
    if (current_material && lib[*current_material].name == name) return;
    auto it = lib_index.find(name);
    if (it == lib_index.end()) {  // assimp makes a default material of that name
      lib.emplace_back(name);
      it = lib_index.emplace(name, static_cast<uint32_t>(lib.size() - 1)).first;
    }
    current_material = it->second;
    const bool current_has_faces = has_mesh && faces > runs.back().first_face;
    const bool new_mesh = !has_mesh || (runs.back().material != kNoMaterial &&
                                        runs.back().material != it->second && current_has_faces);
    if (new_mesh) create_mesh();
    runs.back().material = it->second;
  }

  // As tinyobjloader does: a library read once, its materials added to the earlier ones.
  void mtllib(const std::string& file) {
    if (mtl_files.count(file) == 0) {
      std::string warn, err;
      if (!mtl(file, &mtl_materials, &mtl_map, &warn, &err)) {
        declined = true;
        return;
      }
      mtl_files.insert(file);
    }
    const std::vector<MtlKeys>& keys = mtl.keys();
    for (size_t i = from_libraries; i < mtl_materials.size(); ++i) {
      const tinyobj::material_t& m = mtl_materials[i];
      if (i >= keys.size() || keys[i].name != m.name || lib_index.count(m.name) != 0) {
        declined = true;  // defined twice, or used before its definition
        continue;
      }
      const MtlKeys& k = keys[i];
      MaterialEntry e{m.name};
      const auto colour = [](const float* c) { return glm::vec3(c[0], c[1], c[2]); };
      if (k.kd) e.keys.diffuse = colour(m.diffuse);
      if (k.ks) e.keys.specular = colour(m.specular);
      if (k.ke) e.keys.emissive = colour(m.emission);
      if (k.ns) e.keys.shininess = m.shininess;
      if (k.ni) e.keys.ior = m.ior;
      if (k.d) e.keys.opacity = m.dissolve;
      if (k.map_kd != m.diffuse_texname || k.map_ke != m.emissive_texname) declined = true;
      e.map_kd = k.map_kd;
      e.map_ke = k.map_ke;
      lib.push_back(std::move(e));
      lib_index.emplace(m.name, static_cast<uint32_t>(lib.size() - 1));
      ++from_libraries;
    }
  }
};

class MemoryStreamBuf final : public std::streambuf {
 public:
  explicit MemoryStreamBuf(std::span<const char> bytes) {
    char* p = const_cast<char*>(bytes.data());  // read only: the get area is never written
    setg(p, p, p + bytes.size());
  }
};

// aiProcess_Triangulate's split of a quad (assimp 5.2, TriangulateProcess): the fan starts at the
// first corner whose two angles to the neighbours around the opposite diagonal add up to more
// than pi (a concave corner), else at corner 0. Written with assimp's own vector type so that the
// float operations are those it performs.
int quad_start(const aiVector3D* v) {
  for (int i = 0; i < 4; ++i) {
    aiVector3D left = v[(i + 3) % 4] - v[i];
    aiVector3D diag = v[(i + 2) % 4] - v[i];
    aiVector3D right = v[(i + 1) % 4] - v[i];
    left.Normalize();
    diag.Normalize();
    right.Normalize();
    const float angle = std::acos(left * diag) + std::acos(right * diag);
    if (angle > AI_MATH_PI_F) return i;
  }
  return 0;
}

}  // namespace

bool native_obj_reader_built() {
  return true;
}

std::optional<ImportedMesh> read_obj_triangles(std::span<const char> bytes,
                                               const std::string& subject,
                                               const std::string& directory, size_t piece_bytes) {
  const std::string_view text(bytes.data(), bytes.size());
  const PreScan scan = pre_scan(text);
  if (!scan.ok) return std::nullopt;
  for (const size_t at : scan.mtllib_lines) {
    const size_t end = std::min(text.find('\n', at), text.size());
    const std::string_view name = trimmed(text.substr(at + 6, end - at - 6));
    // From memory assimp would look for the library beside the running program.
    if (directory.empty() || name.empty() || has_blank(name)) return std::nullopt;
  }

  // tinyobjloader reads pieces of about piece_bytes, each ending at a line end, in parallel.
  std::vector<size_t> cuts = {0};
  while (cuts.back() < text.size()) {
    size_t cut = std::min(cuts.back() + std::max<size_t>(piece_bytes, 1), text.size());
    while (cut < text.size() && text[cut - 1] != '\n') ++cut;
    cuts.push_back(cut);
  }
  std::vector<Piece> pieces(cuts.size() - 1);
  std::atomic<bool> failed{false};
  // Worker threads report to the calling thread's progress, in bytes parsed.
  LoadProgress* progress = load_progress();
  if (progress != nullptr) progress->begin("parsing", text.size());
  parallel::for_range(tbb::blocked_range<size_t>(0, pieces.size(), 1), [&](const auto& range) {
    for (size_t k = range.begin(); k < range.end(); ++k) {
      Piece& piece = pieces[k];
      // Room for the densest text (a face line takes at least 6 bytes, a corner 2, a vertex
      // 8): reserved, not touched, so that growing never copies.
      const size_t size = cuts[k + 1] - cuts[k];
      piece.positions.reserve(size / 8);
      piece.corners.reserve(size / 2);
      piece.face_start.reserve(size / 6);
      piece.face_parts.reserve(size / 6);
      tinyobj::callback_t callbacks;
      callbacks.vertex_cb = &Piece::vertex;
      callbacks.normal_cb = &Piece::normal;
      callbacks.texcoord_cb = &Piece::texcoord;
      callbacks.index_cb = &Piece::face;
      callbacks.usemtl_cb = &Piece::usemtl;
      callbacks.group_cb = &Piece::group;
      callbacks.object_cb = &Piece::object;
      MtllibRecorder recorder(piece);
      MemoryStreamBuf buffer(bytes.subspan(cuts[k], cuts[k + 1] - cuts[k]));
      std::istream stream(&buffer);
      std::string warn, err;
      try {
        if (!tinyobj::LoadObjWithCallback(stream, callbacks, &piece, &recorder, &warn, &err)) {
          failed = true;
        }
      } catch (const std::exception&) {
        failed = true;  // assimp reads it, or gives its error
      }
      if (progress != nullptr) progress->advance(size);
    }
  });
  if (failed) return std::nullopt;

  // The pieces' statements in order, and where each piece's elements start in the whole file.
  MtlReader mtl(directory);
  Replay replay(mtl);
  struct Base {
    size_t positions = 0, normals = 0, texcoords = 0, corners = 0, faces = 0;
  };
  std::vector<Base> base(pieces.size() + 1);
  for (size_t k = 0; k < pieces.size(); ++k) {
    const Piece& piece = pieces[k];
    if (piece.declined || (piece.uvs_before_vt && base[k].texcoords == 0) ||
        (piece.normals_before_vn && base[k].normals == 0)) {
      return std::nullopt;
    }
    for (const Event& e : piece.events) {
      replay.add_faces(base[k].faces + e.face,
                       piece.face_parts.data() + (replay.faces - base[k].faces));
      replay.apply(e);
      if (replay.declined || mtl.declined) return std::nullopt;
    }
    base[k + 1] = {base[k].positions + piece.positions.size(),
                   base[k].normals + piece.normals.size(),
                   base[k].texcoords + piece.texcoords.size(),
                   base[k].corners + piece.corners.size(), base[k].faces + piece.face_start.size()};
    replay.add_faces(base[k + 1].faces, piece.face_parts.data() + (replay.faces - base[k].faces));
  }
  const Base& total = base.back();
  if (total.faces == 0) return std::nullopt;
  if (total.positions > INT32_MAX || total.normals > INT32_MAX || total.texcoords > INT32_MAX) {
    return std::nullopt;
  }
  replay.positions.resize(total.positions);
  replay.normals.resize(total.normals);
  replay.texcoords.resize(total.texcoords);
  replay.corners.resize(total.corners);
  replay.face_start.resize(total.faces);
  parallel::for_range(tbb::blocked_range<size_t>(0, pieces.size(), 1), [&](const auto& range) {
    for (size_t k = range.begin(); k < range.end(); ++k) {
      Piece& piece = pieces[k];
      const Base& b = base[k];
      for (const auto& [corner, field] : piece.relative) {
        Corner& c = piece.corners[corner];
        int32_t& index = field == 0 ? c.v : field == 1 ? c.vt : c.vn;
        index += static_cast<int32_t>(field == 0   ? b.positions
                                      : field == 1 ? b.texcoords
                                                   : b.normals);
      }
      bool bad = false;
      for (const Corner& c : piece.corners) {
        // Out of range: assimp fails, or drops the mesh's normals or coordinates.
        bad |= c.v < 0 || static_cast<size_t>(c.v) >= total.positions ||
               (c.vt != kAbsent && (c.vt < 0 || static_cast<size_t>(c.vt) >= total.texcoords)) ||
               (c.vn != kAbsent && (c.vn < 0 || static_cast<size_t>(c.vn) >= total.normals));
      }
      if (bad) failed = true;
      std::copy(piece.positions.begin(), piece.positions.end(),
                replay.positions.begin() + static_cast<ptrdiff_t>(b.positions));
      std::copy(piece.normals.begin(), piece.normals.end(),
                replay.normals.begin() + static_cast<ptrdiff_t>(b.normals));
      std::copy(piece.texcoords.begin(), piece.texcoords.end(),
                replay.texcoords.begin() + static_cast<ptrdiff_t>(b.texcoords));
      std::copy(piece.corners.begin(), piece.corners.end(),
                replay.corners.begin() + static_cast<ptrdiff_t>(b.corners));
      for (size_t f = 0; f < piece.face_start.size(); ++f) {
        replay.face_start[b.faces + f] = b.corners + piece.face_start[f];
      }
      piece = Piece();  // its memory back before the triangles are made
    }
  });
  if (failed) return std::nullopt;

  const size_t faces = replay.face_start.size();
  const size_t triangles = replay.corners.size() - 2 * faces;
  if (triangles > kMaxSceneTriangles) {
    throw Error(subject, "has more than " + std::to_string(kMaxSceneTriangles) + " triangles");
  }
  ImportedMesh out;
  ExternalTextures textures(subject, directory, out);
  for (const MaterialEntry& e : replay.lib) {
    MaterialKeys keys = e.keys;
    if (!e.map_kd.empty()) keys.albedo_texture.index = textures.index_of(e.map_kd);
    if (!e.map_ke.empty()) keys.emission_texture.index = textures.index_of(e.map_ke);
    out.materials.push_back(map_material(keys));
    out.material_names.push_back(e.name);
  }

  // A mesh has normals (coordinates) where a face of it has them and the file has some; the
  // others get zeros, as the assimp path fills them in.
  const bool any_normals =
      !replay.normals.empty() &&
      std::any_of(replay.runs.begin(), replay.runs.end(), [](const Run& r) { return r.normals; });
  const bool any_uvs =
      !replay.texcoords.empty() &&
      std::any_of(replay.runs.begin(), replay.runs.end(), [](const Run& r) { return r.uvs; });
  out.indices.resize(3 * triangles);
  out.material.resize(triangles);
  if (any_normals) out.normals.resize(3 * triangles);
  if (any_uvs) out.uvs.resize(3 * triangles);
  std::vector<Run> runs;  // those with faces
  for (size_t i = 0; i < replay.runs.size(); ++i) {
    const size_t next = i + 1 < replay.runs.size() ? replay.runs[i + 1].first_face : faces;
    if (next > replay.runs[i].first_face) runs.push_back(replay.runs[i]);
  }
  out.meshes = runs.size();
  replay.face_start.push_back(replay.corners.size());
  // assimp makes a node per object under the root, and the assimp path walks nodes with a stack:
  // the objects come out last first, each with its meshes in order.
  {
    std::vector<size_t> order(runs.size());
    for (size_t i = 0; i < runs.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return runs[a].object > runs[b].object; });
    size_t next = 0;
    for (const size_t i : order) {
      runs[i].first_triangle = next;
      const size_t end_face = i + 1 < runs.size() ? runs[i + 1].first_face : faces;
      next += (replay.face_start[end_face] - 2 * end_face) -
              (replay.face_start[runs[i].first_face] - 2 * runs[i].first_face);
    }
  }

  // The node transform of assimp's OBJ scenes is the identity, but applying it as the assimp path
  // does keeps its float results, signed zeros included. The vertices are moved once each (the
  // assimp path moves every corner, with the same operations on the same vertex) and the triangles
  // index them: 12 bytes per triangle instead of a copy of every corner.
  const aiMatrix4x4 transform = aiMatrix4x4() * aiMatrix4x4();
  aiMatrix3x3 normal_transform(transform);
  normal_transform.Inverse().Transpose();
  out.positions.resize(replay.positions.size());
  parallel::for_range(tbb::blocked_range<size_t>(0, replay.positions.size(), 1 << 16),
                      [&](const auto& range) {
                        for (size_t i = range.begin(); i != range.end(); ++i) {
                          const aiVector3D v = transform * replay.positions[i];
                          out.positions[i] = glm::vec3(v.x, v.y, v.z);
                        }
                      });
  parallel::for_range(tbb::blocked_range<size_t>(0, faces, 1 << 14), [&](const auto& range) {
    size_t run = static_cast<size_t>(
        std::upper_bound(runs.begin(), runs.end(), range.begin(),
                         [](size_t f, const Run& r) { return f < r.first_face; }) -
        runs.begin() - 1);
    for (size_t f = range.begin(); f < range.end(); ++f) {
      while (run + 1 < runs.size() && runs[run + 1].first_face <= f) ++run;
      const Run& mesh = runs[run];
      const bool normals = mesh.normals && !replay.normals.empty();
      const bool uvs = mesh.uvs && !replay.texcoords.empty();
      const size_t first = replay.face_start[f], n = replay.face_start[f + 1] - first;
      aiVector3D p[4];
      for (size_t k = 0; k < n; ++k) p[k] = replay.positions[replay.corners[first + k].v];
      const int start = n == 4 ? quad_start(p) : 0;
      const size_t tri = mesh.first_triangle + (first - 2 * f) -
                         (replay.face_start[mesh.first_face] - 2 * mesh.first_face);
      for (size_t t = 0; t + 2 < n; ++t) {
        const size_t order[3] = {static_cast<size_t>(start), (start + t + 1) % 4,
                                 (start + t + 2) % 4};
        uint32_t corner[3];
        glm::vec3 normal[3] = {};
        glm::vec2 uv[3] = {};
        for (int k = 0; k < 3; ++k) {
          const Corner& c = replay.corners[first + (n == 4 ? order[k] : order[k] % 3)];
          corner[k] = static_cast<uint32_t>(c.v);
          if (normals) {
            const aiVector3D nv =
                normal_transform * (c.vn != kAbsent ? replay.normals[c.vn] : aiVector3D());
            normal[k] = glm::vec3(nv.x, nv.y, nv.z);
          }
          if (uvs && c.vt != kAbsent)
            uv[k] = glm::vec2(replay.texcoords[c.vt].x, replay.texcoords[c.vt].y);
        }
        const size_t i = tri + t;
        // The assimp path's winding: the second and third corners swap (mesh_import.cpp).
        out.indices[3 * i] = corner[0];
        out.indices[3 * i + 1] = corner[2];
        out.indices[3 * i + 2] = corner[1];
        if (any_normals) {
          out.normals[3 * i] = normal[0];
          out.normals[3 * i + 1] = normal[2];
          out.normals[3 * i + 2] = normal[1];
        }
        if (any_uvs) {
          out.uvs[3 * i] = uv[0];
          out.uvs[3 * i + 1] = uv[2];
          out.uvs[3 * i + 2] = uv[1];
        }
        out.material[i] = mesh.material == kNoMaterial ? 0 : mesh.material;
      }
    }
  });
  return out;
}

#endif  // TRITRACE_HAVE_TINYOBJLOADER

}  // namespace tritrace
