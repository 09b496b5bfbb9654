// Tangents for normal maps where a glTF file has none (its TANGENT attribute absent), computed
// from the texture coordinates as the glTF specification asks: "MikkTSpace" (Mikkelsen,
// "Simulation of Wrinkled Surfaces Revisited", 2008), the convention Blender and the other
// exporters bake normal maps in.
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <span>
#include <vector>

namespace tritrace {

// Per-corner tangents of an indexed triangle mesh (three indices per triangle, counter-clockwise
// front faces) whose vertices have `positions`, `normals` (empty: each corner gets its face's
// normal) and texture coordinates `uvs` (v up, tritrace's and assimp's convention), in the corner
// order of `indices`. After Mikkelsen's thesis (section 4.2 and appendix): each triangle's tangent
// is dp/du of its linear texture map; its orientation is the sign of the signed area of its
// texture triangle (w = +1 where the texture is not mirrored, -1 where it is, so that
// w cross(n, t) points along dp/dv); at each vertex the triangle tangents projected onto the
// vertex normal's plane are normalised and summed, weighted by the triangle's angle at that
// vertex, separately for the two orientations (a mirrored seam keeps two tangents), then projected
// and normalised again. Unlike the reference implementation, vertices are those of the index
// buffer (glTF's), not welded by equal position, normal and coordinates. A corner whose triangle
// has no texture area takes its vertex's tangent of either orientation, else (0, 0, 0, 1).
std::vector<glm::vec4> mikktspace_tangents(std::span<const glm::vec3> positions,
                                           std::span<const glm::vec3> normals,
                                           std::span<const glm::vec2> uvs,
                                           std::span<const uint32_t> indices);

}  // namespace tritrace
