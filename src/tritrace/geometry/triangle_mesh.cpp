// TriangleMesh construction and queries.
#include "tritrace/geometry/triangle_mesh.h"

#include <glm/glm.hpp>

namespace tritrace {

void TriangleMesh::add(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                       uint32_t material) {
  const glm::vec3 e1 = b - a;
  const glm::vec3 e2 = c - a;
  const glm::vec3 n = glm::cross(e2, e1);
  const float len = glm::length(n);
  v0_.push_back(a);
  v1_.push_back(b);
  v2_.push_back(c);
  e1_.push_back(e1);
  e2_.push_back(e2);
  normal_.push_back(len > 0.0f ? n / len : glm::vec3(0.0f));
  material_.push_back(material);
}

void TriangleMesh::reserve(size_t triangles) {
  for (auto* v : {&v0_, &v1_, &v2_, &e1_, &e2_, &normal_}) v->reserve(triangles);
  material_.reserve(triangles);
}

void TriangleMesh::append(const TriangleMesh& other, uint32_t material_offset) {
  v0_.insert(v0_.end(), other.v0_.begin(), other.v0_.end());
  v1_.insert(v1_.end(), other.v1_.begin(), other.v1_.end());
  v2_.insert(v2_.end(), other.v2_.begin(), other.v2_.end());
  e1_.insert(e1_.end(), other.e1_.begin(), other.e1_.end());
  e2_.insert(e2_.end(), other.e2_.begin(), other.e2_.end());
  normal_.insert(normal_.end(), other.normal_.begin(), other.normal_.end());
  for (uint32_t m : other.material_) material_.push_back(m + material_offset);
}

glm::vec3 TriangleMesh::vertex(size_t tri, int corner) const {
  if (corner == 1) return v1_[tri];
  if (corner == 2) return v2_[tri];
  return v0_[tri];
}

Bounds3 TriangleMesh::triangle_bounds(size_t tri) const {
  Bounds3 b = Bounds3::empty();
  for (int c = 0; c < 3; ++c) b.extend(vertex(tri, c));
  return b;
}

Bounds3 TriangleMesh::bounds() const {
  if (empty()) return {};
  Bounds3 b = Bounds3::empty();
  for (size_t i = 0; i < size(); ++i) b.extend(triangle_bounds(i));
  return b;
}

}  // namespace tritrace
