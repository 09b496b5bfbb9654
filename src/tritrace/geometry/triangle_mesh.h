// TriangleMesh: triangles stored as structure-of-arrays (v0, e1 = v1 - v0, e2 = v2 - v0, and the
// vertices v1, v2 themselves for the watertight kernel), the layouts the kernels read, plus the
// geometric normal and a material id per triangle.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

#include "tritrace/geometry/intersect.h"
#include "tritrace/math/bounds.h"

namespace tritrace {

class TriangleMesh {
 public:
  // The normal follows the lab's convention, normalize(cross(e2, e1)); a zero-area triangle gets a
  // zero normal (it can never be hit).
  void add(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, uint32_t material);
  // Appends `other`'s triangles exactly as stored, adding `material_offset` to their material ids.
  void append(const TriangleMesh& other, uint32_t material_offset);

  void reserve(size_t triangles);
  size_t size() const { return v0_.size(); }
  bool empty() const { return v0_.empty(); }

  const std::vector<glm::vec3>& v0() const { return v0_; }
  // The vertices exactly as given to add(): v0 + e1 rounds, and the watertight kernel needs
  // neighbouring triangles to see bit-identical shared vertices.
  const std::vector<glm::vec3>& v1() const { return v1_; }
  const std::vector<glm::vec3>& v2() const { return v2_; }
  const std::vector<glm::vec3>& e1() const { return e1_; }
  const std::vector<glm::vec3>& e2() const { return e2_; }
  const std::vector<glm::vec3>& normal() const { return normal_; }
  const std::vector<uint32_t>& material() const { return material_; }

  glm::vec3 vertex(size_t tri, int corner) const;  // corner 0, 1 or 2, exactly as added
  Bounds3 bounds() const;                          // of the whole mesh; all zero when empty
  Bounds3 triangle_bounds(size_t tri) const;
  TriangleArrays arrays() const {
    return {v0_.data(), v1_.data(), v2_.data(), e1_.data(), e2_.data()};
  }

 private:
  std::vector<glm::vec3> v0_, v1_, v2_, e1_, e2_, normal_;
  std::vector<uint32_t> material_;
};

}  // namespace tritrace
