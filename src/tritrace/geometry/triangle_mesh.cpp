// TriangleMesh construction and queries.
#include "tritrace/geometry/triangle_mesh.h"

#include <cassert>
#include <cmath>
#include <glm/glm.hpp>

namespace tritrace {

namespace {

// The unit normal add() and set() store: the lab's cross(e2, e1), or zero for no area.
glm::vec3 face_normal(const glm::vec3& e1, const glm::vec3& e2) {
  const glm::vec3 n = glm::cross(e2, e1);
  const float len = glm::length(n);
  return len > 0.0f ? n / len : glm::vec3(0.0f);
}

}  // namespace

void TriangleMesh::add(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                       uint32_t material) {
  const glm::vec3 e1 = b - a;
  const glm::vec3 e2 = c - a;
  v0_.push_back(a);
  v1_.push_back(b);
  v2_.push_back(c);
  normal_.push_back(face_normal(e1, e2));
  material_.push_back(material);
  if (!corner_normals_.empty()) corner_normals_.insert(corner_normals_.end(), 3, normal_.back());
  if (!corner_uvs_.empty()) corner_uvs_.insert(corner_uvs_.end(), 3, glm::vec2(0.0f));
}

void TriangleMesh::add(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                       uint32_t material, const std::array<glm::vec3, 3>* normals,
                       const std::array<glm::vec2, 3>* uvs) {
  if (uvs != nullptr && corner_uvs_.empty()) corner_uvs_.assign(3 * size(), glm::vec2(0.0f));
  const size_t before = corner_uvs_.size();
  if (normals != nullptr) {
    add(a, b, c, material, *normals);
  } else {
    add(a, b, c, material);
  }
  if (uvs != nullptr) {
    corner_uvs_.resize(before);
    corner_uvs_.insert(corner_uvs_.end(), uvs->begin(), uvs->end());
  }
}

glm::vec2 TriangleMesh::uv(size_t tri, float u, float v) const {
  if (corner_uvs_.empty()) return glm::vec2(0.0f);
  const glm::vec2* t = &corner_uvs_[3 * tri];
  return (1.0f - u - v) * t[0] + u * t[1] + v * t[2];
}

void TriangleMesh::add(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                       uint32_t material, const std::array<glm::vec3, 3>& normals) {
  if (corner_normals_.empty()) {
    corner_normals_.reserve(3 * normal_.capacity());
    for (const glm::vec3& n : normal_) corner_normals_.insert(corner_normals_.end(), 3, n);
  }
  const size_t before = corner_normals_.size();
  add(a, b, c, material);
  corner_normals_.resize(before);
  corner_normals_.insert(corner_normals_.end(), normals.begin(), normals.end());
}

glm::vec3 TriangleMesh::shading_normal(size_t tri, float u, float v) const {
  if (corner_normals_.empty()) return normal_[tri];
  const glm::vec3* n = &corner_normals_[3 * tri];
  const glm::vec3 s = (1.0f - u - v) * n[0] + u * n[1] + v * n[2];
  const float len2 = glm::dot(s, s);
  return len2 > 0.0f && std::isfinite(len2) ? s * (1.0f / std::sqrt(len2)) : normal_[tri];
}

void TriangleMesh::reserve(size_t triangles) {
  for (auto* v : {&v0_, &v1_, &v2_, &normal_}) v->reserve(triangles);
  material_.reserve(triangles);
  if (!corner_normals_.empty()) corner_normals_.reserve(3 * triangles);
  if (!corner_uvs_.empty()) corner_uvs_.reserve(3 * triangles);
}

void TriangleMesh::grow(size_t more, bool corner_normals, bool corner_uvs) {
  const size_t held = size();
  const bool normals = corner_normals || has_shading_normals();
  const bool uvs = corner_uvs || has_uvs();
  if (corner_normals && corner_normals_.empty()) {
    corner_normals_.reserve(3 * (held + more));
    for (const glm::vec3& n : normal_) corner_normals_.insert(corner_normals_.end(), 3, n);
  }
  if (corner_uvs && corner_uvs_.empty()) corner_uvs_.assign(3 * held, glm::vec2(0.0f));
  for (auto* v : {&v0_, &v1_, &v2_, &normal_}) v->resize(held + more);
  material_.resize(held + more);
  if (normals) corner_normals_.resize(3 * (held + more));
  if (uvs) corner_uvs_.resize(3 * (held + more));
}

void TriangleMesh::set(size_t i, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                       uint32_t material, const std::array<glm::vec3, 3>* normals,
                       const std::array<glm::vec2, 3>* uvs) {
  assert(i < size() && (normals == nullptr || has_shading_normals()) &&
         (uvs == nullptr || has_uvs()));
  const glm::vec3 e1 = b - a;
  const glm::vec3 e2 = c - a;
  v0_[i] = a;
  v1_[i] = b;
  v2_[i] = c;
  normal_[i] = face_normal(e1, e2);
  material_[i] = material;
  if (has_shading_normals()) {
    for (size_t k = 0; k < 3; ++k)
      corner_normals_[3 * i + k] = normals ? (*normals)[k] : normal_[i];
  }
  if (has_uvs()) {
    for (size_t k = 0; k < 3; ++k) corner_uvs_[3 * i + k] = uvs ? (*uvs)[k] : glm::vec2(0.0f);
  }
}

void TriangleMesh::append(const TriangleMesh& other, uint32_t material_offset) {
  v0_.insert(v0_.end(), other.v0_.begin(), other.v0_.end());
  v1_.insert(v1_.end(), other.v1_.begin(), other.v1_.end());
  v2_.insert(v2_.end(), other.v2_.begin(), other.v2_.end());
  normal_.insert(normal_.end(), other.normal_.begin(), other.normal_.end());
  for (uint32_t m : other.material_) material_.push_back(m + material_offset);
  if (!other.corner_uvs_.empty() || !corner_uvs_.empty()) {
    corner_uvs_.resize(3 * (size() - other.size()), glm::vec2(0.0f));
    if (other.corner_uvs_.empty()) {
      corner_uvs_.resize(3 * size(), glm::vec2(0.0f));
    } else {
      corner_uvs_.insert(corner_uvs_.end(), other.corner_uvs_.begin(), other.corner_uvs_.end());
    }
  }
  if (other.corner_normals_.empty() && corner_normals_.empty()) return;
  // One of the two has shading normals: the other's triangles get their geometric normals.
  const size_t mine = normal_.size() - other.normal_.size();
  if (corner_normals_.empty()) {
    for (size_t i = 0; i < mine; ++i) corner_normals_.insert(corner_normals_.end(), 3, normal_[i]);
  }
  if (other.corner_normals_.empty()) {
    for (const glm::vec3& n : other.normal_) corner_normals_.insert(corner_normals_.end(), 3, n);
  } else {
    corner_normals_.insert(corner_normals_.end(), other.corner_normals_.begin(),
                           other.corner_normals_.end());
  }
}

Bounds3 TriangleMesh::bounds() const {
  if (empty()) return {};
  Bounds3 b = Bounds3::empty();
  for (size_t i = 0; i < size(); ++i) b.extend(triangle_bounds(i));
  return b;
}

}  // namespace tritrace
