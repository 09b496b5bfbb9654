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

}  // namespace tritrace
