// assimp does the parsing and triangulation; this file walks the node tree without recursion (a
// hostile file can nest nodes deeply), checks every face index, and converts materials.
#include "tritrace/scene/io/mesh_import.h"

#include <assimp/GltfMaterial.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <tbb/blocked_range.h>
#include <unistd.h>
#include <algorithm>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/ProgressHandler.hpp>
#include <cctype>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <utility>

#include "tritrace/error.h"
#include "tritrace/image/image_limits.h"
#include "tritrace/parallel.h"
#include "tritrace/scene/io/gltf_json.h"
#include "tritrace/scene/io/gltf_lights.h"  // is_gltf_file
#include "tritrace/scene/io/gltf_materials.h"
#include "tritrace/scene/io/input_file.h"
#include "tritrace/scene/io/isolated_call.h"
#include "tritrace/scene/io/load_progress.h"
#include "tritrace/scene/io/material_mapping.h"
#include "tritrace/scene/io/obj_reader.h"
#include "tritrace/scene/io/ply_reader.h"
#include "tritrace/scene/io/tangents.h"
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

std::optional<float> get_float(const aiMaterial& m, const char* key, unsigned type,
                               unsigned index) {
  float value = 0.0f;
  if (m.Get(key, type, index, value) != AI_SUCCESS) return std::nullopt;
  return value;
}

std::optional<glm::vec3> get_colour(const aiMaterial& m, const char* key, unsigned type,
                                    unsigned index) {
  aiColor4D c;
  if (m.Get(key, type, index, c) != AI_SUCCESS) return std::nullopt;
  return glm::vec3(c.r, c.g, c.b);
}

WrapMode wrap_mode(aiTextureMapMode mode) {
  switch (mode) {
    case aiTextureMapMode_Clamp:
    case aiTextureMapMode_Decal:
      return WrapMode::kClamp;
    case aiTextureMapMode_Mirror:
      return WrapMode::kMirror;
    default:
      return WrapMode::kRepeat;
  }
}

// The textures of one file: each image decoded once, whichever materials use it. Embedded images
// (glTF buffers, .glb) come from the aiScene; external ones are read relative to the model file.
class TextureTable {
 public:
  TextureTable(const aiScene& scene, const std::string& subject, std::string directory,
               ImportedMesh& out)
      : scene_(scene),
        subject_(subject),
        external_(subject, std::move(directory), out),
        out_(out) {}

  // The material's first texture of `type` (tried in order), or none.
  TextureRef find(const aiMaterial& m, std::initializer_list<aiTextureType> types) {
    for (aiTextureType type : types) {
      if (m.GetTextureCount(type) == 0) continue;
      aiString path;
      aiTextureMapMode modes[2] = {aiTextureMapMode_Wrap, aiTextureMapMode_Wrap};
      if (m.GetTexture(type, 0, &path, nullptr, nullptr, nullptr, nullptr, modes) != AI_SUCCESS) {
        continue;
      }
      TextureRef ref;
      ref.index = index_of(path.C_Str(), true);
      ref.wrap_s = wrap_mode(modes[0]);
      ref.wrap_t = wrap_mode(modes[1]);
      return ref;
    }
    return {};
  }

  // A glTF material's texture (gltf_materials.h) with its sampler, coordinate set and transform,
  // its image decoded as colour (`srgb`) or as data.
  TextureRef find_gltf(const GltfTextureRef& g, const GltfMaterialTable& table, bool srgb) {
    if (!g.present()) return {};
    const GltfImage& image = table.images[static_cast<size_t>(g.image)];
    TextureRef ref;
    // assimp names an embedded image "*N" (aiScene::GetEmbeddedTexture).
    std::string path = image.uri;
    if (image.embedded >= 0) path = std::string(1, '*').append(std::to_string(image.embedded));
    ref.index = index_of(path, srgb);
    ref.wrap_s = g.wrap_s;
    ref.wrap_t = g.wrap_t;
    ref.texcoord = g.texcoord;
    std::copy(std::begin(g.transform), std::end(g.transform), std::begin(ref.transform));
    return ref;
  }

 private:
  // The image at `path`, decoded as colour or as data: the first use decides how an image is
  // read, and one used both ways is held twice.
  int32_t index_of(const std::string& path, bool srgb) {
    const int32_t i = index_of(path);
    const auto [it, first] = decoding_.emplace(i, srgb);
    if (first) {
      out_.textures[static_cast<size_t>(i)].srgb = srgb;
      return i;
    }
    if (it->second == srgb) return i;
    const auto [copy, added] = other_way_.emplace(i, -1);
    if (added) {
      TextureImage image = out_.textures[static_cast<size_t>(i)];
      image.srgb = srgb;
      out_.textures.push_back(std::move(image));
      copy->second = static_cast<int32_t>(out_.textures.size() - 1);
    }
    return copy->second;
  }

  int32_t index_of(const std::string& path) {
    const aiTexture* embedded = scene_.GetEmbeddedTexture(path.c_str());
    if (embedded == nullptr) return external_.index_of(path);
    if (const auto it = embedded_.find(path); it != embedded_.end()) return it->second;
    out_.textures.push_back(decode_embedded(*embedded, path));
    const auto index = static_cast<int32_t>(out_.textures.size() - 1);
    embedded_.emplace(path, index);
    return index;
  }

  TextureImage decode_embedded(const aiTexture& t, const std::string& path) const {
    const std::string what = subject_ + " (embedded texture '" + one_line(path) + "')";
    if (t.mHeight == 0) {  // compressed: mWidth bytes of a PNG, JPEG ... file
      return decode_texture_image(
          std::span(reinterpret_cast<const uint8_t*>(t.pcData), static_cast<size_t>(t.mWidth)),
          what);
    }
    try {
      check_image_sides(t.mWidth, t.mHeight, what);
    } catch (const Error& e) {
      throw Error(what, "cannot read texture: " + e.reason());
    }
    TextureImage image{static_cast<int>(t.mWidth), static_cast<int>(t.mHeight), {}, {}, true};
    image.rgb.reserve(static_cast<size_t>(t.mWidth) * t.mHeight * 3);
    image.alpha.reserve(static_cast<size_t>(t.mWidth) * t.mHeight);
    for (size_t i = 0; i < static_cast<size_t>(t.mWidth) * t.mHeight; ++i) {
      image.rgb.insert(image.rgb.end(), {t.pcData[i].r, t.pcData[i].g, t.pcData[i].b});
      image.alpha.push_back(t.pcData[i].a);
    }
    drop_opaque_alpha(image);
    return image;
  }

  const aiScene& scene_;
  const std::string& subject_;
  ExternalTextures external_;  // files beside the model
  ImportedMesh& out_;
  std::map<std::string, int32_t> embedded_;
  std::map<int32_t, bool> decoding_;      // image index -> read as colour
  std::map<int32_t, int32_t> other_way_;  // image index -> its copy read the other way
};

// glTF's alphaMode, alphaCutoff and the base colour factor's alpha (assimp keeps all three; its
// base colour texture is the albedo texture, whose alpha channel the alpha test also reads). The
// alpha mode of other formats stays opaque: OBJ's dissolve maps to glass (material_mapping.h).
void read_alpha_mode(const aiMaterial& m, Material& out) {
  aiString mode;
  if (m.Get(AI_MATKEY_GLTF_ALPHAMODE, mode) != AI_SUCCESS) return;
  const std::string name = mode.C_Str();
  if (name == "MASK") {
    out.alpha_mode = AlphaMode::kMask;
  } else if (name == "BLEND") {
    out.alpha_mode = AlphaMode::kBlend;
  } else {
    return;  // "OPAQUE" (glTF's default): alpha is ignored
  }
  aiColor4D base;
  if (m.Get(AI_MATKEY_BASE_COLOR, base) == AI_SUCCESS && std::isfinite(base.a)) {
    out.alpha = std::clamp(base.a, 0.0f, 1.0f);
  }
  if (const std::optional<float> cutoff = get_float(m, AI_MATKEY_GLTF_ALPHACUTOFF);
      cutoff && std::isfinite(*cutoff)) {
    out.alpha_cutoff = std::max(*cutoff, 0.0f);
  }
}

// assimp's keys, as they are, for the one mapping (material_mapping.h).
Material convert_material(const aiMaterial& m, TextureTable& textures) {
  MaterialKeys keys;
  keys.metallic = get_float(m, AI_MATKEY_METALLIC_FACTOR);
  keys.roughness = get_float(m, AI_MATKEY_ROUGHNESS_FACTOR);
  keys.base_colour = get_colour(m, AI_MATKEY_BASE_COLOR);
  keys.diffuse = get_colour(m, AI_MATKEY_COLOR_DIFFUSE);
  keys.specular = get_colour(m, AI_MATKEY_COLOR_SPECULAR);
  keys.emissive = get_colour(m, AI_MATKEY_COLOR_EMISSIVE);
  keys.emissive_intensity = get_float(m, AI_MATKEY_EMISSIVE_INTENSITY);
  keys.ior = get_float(m, AI_MATKEY_REFRACTI);
  keys.shininess = get_float(m, AI_MATKEY_SHININESS);
  keys.opacity = get_float(m, AI_MATKEY_OPACITY);
  keys.transmission = get_float(m, AI_MATKEY_TRANSMISSION_FACTOR);
  keys.albedo_texture = textures.find(m, {aiTextureType_BASE_COLOR, aiTextureType_DIFFUSE});
  keys.emission_texture = textures.find(m, {aiTextureType_EMISSIVE});
  Material out = map_material(keys);
  read_alpha_mode(m, out);
  return out;
}

// The tangents at the corners of `mesh`'s triangle faces (three per triangle face, in face order,
// in the mesh's own space): the file's TANGENT attribute, which assimp gives as tangents and
// bitangents cross(n, t) w, or for a normal-mapped glTF material without it, tangents computed
// from the normal map's coordinate set (tangents.h). Empty otherwise.
std::vector<glm::vec4> corner_tangents(const aiMesh& mesh, const GltfMaterial* gltf) {
  std::vector<glm::vec4> out;
  // Only a normal map reads tangents: other meshes store none (16 bytes a corner).
  const bool normal_map = gltf != nullptr && gltf->normal.present();
  if (!normal_map) return out;
  if (mesh.HasTangentsAndBitangents() && mesh.HasNormals()) {
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) continue;
      for (int k = 0; k < 3; ++k) {
        const unsigned i = face.mIndices[k];
        if (i >= mesh.mNumVertices) return {};  // append_mesh reports the bad index
        const aiVector3D t = mesh.mTangents[i], b = mesh.mBitangents[i], n = mesh.mNormals[i];
        const float w = ((n ^ t) * b) < 0.0f ? -1.0f : 1.0f;  // b = w (n x t)
        out.emplace_back(t.x, t.y, t.z, w);
      }
    }
    return out;
  }
  const unsigned set = gltf->normal.texcoord;
  if (!mesh.HasTextureCoords(set)) return out;
  std::vector<glm::vec3> positions(mesh.mNumVertices), normals;
  std::vector<glm::vec2> uvs(mesh.mNumVertices);
  for (unsigned i = 0; i < mesh.mNumVertices; ++i) {
    positions[i] = glm::vec3(mesh.mVertices[i].x, mesh.mVertices[i].y, mesh.mVertices[i].z);
    uvs[i] = glm::vec2(mesh.mTextureCoords[set][i].x, mesh.mTextureCoords[set][i].y);
    if (mesh.HasNormals()) {
      normals.emplace_back(mesh.mNormals[i].x, mesh.mNormals[i].y, mesh.mNormals[i].z);
    }
  }
  std::vector<uint32_t> indices;
  for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
    const aiFace& face = mesh.mFaces[f];
    if (face.mNumIndices == 3) indices.insert(indices.end(), face.mIndices, face.mIndices + 3);
  }
  return mikktspace_tangents(positions, normals, uvs, indices);
}

// What the glTF JSON says (gltf_materials.h) laid over `out`, the material assimp's keys gave:
// every texture again with its coordinate set and transform, the data textures, emission as
// emissiveFactor times KHR_materials_emissive_strength, KHR_materials_ior and
// KHR_materials_transmission.
void apply_gltf_material(const GltfMaterial& g, const GltfMaterialTable& table,
                         TextureTable& textures, Material& out) {
  out.albedo_texture = textures.find_gltf(g.base_colour, table, true);
  out.emission_texture = textures.find_gltf(g.emissive, table, true);
  out.metallic_roughness_texture = textures.find_gltf(g.metallic_roughness, table, false);
  out.normal_texture = textures.find_gltf(g.normal, table, false);
  out.transmission_texture = textures.find_gltf(g.transmission_texture, table, false);
  out.normal_scale = g.normal_scale;
  const auto channel = [](float x) { return x > 0.0f ? x : 0.0f; };  // NaN to 0 too
  out.emission = glm::vec3(channel(g.emissive_factor.x), channel(g.emissive_factor.y),
                           channel(g.emissive_factor.z)) *
                 channel(g.emissive_strength);
  if (!std::isfinite(out.emission.x + out.emission.y + out.emission.z)) {
    throw Error("", "an emissive strength beyond float range");
  }
  // Indices the BSDFs handle (Material::ior): from 1 (an invisible interface) to 4.
  if (g.ior && *g.ior >= 1.0f && *g.ior <= 4.0f && ior_supported(*g.ior)) out.ior = *g.ior;
  out.transmission = std::clamp(g.transmission, 0.0f, 1.0f);
}

// The glTF material of assimp's material `index`, or null (assimp appends a default material,
// and files other than glTF have none).
const GltfMaterial* gltf_material(const GltfMaterialTable* table, size_t index) {
  return table != nullptr && index < table->materials.size() ? &table->materials[index] : nullptr;
}

// `gltf_file`: the file is glTF, whose vertex colours and second coordinate set are read (other
// formats' are not: their materials do not say to multiply the colours in); `gltf` its material.
void append_mesh(const aiMesh& mesh, const aiMatrix4x4& transform, uint32_t material,
                 bool gltf_file, const GltfMaterial* gltf, const std::string& subject,
                 ImportedMesh& out) {
  const bool has_uvs = mesh.HasTextureCoords(0);
  const bool uvs = has_uvs || !out.uvs.empty();
  if (uvs) out.uvs.resize(out.corners.size(), glm::vec2(0.0f));
  // Normals move with the inverse transpose of the transform's linear part (which keeps them
  // perpendicular to the surface under non-uniform scales); they are normalised later.
  aiMatrix3x3 normal_transform(transform);
  normal_transform.Inverse().Transpose();
  // Earlier meshes without normals get zero vectors (add_checked makes them geometric normals).
  const bool normals = mesh.HasNormals() || !out.normals.empty();
  if (normals) out.normals.resize(out.corners.size(), glm::vec3(0.0f));
  // glTF's further attributes (ImportedMesh), earlier meshes without them given the defaults.
  const std::vector<glm::vec4> tangent = corner_tangents(mesh, gltf);
  const bool has_colours = gltf_file && mesh.HasVertexColors(0);
  const bool has_uvs1 = gltf_file && mesh.HasTextureCoords(1);
  const bool tangents = !tangent.empty() || !out.tangents.empty();
  const bool colours = has_colours || !out.colours.empty();
  const bool uvs1 = has_uvs1 || !out.uvs1.empty();
  if (tangents) out.tangents.resize(out.corners.size(), glm::vec4(0.0f));
  if (colours) out.colours.resize(out.corners.size(), glm::vec4(1.0f));
  if (uvs1) out.uvs1.resize(out.corners.size(), glm::vec2(0.0f));
  // Tangents move with the transform's linear part; a mirroring transform turns the bitangent
  // w cross(n, t) around, so w turns with it.
  const aiMatrix3x3 linear(transform);
  const float handedness = linear.Determinant() < 0.0f ? -1.0f : 1.0f;
  size_t triangle = 0;  // this mesh's triangle faces so far (the index into `tangent`)
  for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
    const aiFace& face = mesh.mFaces[f];
    if (face.mNumIndices != 3) continue;  // points and lines carry no surface
    glm::vec3 corner[3], normal[3] = {};
    glm::vec2 uv[3] = {}, uv1[3] = {};
    glm::vec4 colour[3] = {glm::vec4(1.0f), glm::vec4(1.0f), glm::vec4(1.0f)};
    glm::vec4 tan[3] = {};
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
      if (has_uvs)
        uv[k] = glm::vec2(mesh.mTextureCoords[0][index].x, mesh.mTextureCoords[0][index].y);
      if (has_uvs1)
        uv1[k] = glm::vec2(mesh.mTextureCoords[1][index].x, mesh.mTextureCoords[1][index].y);
      if (has_colours) {
        const aiColor4D& c = mesh.mColors[0][index];
        colour[k] = glm::vec4(c.r, c.g, c.b, c.a);
      }
      if (!tangent.empty()) {
        const glm::vec4 t = tangent[3 * triangle + static_cast<size_t>(k)];
        const aiVector3D moved = linear * aiVector3D(t.x, t.y, t.z);
        tan[k] = glm::vec4(moved.x, moved.y, moved.z, t.w * handedness);
      }
    }
    ++triangle;
    if (out.triangles() >= kMaxSceneTriangles) {
      throw Error(subject, "has more than " + std::to_string(kMaxSceneTriangles) + " triangles");
    }
    // Model files wind front faces counter-clockwise (outward normal e1 x e2); the lab's normal is
    // cross(e2, e1), so the second and third corners swap to keep the lit side outside.
    out.corners.insert(out.corners.end(), {corner[0], corner[2], corner[1]});
    if (normals) out.normals.insert(out.normals.end(), {normal[0], normal[2], normal[1]});
    if (uvs) out.uvs.insert(out.uvs.end(), {uv[0], uv[2], uv[1]});
    if (tangents) out.tangents.insert(out.tangents.end(), {tan[0], tan[2], tan[1]});
    if (colours) out.colours.insert(out.colours.end(), {colour[0], colour[2], colour[1]});
    if (uvs1) out.uvs1.insert(out.uvs1.end(), {uv1[0], uv1[2], uv1[1]});
    out.material.push_back(material);
  }
}

// `gltf`: the file's glTF materials (null for other formats).
ImportedMesh convert_scene(const aiScene& scene, const std::string& subject,
                           const std::string& directory, const GltfMaterialTable* gltf) {
  ImportedMesh out;
  TextureTable textures(scene, subject, directory, out);
  for (unsigned i = 0; i < scene.mNumMaterials; ++i) {
    out.materials.push_back(convert_material(*scene.mMaterials[i], textures));
    // A guard on the numbering (GltfMaterialTable::materials): a named material must be the one
    // assimp named so, else assimp's reading of it stands.
    const GltfMaterial* g = gltf_material(gltf, i);
    if (g != nullptr && (g->name.empty() || g->name == scene.mMaterials[i]->GetName().C_Str())) {
      try {
        apply_gltf_material(*g, *gltf, textures, out.materials.back());
      } catch (const Error& e) {
        if (!e.subject().empty()) throw;
        throw Error(subject,
                    "/materials/" + std::to_string(gltf->file_index[i]) + ": " + e.reason());
      }
    }
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
      append_mesh(mesh, transform, material, gltf != nullptr,
                  gltf_material(gltf, mesh.mMaterialIndex), subject, out);
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
// `directory` is where external textures are looked for (empty for a model read from memory).
// assimp's progress (a fraction: half for reading the file, half for post-processing) as the
// "importing" step of the calling thread's LoadProgress.
class ImportProgress final : public Assimp::ProgressHandler {
 public:
  explicit ImportProgress(LoadProgress& progress) : progress_(progress) {}
  bool Update(float fraction) override {
    if (fraction >= 0.0f) {
      progress_.set(static_cast<uint64_t>(std::min(fraction, 1.0f) * kImportSteps));
    }
    return true;
  }
  static constexpr uint64_t kImportSteps = 1000;

 private:
  LoadProgress& progress_;
};

// `gltf_json` reads a glTF file's JSON text for its materials (gltf_materials.h); null for other
// formats.
template <typename ReadFn>
ImportedMesh import_with(const std::string& subject, const std::string& directory,
                         const std::function<std::string()>& gltf_json, ReadFn&& read) {
  try {
    Assimp::Importer importer;
    if (LoadProgress* progress = load_progress()) {
      progress->begin("importing", ImportProgress::kImportSteps);
      importer.SetProgressHandler(new ImportProgress(*progress));  // the importer deletes it
    }
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
    if (gltf_json) {
      const GltfMaterialTable table = parse_gltf_materials(gltf_json(), subject);
      return convert_scene(*scene, subject, directory, &table);
    }
    return convert_scene(*scene, subject, directory, nullptr);
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw Error(subject, "cannot import: out of memory");
  } catch (const std::exception& e) {
    throw Error(subject, "cannot import: " + one_line(e.what()));
  }
}

// PLY and OBJ files go to the native readers first (ply_reader.h, obj_reader.h), which leave what
// they do not take to assimp.
bool has_extension(const std::string& path, const char* extension) {
  if (path.size() < 4) return false;
  std::string ext = path.substr(path.size() - 4);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == extension;
}

bool is_ply(const std::string& path) {
  return has_extension(path, ".ply");
}

bool is_obj(const std::string& path) {
  return has_extension(path, ".obj");
}

// The folder assimp resolves a model's material libraries and textures in.
std::string model_folder(const std::string& path) {
  const std::string folder = std::filesystem::path(path).parent_path().string();
  return folder.empty() ? "." : folder;
}

// The native readers' result for these bytes, or nullopt for assimp to read them. `directory` is
// the model's folder, empty for bytes from memory.
std::optional<ImportedMesh> read_natively(std::span<const char> bytes, const std::string& extension,
                                          const std::string& subject,
                                          const std::string& directory) {
  if (is_ply(extension)) return read_ply_triangles(bytes, subject);
  if (is_obj(extension)) return read_obj_triangles(bytes, subject, directory);
  return std::nullopt;
}

// ImportedMesh to bytes and back, for the trip from the importer process.
// Writes values one after another at `out`, or only counts their bytes when `out` is null: the
// first of two passes (the size, then the bytes straight into the memory shared with the parent).
class Bytes {
 public:
  explicit Bytes(uint8_t* out = nullptr) : out_(out) {}
  template <typename T>
  void put(const T& value) {
    put_raw(&value, sizeof(T));
  }
  template <typename T>
  void put_array(std::span<const T> values) {
    put<uint64_t>(values.size());
    put_raw(values.data(), values.size_bytes());
  }
  template <typename T, typename Allocator>
  void put_array(const std::vector<T, Allocator>& values) {
    put_array(std::span<const T>(values));
  }
  uint64_t size() const { return size_; }

 private:
  void put_raw(const void* p, size_t n) {
    if (out_ != nullptr && n > 0) std::memcpy(out_ + size_, p, n);
    size_ += n;
  }
  uint8_t* out_;
  uint64_t size_ = 0;
};

class Unbytes {
 public:
  explicit Unbytes(std::span<const uint8_t> bytes) : in_(bytes) {}
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
    std::vector<T> values;
    get_array(values);
    return values;
  }
  template <typename T, typename Allocator>
  void get_array(std::vector<T, Allocator>& values) {
    const uint64_t n = get<uint64_t>();
    if (n > (in_.size() - pos_) / sizeof(T)) throw std::runtime_error("truncated");
    values.resize(n);
    // memcpy from or to a null pointer is undefined even for 0 bytes (an empty vector's data()).
    if (n > 0) std::memcpy(values.data(), in_.data() + pos_, n * sizeof(T));
    pos_ += n * sizeof(T);
  }

 private:
  void need(size_t n) const {
    if (in_.size() - pos_ < n) throw std::runtime_error("truncated");
  }
  std::span<const uint8_t> in_;
  size_t pos_ = 0;
};

void put_mesh(const ImportedMesh& mesh, Bytes& b) {
  b.put_array(mesh.corners);
  b.put_array(mesh.material);
  b.put_array(mesh.materials);
  b.put<uint64_t>(mesh.material_names.size());
  for (const std::string& name : mesh.material_names) {
    b.put_array(std::span<const char>(name.data(), name.size()));
  }
  b.put<uint64_t>(mesh.meshes);
  b.put_array(mesh.normals);
  b.put_array(mesh.uvs);
  b.put_array(mesh.tangents);
  b.put_array(mesh.colours);
  b.put_array(mesh.uvs1);
  b.put<uint64_t>(mesh.textures.size());
  for (const TextureImage& t : mesh.textures) {
    b.put<int32_t>(t.width);
    b.put<int32_t>(t.height);
    b.put<uint8_t>(t.srgb ? 1 : 0);
    b.put_array(t.rgb);
    b.put_array(t.alpha);
  }
}

ImportedMesh from_bytes(std::span<const uint8_t> bytes, const std::string& subject) {
  try {
    Unbytes in(bytes);
    ImportedMesh mesh;
    in.get_array(mesh.corners);
    in.get_array(mesh.material);
    mesh.materials = in.get_array<Material>();
    const uint64_t names = in.get<uint64_t>();
    for (uint64_t i = 0; i < names; ++i) {
      const std::vector<char> name = in.get_array<char>();
      mesh.material_names.emplace_back(name.begin(), name.end());
    }
    mesh.meshes = static_cast<size_t>(in.get<uint64_t>());
    in.get_array(mesh.normals);
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.corners.size()) {
      throw std::runtime_error("normals");
    }
    in.get_array(mesh.uvs);
    in.get_array(mesh.tangents);
    in.get_array(mesh.colours);
    in.get_array(mesh.uvs1);
    for (const size_t n :
         {mesh.uvs.size(), mesh.tangents.size(), mesh.colours.size(), mesh.uvs1.size()}) {
      if (n != 0 && n != mesh.corners.size()) throw std::runtime_error("corner attributes");
    }
    const uint64_t textures = in.get<uint64_t>();
    for (uint64_t i = 0; i < textures; ++i) {
      TextureImage t;
      t.width = in.get<int32_t>();
      t.height = in.get<int32_t>();
      t.srgb = in.get<uint8_t>() != 0;
      t.rgb = in.get_array<uint8_t>();
      t.alpha = in.get_array<uint8_t>();
      const size_t texels = static_cast<size_t>(t.width) * static_cast<size_t>(t.height);
      if (t.width <= 0 || t.height <= 0 || t.rgb.size() != texels * 3 ||
          (!t.alpha.empty() && t.alpha.size() != texels)) {
        throw std::runtime_error("texture");
      }
      mesh.textures.push_back(std::move(t));
    }
    for (const Material& m : mesh.materials) {
      for (const TextureRef* r : m.texture_refs()) {
        if (r->present() && static_cast<uint64_t>(r->index) >= textures) {
          throw std::runtime_error("texture index");
        }
      }
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
  // The mesh lives in the child until it has written it out (the lambda's copy of the shared_ptr).
  const IsolatedResult result = call_isolated(
      subject,
      [&] {
        auto mesh = std::make_shared<ImportedMesh>(fn());
        mesh->expand_corners();  // the hand-over carries the corner form
        Bytes counter;
        put_mesh(*mesh, counter);
        return IsolatedOutput{counter.size(), [mesh](uint8_t* out) {
                                Bytes b(out);
                                put_mesh(*mesh, b);
                              }};
      },
      importer_memory_limit());
  progress_begin("unpacking", 0);
  return from_bytes(result.bytes(), subject);
}

}  // namespace

void ImportedMesh::expand_corners() {
  if (!indexed()) return;
  corners.resize(indices.size());
  parallel::for_range(tbb::blocked_range<size_t>(0, indices.size(), 1 << 16), [&](const auto& r) {
    for (size_t k = r.begin(); k != r.end(); ++k) corners[k] = positions[indices[k]];
  });
  positions = {};
  indices = {};
}

ImportedMesh import_mesh_file(const std::string& path) {
  check_input_file(path);
  if (is_ply(path) || is_obj(path)) {
    const MappedFile file(path);
    if (std::optional<ImportedMesh> mesh =
            read_natively(file.bytes(), path, path, model_folder(path))) {
      return std::move(*mesh);
    }
  }
  return import_mesh_file_with_assimp(path);
}

ImportedMesh import_mesh_file_with_assimp(const std::string& path) {
  check_input_file(path);
  return import_isolated(path, [&] {
    std::function<std::string()> json;
    if (is_gltf_file(path)) json = [&] { return read_gltf_json_text(path); };
    return import_with(path, model_folder(path), json, [&](Assimp::Importer& importer) {
      return importer.ReadFile(path, kImportFlags);
    });
  });
}

ImportedMesh import_mesh_memory(std::span<const uint8_t> bytes, const std::string& format_hint,
                                const std::string& subject) {
  if (bytes.empty()) throw Error(subject, "is empty");
  const std::span<const char> chars(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (std::optional<ImportedMesh> mesh = read_natively(chars, "." + format_hint, subject, "")) {
    return std::move(*mesh);
  }
  return import_isolated(
      subject, [&] { return import_mesh_memory_in_process(bytes, format_hint, subject); });
}

ImportedMesh import_mesh_memory_in_process(std::span<const uint8_t> bytes,
                                           const std::string& format_hint,
                                           const std::string& subject) {
  if (bytes.empty()) throw Error(subject, "is empty");
  const std::span<const char> chars(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (std::optional<ImportedMesh> mesh = read_natively(chars, "." + format_hint, subject, "")) {
    return std::move(*mesh);
  }
  std::function<std::string()> json;
  if (is_gltf_file("model." + format_hint)) {
    json = [&] { return std::string(gltf_json_text(bytes, subject)); };
  }
  return import_with(subject, "", json, [&](Assimp::Importer& importer) {
    return importer.ReadFileFromMemory(bytes.data(), bytes.size(), kImportFlags,
                                       format_hint.c_str());
  });
}

}  // namespace tritrace
