// pbrt-v4's analytic shapes (sphere, disk, cylinder) as triangle meshes in object space, with the
// smooth normals and (u, v) parameterisation pbrt gives them, so that tritrace can render them as
// it renders every other surface.
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <vector>

namespace tritrace {

// An indexed mesh in object space: three indices per triangle, with per-vertex normals and texture
// coordinates (each empty or one per position).
struct PbrtMesh {
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> indices;
  std::vector<glm::vec3> normals;
  std::vector<glm::vec2> uvs;
};

// Segments around the full circle; partial shapes (phimax < 360) get their share, at least 3.
inline constexpr int kPbrtTessellationAround = 128;
// Segments from pole to pole of a sphere.
inline constexpr int kPbrtTessellationRings = 64;

// pbrt's sphere about the origin: radius, the z range [zmin, zmax] (clamped to the sphere) and
// the sweep phimax in degrees. Normals point outward; u = phi / phimax, v runs from zmin to zmax.
// Corners that coincide (at the poles) share one vertex, and the triangles that would have zero
// area there are left out.
PbrtMesh tessellate_sphere(double radius, double zmin, double zmax, double phimax_degrees);
// pbrt's disk: the annulus innerradius <= r <= radius in the plane z = height, normal +z.
PbrtMesh tessellate_disk(double height, double radius, double inner_radius, double phimax_degrees);
// pbrt's cylinder about the z axis from zmin to zmax, normals pointing away from the axis.
PbrtMesh tessellate_cylinder(double radius, double zmin, double zmax, double phimax_degrees);

// pbrt's "loopsubdiv": Loop subdivision (Loop 1987) `levels` times, with Warren's vertex weights
// beta = 3/16 for valence 3, else 3 / (8 n), boundary edges and vertices by the crease rules
// (1/2, 1/2 and 1/8, 3/4, 1/8), then every vertex moved to its limit position (interior:
// weight 1 / (n + 3 / (8 beta)) on each neighbour; boundary: 1/5, 3/5, 1/5), as pbrt does. The
// normals are the area-weighted means of the final faces' normals (pbrt takes the limit
// surface's tangents instead). Vertices on more than two boundary edges and edges of more than
// two faces keep the control positions and midpoints.
PbrtMesh loop_subdivide(const std::vector<glm::vec3>& positions,
                        const std::vector<uint32_t>& indices, int levels);

}  // namespace tritrace
