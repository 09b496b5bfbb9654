// assimp does the parsing and triangulation; this file walks the node tree without recursion (a
// hostile file can nest nodes deeply), checks every face index, and converts materials.
#include "tritrace/scene/io/mesh_import.h"

#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <cmath>
#include <cstring>
#include <exception>
#include <mutex>
#include <utility>

#include "tritrace/error.h"
#include "tritrace/scene/io/input_file.h"
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

Material convert_material(const aiMaterial& m) {
  aiColor4D colour;
  if (m.Get(AI_MATKEY_BASE_COLOR, colour) == AI_SUCCESS ||
      m.Get(AI_MATKEY_COLOR_DIFFUSE, colour) == AI_SUCCESS) {
    return {glm::vec3(unit_channel(colour.r), unit_channel(colour.g), unit_channel(colour.b))};
  }
  return {kNeutralGrey};
}

void append_mesh(const aiMesh& mesh, const aiMatrix4x4& transform, uint32_t material,
                 const std::string& subject, ImportedMesh& out) {
  for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
    const aiFace& face = mesh.mFaces[f];
    if (face.mNumIndices != 3) continue;  // points and lines carry no surface
    glm::vec3 corner[3];
    for (int k = 0; k < 3; ++k) {
      const unsigned index = face.mIndices[k];
      if (index >= mesh.mNumVertices) {
        throw Error(subject, "face index " + std::to_string(index) + " out of range (mesh has " +
                                 std::to_string(mesh.mNumVertices) + " vertices)");
      }
      const aiVector3D v = transform * mesh.mVertices[index];
      corner[k] = glm::vec3(v.x, v.y, v.z);
    }
    if (out.triangles() >= kMaxSceneTriangles) {
      throw Error(subject, "has more than " + std::to_string(kMaxSceneTriangles) + " triangles");
    }
    // Model files wind front faces counter-clockwise (outward normal e1 x e2); the lab's normal is
    // cross(e2, e1), so the second and third corners swap to keep the lit side outside.
    out.corners.insert(out.corners.end(), {corner[0], corner[2], corner[1]});
    out.material.push_back(material);
  }
}

ImportedMesh convert_scene(const aiScene& scene, const std::string& subject) {
  ImportedMesh out;
  for (unsigned i = 0; i < scene.mNumMaterials; ++i) {
    out.materials.push_back(convert_material(*scene.mMaterials[i]));
    out.material_names.push_back(scene.mMaterials[i]->GetName().C_Str());
  }
  if (out.materials.empty()) {
    out.materials.push_back({kNeutralGrey});
    out.material_names.push_back("default");
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

// assimp's logger is one global object, so imports that watch it take turns.
std::mutex& import_mutex() {
  static std::mutex mutex;
  return mutex;
}

template <typename ReadFn>
ImportedMesh import_with(const std::string& subject, ReadFn&& read) {
  const std::lock_guard lock(import_mutex());
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
      throw Error(subject, "cannot import: " + one_line(importer.GetErrorString()));
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

}  // namespace

ImportedMesh import_mesh_file(const std::string& path) {
  check_input_file(path);
  return import_with(
      path, [&](Assimp::Importer& importer) { return importer.ReadFile(path, kImportFlags); });
}

ImportedMesh import_mesh_memory(std::span<const uint8_t> bytes, const std::string& format_hint,
                                const std::string& subject) {
  if (bytes.empty()) throw Error(subject, "is empty");
  return import_with(subject, [&](Assimp::Importer& importer) {
    return importer.ReadFileFromMemory(bytes.data(), bytes.size(), kImportFlags,
                                       format_hint.c_str());
  });
}

}  // namespace tritrace
