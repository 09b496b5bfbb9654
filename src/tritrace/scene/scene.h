// Scene: everything a render reads, built once and then read-only: triangles, materials, point
// lights, the constant indirect (ambient) term and the camera, plus instanced meshes.
#pragma once

#include <cstdint>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <vector>

#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/scene/camera.h"

namespace tritrace {

// A two-sided Lambertian (diffuse) surface that may also emit light.
struct Material {
  glm::vec3 albedo{0.75f};  // diffuse reflectance rho, linear RGB
  // Emitted radiance Le (linear RGB, W/(m^2 sr) per channel), from the triangle's front (the side
  // its lab normal, normalize(cross(e2, e1)), points to), or from both sides when two_sided.
  glm::vec3 emission{0.0f};
  bool two_sided = false;

  bool emits() const { return emission.x > 0.0f || emission.y > 0.0f || emission.z > 0.0f; }
};

// Radiates intensity power / (4 pi) in every direction (the lab's light).
struct PointLight {
  glm::vec3 position{0.0f};
  glm::vec3 power{0.0f};  // P, radiant power per channel
};

// p -> linear * p + translation. Points and directions are moved with the same operations
// everywhere (flattening, shading, rays into object space), so that they round alike.
struct Affine {
  glm::mat3 linear{1.0f};  // columns, as glm stores them
  glm::vec3 translation{0.0f};

  glm::vec3 apply_vector(glm::vec3 v) const {
    const glm::mat3& m = linear;
    return {m[0][0] * v.x + m[1][0] * v.y + m[2][0] * v.z,
            m[0][1] * v.x + m[1][1] * v.y + m[2][1] * v.z,
            m[0][2] * v.x + m[1][2] * v.y + m[2][2] * v.z};
  }
  glm::vec3 apply(glm::vec3 p) const { return apply_vector(p) + translation; }
};

// The inverse transform (linear part inverted in double precision, then rounded). `a` must be
// invertible with a finite inverse.
Affine inverse(const Affine& a);

// One placement of a prototype mesh: drawn as if its vertices were to_world.apply(v). Rays are
// moved into object space with to_object (the direction is not renormalised, so a hit's t is the
// same in both spaces).
struct Instance {
  uint32_t prototype = 0;  // into Scene::prototypes
  Affine to_world;
  Affine to_object;  // inverse(to_world)
  // The instance's triangle k is the scene's triangle first_prim + k (Scene::triangle).
  uint32_t first_prim = 0;
};

// A triangle as drawn, in world space: what shading needs from a hit. For a triangle of
// Scene::mesh the stored values; for an instanced one they are computed as TriangleMesh::add
// would from its world vertices, so an instance shades bit for bit like its flattened copy. The
// normal normalize(cross(e2, e1)) of the world edges equals det(L) L^-T n for the object normal n
// and linear part L (cross(La, Lb) = det(L) L^-T (a x b)): the inverse transpose, flipped by a
// mirroring transform, so the "front" stays the side the vertex order makes front.
struct SurfaceTriangle {
  glm::vec3 v0, e1, e2, normal;
  uint32_t material = 0;
};

// Triangle `prim` of `mesh`, as stored.
inline SurfaceTriangle stored_triangle(const TriangleMesh& mesh, uint32_t prim) {
  return {mesh.v0()[prim], mesh.e1()[prim], mesh.e2()[prim], mesh.normal()[prim],
          mesh.material()[prim]};
}

// The most triangles a scene may draw (instances counted once per placement): a hit names its
// triangle with 32 bits, and kNoHit is taken.
inline constexpr uint64_t kMaxDrawnTriangles = 0xFFFFFFFEull;

struct Scene {
  // The triangles placed once, in world space. The scene's triangle numbering (Hit::prim) starts
  // with these, then each instance's triangles in instance order: the order of the flattened
  // scene (flattened() below).
  TriangleMesh mesh;
  // Meshes placed by instances only; their material ids index `materials`.
  std::vector<TriangleMesh> prototypes;
  std::vector<Instance> instances;
  std::vector<Material> materials;
  std::vector<PointLight> lights;
  glm::vec3 ambient{0.0f};  // the lab's constant indirect light N
  Camera camera;

  bool has_instances() const { return !instances.empty(); }
  // Triangles drawn: the mesh's plus each instance's prototype's.
  uint64_t drawn_triangles() const;
  // Triangles stored: the mesh's plus each prototype's once.
  uint64_t stored_triangles() const;
  // Which instance draws triangle `prim` (prim >= mesh.size()).
  const Instance& instance_of(uint32_t prim) const;
  // Triangle `prim` of the scene's numbering, in world space.
  SurfaceTriangle triangle(uint32_t prim) const {
    if (prim < mesh.size()) return stored_triangle(mesh, prim);
    return instanced_triangle(prim);
  }
  uint32_t material_of(uint32_t prim) const {
    return prim < mesh.size() ? mesh.material()[prim] : instanced_triangle(prim).material;
  }

 private:
  SurfaceTriangle instanced_triangle(uint32_t prim) const;
};

// Appends an instance of prototype `prototype` placed by `to_world`, numbering its triangles after
// the ones before it. Throws Error("instances", ...) when the scene would draw more than
// kMaxDrawnTriangles or `to_world` is not invertible.
void add_instance(Scene& scene, uint32_t prototype, const Affine& to_world);

// The world box of an instance: its prototype's box (`prototype_bounds`, computed once per
// prototype by the caller: a box costs a pass over the mesh) with the eight corners moved to
// world space.
Bounds3 instance_bounds(const Bounds3& prototype_bounds, const Instance& instance);
// The box of everything the scene draws.
Bounds3 scene_bounds(const Scene& scene);

// The same scene with every instance copied into `mesh` (in the scene's triangle numbering), its
// vertices moved by to_world.apply: the oracle that instanced rendering is tested against.
Scene flattened(const Scene& scene);

}  // namespace tritrace
