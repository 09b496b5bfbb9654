// Mesh import through assimp: any format it reads (OBJ, PLY, STL, glTF 2, FBX, Collada, 3DS ...)
// becomes a flat triangle list in world space (faces triangulated, node transforms applied) with
// the file's vertex normals, texture coordinates, textures (decoded in the importer's process) and
// materials: glTF's metallic-roughness and OBJ/MTL's parameters mapped to tritrace's material types
// (docs/SCENE_FORMAT.md has the table), or a neutral grey where the file has none.
#pragma once

#include <cstddef>
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <span>
#include <string>
#include <vector>

#include "tritrace/huge_page_allocator.h"
#include "tritrace/scene/io/triangle_filter.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

inline constexpr glm::vec3 kNeutralGrey{0.6f, 0.6f, 0.6f};

// The per-triangle arrays live on huge pages, as the mesh they are added to: for a big mesh they
// are hundreds of MiB written once, and in 4 KiB pages their first touch (zeroing and a fault per
// page) costs more than reading the file (docs/PERFORMANCE.md, "Loading straight from a mapped
// file"). Their resize() leaves new elements uninitialised (huge_page_allocator.h): give a value
// or write them all.
struct ImportedMesh {
  // The corners, node transforms applied, in one of two forms: three per triangle in `corners`, or
  // (the native PLY and OBJ readers', `corners` empty) three indices per triangle into the file's
  // vertices `positions`, which spares a copy of every corner: 12 instead of 36 bytes per triangle.
  HugePageVector<glm::vec3> corners;
  HugePageVector<glm::vec3> positions;
  HugePageVector<uint32_t> indices;
  // The file's vertex normals at those corners (node transforms applied), or empty when no mesh of
  // the file has normals; a mesh without them among others that have them gets zero vectors, which
  // add_checked replaces by the geometric normal.
  HugePageVector<glm::vec3> normals;
  // Texture coordinates (u, v) of the first set at the corners, or empty when no mesh has any.
  HugePageVector<glm::vec2> uvs;
  // glTF's further corner attributes, each three per triangle or empty when no mesh has any
  // (TriangleMesh::set_extras has the defaults a mesh without them gets): tangents of
  // normal-mapped materials' primitives (TANGENT with node transforms applied, else computed:
  // tangents.h), vertex colours (COLOR_0, RGBA) and the second texture coordinates (TEXCOORD_1).
  // Read from glTF files only.
  HugePageVector<glm::vec4> tangents;
  HugePageVector<glm::vec4> colours;
  HugePageVector<glm::vec2> uvs1;
  // The textures the materials refer to (TextureRef::index into this list), each file or embedded
  // image once however many materials use it.
  std::vector<TextureImage> textures;
  HugePageVector<uint32_t> material;  // one per triangle, an index into `materials`
  std::vector<Material> materials;    // the file's, in its order
  std::vector<std::string> material_names;
  size_t meshes = 0;  // mesh instances (a mesh used by two nodes counts twice)

  size_t triangles() const { return material.size(); }
  bool indexed() const { return !indices.empty(); }
  glm::vec3 corner(size_t k) const { return corner_view()[k]; }
  CornerView corner_view() const {
    return indexed() ? CornerView(positions, indices) : CornerView(corners);
  }
  // Turns the indexed form into the corner form (the one put into the importer's hand-over).
  void expand_corners();
};

// Reads a mesh file: PLY triangle meshes through a native reader (ply_reader.h), everything else
// through assimp. Throws Error(path, reason) when the file is missing, unreadable or empty,
// when assimp rejects it, or when it holds no triangles. Triangles are not yet checked for
// degeneracy: add_checked does that when they join a scene.
ImportedMesh import_mesh_file(const std::string& path);

// import_mesh_file through assimp alone, without the native PLY reader: the reference the tests
// compare that reader with.
ImportedMesh import_mesh_file_with_assimp(const std::string& path);

// The same from bytes in memory; `format_hint` is a file extension without the dot ("obj") and
// `subject` names the data in error messages.
ImportedMesh import_mesh_memory(std::span<const uint8_t> bytes, const std::string& format_hint,
                                const std::string& subject);

// Both functions above run assimp in a child process (isolated_call.h): assimp has crashed on
// malformed files, and a crash there becomes an Error here. The fuzzer needs assimp in its own
// process, where coverage is counted, so it calls this variant; nothing else should.
ImportedMesh import_mesh_memory_in_process(std::span<const uint8_t> bytes,
                                           const std::string& format_hint,
                                           const std::string& subject);

}  // namespace tritrace
