// A native reader for triangle meshes in PLY (ASCII, binary little- and big-endian): the fast
// path for the big scanned and generated meshes that PLY usually carries, straight from the file's
// bytes into an ImportedMesh (its indexed form: the file's vertices and three indices per
// triangle), in parallel over vertices and faces. It takes only what it can read
// exactly as the assimp path does (a vertex element with scalar x, y, z among any other scalar
// properties, then a face element holding nothing but one index list of three per face); every
// other file, well-formed or not, is left to assimp, whose results and errors it then gives.
#pragma once

#include <optional>
#include <span>
#include <string>

#include "tritrace/scene/io/mesh_import.h"

namespace tritrace {

// The triangles of a PLY file's bytes in the order and with the material assimp gives them, or
// nullopt where the file is not a plain triangle mesh this reader takes (or is malformed), for
// assimp to read or reject. Throws Error(subject, ...) only for more than kMaxSceneTriangles
// triangles, as the assimp path does.
std::optional<ImportedMesh> read_ply_triangles(std::span<const char> bytes,
                                               const std::string& subject);

}  // namespace tritrace
