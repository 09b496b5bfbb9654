// assimp does the parsing and triangulation; this file walks the node tree without recursion (a
// hostile file can nest nodes deeply), checks every face index, and converts materials.
#include "tritrace/scene/io/mesh_import.h"

#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <unistd.h>
#include <algorithm>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <cctype>
#include <cmath>
#include <cstring>
#include <exception>
#include <functional>
#include <optional>
#include <stdexcept>
#include <utility>

#include "tritrace/error.h"
#include "tritrace/scene/io/input_file.h"
#include "tritrace/scene/io/isolated_call.h"
#include "tritrace/scene/io/ply_reader.h"
#include "tritrace/scene/io/triangle_filter.h"

namespace tritrace {
namespace {

// Triangulate turns polygons into triangles; ValidateDataStructure makes assimp itself reject
// files whose indices point outside their vertex arrays, with its own message.
constexpr unsigned kImportFlags = aiProcess_Triangulate | aiProcess_ValidateDataStructure;

// Upper bound on node visits: a file that instances its nodes combinatorially is refused.
constexpr size_t kMaxNodeVisits = size_t{1} << 22;

std::string one_line(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text.empty() ? "unknown reason" : text;
}

float unit_channel(float c) {
  return std::isfinite(c) ? std::clamp(c, 0.0f, 1.0f) : kNeutralGrey.x;
}

// Imported materials are two-sided (emission too): a file's winding says nothing about which side
// should glow, and under `path` every type already reflects on both sides.
Material convert_material(const aiMaterial& m) {
  Material out{kNeutralGrey};
  out.two_sided = true;
  aiColor4D colour;
  if (m.Get(AI_MATKEY_BASE_COLOR, colour) == AI_SUCCESS ||
      m.Get(AI_MATKEY_COLOR_DIFFUSE, colour) == AI_SUCCESS) {
    out.albedo = glm::vec3(unit_channel(colour.r), unit_channel(colour.g), unit_channel(colour.b));
  }
  aiColor4D emissive;
  if (m.Get(AI_MATKEY_COLOR_EMISSIVE, emissive) == AI_SUCCESS) {
    auto channel = [](float x) { return std::isfinite(x) ? std::max(x, 0.0f) : 0.0f; };
    out.emission = glm::vec3(channel(emissive.r), channel(emissive.g), channel(emissive.b));
  }
  return out;
}

void append_mesh(const aiMesh& mesh, const aiMatrix4x4& transform, uint32_t material,
                 const std::string& subject, ImportedMesh& out) {
  // Normals move with the inverse transpose of the transform's linear part (which keeps them
  // perpendicular to the surface under non-uniform scales); they are normalised later.
  aiMatrix3x3 normal_transform(transform);
  normal_transform.Inverse().Transpose();
  // Earlier meshes without normals get zero vectors (add_checked makes them geometric normals).
  const bool normals = mesh.HasNormals() || !out.normals.empty();
  if (normals) out.normals.resize(out.corners.size());
  for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
    const aiFace& face = mesh.mFaces[f];
    if (face.mNumIndices != 3) continue;  // points and lines carry no surface
    glm::vec3 corner[3], normal[3] = {};
    for (int k = 0; k < 3; ++k) {
      const unsigned index = face.mIndices[k];
      if (index >= mesh.mNumVertices) {
        throw Error(subject, "face index " + std::to_string(index) + " out of range (mesh has " +
                                 std::to_string(mesh.mNumVertices) + " vertices)");
      }
      const aiVector3D v = transform * mesh.mVertices[index];
      corner[k] = glm::vec3(v.x, v.y, v.z);
      if (mesh.HasNormals()) {
        const aiVector3D n = normal_transform * mesh.mNormals[index];
        normal[k] = glm::vec3(n.x, n.y, n.z);
      }
    }
    if (out.triangles() >= kMaxSceneTriangles) {
      throw Error(subject, "has more than " + std::to_string(kMaxSceneTriangles) + " triangles");
    }
    // Model files wind front faces counter-clockwise (outward normal e1 x e2); the lab's normal is
    // cross(e2, e1), so the second and third corners swap to keep the lit side outside.
    out.corners.insert(out.corners.end(), {corner[0], corner[2], corner[1]});
    if (normals) out.normals.insert(out.normals.end(), {normal[0], normal[2], normal[1]});
    out.material.push_back(material);
  }
}

ImportedMesh convert_scene(const aiScene& scene, const std::string& subject) {
  ImportedMesh out;
  for (unsigned i = 0; i < scene.mNumMaterials; ++i) {
    out.materials.push_back(convert_material(*scene.mMaterials[i]));
    out.material_names.emplace_back(scene.mMaterials[i]->GetName().C_Str());
  }
  if (out.materials.empty()) {
    out.materials.push_back({kNeutralGrey});
    out.materials.back().two_sided = true;
    out.material_names.emplace_back("default");
  }
  if (scene.mRootNode == nullptr) throw Error(subject, "has no scene graph (no root node)");

  std::vector<std::pair<const aiNode*, aiMatrix4x4>> stack = {
      {scene.mRootNode, scene.mRootNode->mTransformation}};
  size_t visits = 0;
  while (!stack.empty()) {
    const auto [node, transform] = stack.back();
    stack.pop_back();
    if (++visits > kMaxNodeVisits) throw Error(subject, "has too many scene nodes");
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
      const unsigned mesh_index = node->mMeshes[i];
      if (mesh_index >= scene.mNumMeshes) throw Error(subject, "node refers to a missing mesh");
      const aiMesh& mesh = *scene.mMeshes[mesh_index];
      const uint32_t material =
          mesh.mMaterialIndex < out.materials.size() ? mesh.mMaterialIndex : 0;
      const size_t before = out.triangles();
      append_mesh(mesh, transform, material, subject, out);
      if (out.triangles() > before) ++out.meshes;
    }
    for (unsigned i = 0; i < node->mNumChildren; ++i) {
      const aiNode* child = node->mChildren[i];
      if (child != nullptr) stack.emplace_back(child, transform * child->mTransformation);
    }
  }
  if (out.triangles() == 0) throw Error(subject, "contains no triangles");
  return out;
}

// assimp repairs some broken files quietly, reporting only through its log: faces whose indices
// point past the vertex array are dropped with a warning. tritrace treats that as a broken file,
// so the warning is watched for while an import runs.
class LogWatch final : public Assimp::LogStream {
 public:
  void write(const char* message) override {
    if (std::strstr(message, "out-of-range") != nullptr) index_out_of_range = true;
  }
  bool index_out_of_range = false;
};

// Runs in the importer process (import_isolated), which has assimp's global logger to itself.
template <typename ReadFn>
ImportedMesh import_with(const std::string& subject, ReadFn&& read) {
  try {
    Assimp::Importer importer;
    Assimp::DefaultLogger::create(nullptr, Assimp::Logger::NORMAL, 0);
    LogWatch* watch = new LogWatch;  // owned by the logger once attached
    Assimp::DefaultLogger::get()->attachStream(watch, Assimp::Logger::Warn | Assimp::Logger::Err);
    struct KillLogger {
      ~KillLogger() { Assimp::DefaultLogger::kill(); }
    } kill_logger;
    const aiScene* scene = read(importer);
    if (scene == nullptr) {
      const std::string why = one_line(importer.GetErrorString());
      // assimp turns std::bad_alloc into its own error string.
      if (why.find("bad_alloc") != std::string::npos) throw std::bad_alloc();
      throw Error(subject, "cannot import: " + why);
    }
    if (watch->index_out_of_range) {
      throw Error(subject, "cannot import: face indices out of range of the vertex data");
    }
    if (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) {
      throw Error(subject, "cannot import: the file is incomplete");
    }
    return convert_scene(*scene, subject);
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw Error(subject, "cannot import: out of memory");
  } catch (const std::exception& e) {
    throw Error(subject, "cannot import: " + one_line(e.what()));
  }
}

// PLY files go to the native reader first (ply_reader.h), which leaves what it does not take to
// assimp.
bool is_ply(const std::string& path) {
  if (path.size() < 4) return false;
  std::string ext = path.substr(path.size() - 4);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".ply";
}

// ImportedMesh to bytes and back, for the trip from the importer process.
class Bytes {
 public:
  template <typename T>
  void put(const T& value) {
    const auto* p = reinterpret_cast<const uint8_t*>(&value);
    out.insert(out.end(), p, p + sizeof(T));
  }
  template <typename T>
  void put_array(const std::vector<T>& values) {
    put<uint64_t>(values.size());
    const auto* p = reinterpret_cast<const uint8_t*>(values.data());
    out.insert(out.end(), p, p + values.size() * sizeof(T));
  }
  std::vector<uint8_t> out;
};

class Unbytes {
 public:
  explicit Unbytes(const std::vector<uint8_t>& bytes) : in_(bytes) {}
  template <typename T>
  T get() {
    T value{};
    need(sizeof(T));
    std::memcpy(&value, in_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  template <typename T>
  std::vector<T> get_array() {
    const uint64_t n = get<uint64_t>();
    if (n > (in_.size() - pos_) / sizeof(T)) throw std::runtime_error("truncated");
    std::vector<T> values(n);
    // memcpy from or to a null pointer is undefined even for 0 bytes (an empty vector's data()).
    if (n > 0) std::memcpy(values.data(), in_.data() + pos_, n * sizeof(T));
    pos_ += n * sizeof(T);
    return values;
  }

 private:
  void need(size_t n) const {
    if (in_.size() - pos_ < n) throw std::runtime_error("truncated");
  }
  const std::vector<uint8_t>& in_;
  size_t pos_ = 0;
};

std::vector<uint8_t> to_bytes(const ImportedMesh& mesh) {
  Bytes b;
  b.put_array(mesh.corners);
  b.put_array(mesh.material);
  b.put_array(mesh.materials);
  b.put<uint64_t>(mesh.material_names.size());
  for (const std::string& name : mesh.material_names)
    b.put_array(std::vector<char>(name.begin(), name.end()));
  b.put<uint64_t>(mesh.meshes);
  b.put_array(mesh.normals);
  return std::move(b.out);
}

ImportedMesh from_bytes(const std::vector<uint8_t>& bytes, const std::string& subject) {
  try {
    Unbytes in(bytes);
    ImportedMesh mesh;
    mesh.corners = in.get_array<glm::vec3>();
    mesh.material = in.get_array<uint32_t>();
    mesh.materials = in.get_array<Material>();
    const uint64_t names = in.get<uint64_t>();
    for (uint64_t i = 0; i < names; ++i) {
      const std::vector<char> name = in.get_array<char>();
      mesh.material_names.emplace_back(name.begin(), name.end());
    }
    mesh.meshes = static_cast<size_t>(in.get<uint64_t>());
    mesh.normals = in.get_array<glm::vec3>();
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.corners.size()) {
      throw std::runtime_error("normals");
    }
    return mesh;
  } catch (const std::exception&) {
    throw Error(subject, "cannot import: the importer process returned damaged data");
  }
}

// The importer process may use at most half of this machine's memory; a file that asks for more
// (assimp trusts counts in headers) fails there with "out of memory" instead of swapping here.
uint64_t importer_memory_limit() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  const uint64_t physical = pages > 0 && page > 0 ? static_cast<uint64_t>(pages) * page : 0;
  return std::max<uint64_t>(physical / 2, uint64_t{2} << 30);
}

ImportedMesh import_isolated(const std::string& subject, const std::function<ImportedMesh()>& fn) {
  return from_bytes(call_isolated(
                        subject, [&] { return to_bytes(fn()); }, importer_memory_limit()),
                    subject);
}

}  // namespace

ImportedMesh import_mesh_file(const std::string& path) {
  check_input_file(path);
  if (is_ply(path)) {
    const std::string bytes = read_input_file(path);
    if (std::optional<ImportedMesh> mesh = read_ply_triangles(bytes, path)) return std::move(*mesh);
  }
  return import_mesh_file_with_assimp(path);
}

ImportedMesh import_mesh_file_with_assimp(const std::string& path) {
  check_input_file(path);
  return import_isolated(path, [&] {
    return import_with(
        path, [&](Assimp::Importer& importer) { return importer.ReadFile(path, kImportFlags); });
  });
}

ImportedMesh import_mesh_memory(std::span<const uint8_t> bytes, const std::string& format_hint,
                                const std::string& subject) {
  if (bytes.empty()) throw Error(subject, "is empty");
  if (is_ply("." + format_hint)) {
    const std::span<const char> chars(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    if (std::optional<ImportedMesh> mesh = read_ply_triangles(chars, subject)) {
      return std::move(*mesh);
    }
  }
  return import_isolated(
      subject, [&] { return import_mesh_memory_in_process(bytes, format_hint, subject); });
}

ImportedMesh import_mesh_memory_in_process(std::span<const uint8_t> bytes,
                                           const std::string& format_hint,
                                           const std::string& subject) {
  if (bytes.empty()) throw Error(subject, "is empty");
  if (is_ply("." + format_hint)) {
    const std::span<const char> chars(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    if (std::optional<ImportedMesh> mesh = read_ply_triangles(chars, subject)) {
      return std::move(*mesh);
    }
  }
  return import_with(subject, [&](Assimp::Importer& importer) {
    return importer.ReadFileFromMemory(bytes.data(), bytes.size(), kImportFlags,
                                       format_hint.c_str());
  });
}

}  // namespace tritrace
