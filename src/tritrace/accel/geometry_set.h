// GeometrySet: several triangle meshes (geometries) in one BVH, for geometric queries on meshes a
// program hands over as arrays (the Python module's QueryScene): the first hit, every hit along a
// ray, closest points. Each triangle keeps the caller's index within its geometry, so every answer
// says which geometry and which of its triangles, whatever the BVH did with them.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <memory>
#include <span>
#include <vector>

#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace {

class GeometrySet {
 public:
  // Where a triangle of the concatenated mesh came from: the geometry (its id from add()) and its
  // index in that geometry's `triangles`.
  struct Location {
    uint32_t geometry = 0;
    uint32_t prim = 0;
  };

  GeometrySet();
  ~GeometrySet();
  GeometrySet(GeometrySet&&) noexcept;
  GeometrySet& operator=(GeometrySet&&) noexcept;
  GeometrySet(const GeometrySet&) = delete;
  GeometrySet& operator=(const GeometrySet&) = delete;

  // Appends a geometry: `triangles` index `vertices`. Returns its id, 0, 1, 2, ... in the order
  // added. Throws Error (subject "vertices" or "triangles") for a vertex that is not finite, an
  // index out of range, or more triangles in all than 32-bit ids hold; the set is then unchanged.
  // Zero-area triangles are kept (prim ids stay the caller's indices): rays never hit them
  // (degenerate()), closest-point queries see them. Adding after build() is allowed: it drops the
  // BVH, and build() must run again before accel() or tree() are read.
  uint32_t add(std::span<const glm::vec3> vertices, std::span<const glm::uvec3> triangles);

  // Builds the BVH (watertight kernel) over every triangle added so far; does nothing when it is
  // already built. An empty set builds an empty BVH, which every ray misses.
  void build();
  bool built() const { return accel_ != nullptr; }

  size_t geometry_count() const { return first_prim_.size(); }
  size_t triangle_count() const { return mesh_->size(); }
  // The concatenated index of geometry g's first triangle.
  uint32_t first_prim(uint32_t geometry) const { return first_prim_[geometry]; }

  // Every geometry's triangles one after another, vertices exactly as given; triangle i's material
  // id is its geometry's id. Stays valid (same address) while the set lives, across add().
  const TriangleMesh& mesh() const { return *mesh_; }
  // The accel and its tree; built() must be true. The tree's triangle blocks hold each zero-area
  // triangle with its three corners collapsed onto its first, so that no kernel ever reports a hit
  // on one; its box in the tree is the real triangle's. Read the real vertices from mesh(). (A
  // build without AVX2, which x86-64 builds always have, tests leaves against mesh() instead, so
  // there a ray may in rare cases hit a zero-area triangle opened by rounding; the all-hits
  // queries never do.)
  const BvhAccel& accel() const { return *accel_; }
  const bvh::WideBvh& tree() const { return accel_->tree(); }

  // Whether concatenated triangle `prim` has zero area: its edge vectors' cross product, in
  // double, is exactly zero (coincident or collinear corners).
  bool degenerate(uint32_t prim) const { return degenerate_[prim] != 0; }

  Location locate(uint32_t concatenated_prim) const {
    const uint32_t g = mesh_->material()[concatenated_prim];
    return {g, concatenated_prim - first_prim_[g]};
  }

 private:
  std::unique_ptr<TriangleMesh> mesh_;  // behind a pointer: the accel keeps its address
  std::vector<uint32_t> first_prim_;
  std::vector<uint8_t> degenerate_;
  std::unique_ptr<BvhAccel> accel_;
};

}  // namespace tritrace
