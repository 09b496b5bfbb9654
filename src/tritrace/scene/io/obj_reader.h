// A native reader for Wavefront OBJ (+ MTL) through Debian's tinyobjloader: the fast path for big
// OBJ meshes, straight from the file's bytes into an ImportedMesh (its indexed form) with the
// triangles, order, normals, texture coordinates and materials that the assimp path gives. It takes
// only what it can reproduce exactly (triangles and quads, one name per object and group, plain MTL
// keys), reading pieces of the file in parallel; every other file, well-formed or not, is left to
// assimp, whose results and errors it then gives.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>

#include "tritrace/scene/io/mesh_import.h"

namespace tritrace {

// Whether this build has the native reader (tinyobjloader was found at configure time); without
// it read_obj_triangles always leaves the file to assimp.
bool native_obj_reader_built();

// The triangles of an OBJ file's bytes as assimp gives them, or nullopt where the file uses
// something this reader does not reproduce (or is malformed), for assimp to read or reject.
// `directory` is the OBJ's folder, where `mtllib` files and textures are found; it is empty for
// bytes from memory, which then may not name a material library. Throws Error(subject, ...) for
// more than kMaxSceneTriangles triangles and for unreadable textures, as the assimp path does.
// tinyobjloader reads pieces of about `piece_bytes` (ending at line ends) in parallel; the result
// does not depend on their size, which tests set small to cut small files.
inline constexpr size_t kObjPieceBytes = size_t{8} << 20;
std::optional<ImportedMesh> read_obj_triangles(std::span<const char> bytes,
                                               const std::string& subject,
                                               const std::string& directory,
                                               size_t piece_bytes = kObjPieceBytes);

}  // namespace tritrace
