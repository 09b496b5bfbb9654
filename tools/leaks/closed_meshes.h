// Closed, welded triangle meshes for the leak test: every edge is shared by exactly two triangles
// and every shared vertex is one float position, so a watertight kernel must let no ray through.
#pragma once

#include <array>
#include <cstdint>
#include <glm/vec3.hpp>
#include <string>
#include <vector>

namespace tritrace::leaks {

struct IndexedMesh {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<std::array<uint32_t, 3>> triangles;
};

// Latitude-longitude sphere: one vertex at each pole (triangle fans), `rings` latitude bands and
// `segments` longitudes, the seam welded (the last column reuses the first).
IndexedMesh make_uv_sphere(int rings, int segments, glm::vec3 centre, float radius);

// Icosahedron subdivided `levels` times (each triangle into four), vertices pushed to the sphere.
IndexedMesh make_icosphere(int levels, glm::vec3 centre, float radius);

// A cube of side 2 turned by `yaw` and `pitch` radians about y and x (so no edge is axis-aligned
// unless both are 0), two triangles per face.
IndexedMesh make_cube(glm::vec3 centre, double yaw, double pitch);

// The lab's Cornell box as three closed boxes, from the built-in scene's own float vertices: the
// room closed by a front wall (z = -1), and each block closed by its bottom face.
std::vector<IndexedMesh> make_lab_boxes();

// All of the above, the set docs/RELIABILITY.md reports.
std::vector<IndexedMesh> leak_test_meshes();

// Every undirected edge and how many triangles use it; a closed 2-manifold has 2 for each.
struct EdgeUse {
  uint32_t a, b;  // a < b
  int triangles;
};
std::vector<EdgeUse> edge_uses(const IndexedMesh& mesh);

}  // namespace tritrace::leaks
