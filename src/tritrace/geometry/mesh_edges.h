// Whether a triangle mesh is closed: its edges counted with corners welded by exact position (a
// mesh file that repeats a vertex per triangle is still closed). The inside of a mesh, and so the
// sign of a signed distance, is well defined only when every edge joins exactly two triangles
// that run along it in opposite directions.
#pragma once

#include <cstddef>

#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace {

struct EdgeReport {
  size_t edges = 0;         // distinct edges between distinct positions
  size_t boundary = 0;      // edges of one triangle only: holes
  size_t non_manifold = 0;  // edges of three or more triangles
  size_t misoriented = 0;   // edges of two triangles that run along them the same way
  bool closed() const { return boundary == 0 && non_manifold == 0 && misoriented == 0; }
};

// The edges of triangles [first, first + count) of `mesh`. Zero-length edges (a triangle with a
// repeated corner) are left out.
[[nodiscard]] EdgeReport count_edges(const TriangleMesh& mesh, size_t first, size_t count);

}  // namespace tritrace
