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
  fit_extras();
}

namespace {
constexpr glm::vec4 kNoTangent{0.0f};
constexpr glm::vec4 kWhite{1.0f};
constexpr glm::vec2 kNoUv{0.0f};

template <typename T>
void fit(HugePageVector<T>& v, size_t n, const T& fill) {
  if (v.empty() || v.size() == n) return;
  const size_t held = v.size();
  v.resize(n);  // new elements uninitialised (huge_page_allocator.h)
  for (size_t k = held; k < n; ++k) v[k] = fill;
}

template <typename T>
T interpolate(const HugePageVector<T>& v, size_t tri, float u, float v_, const T& none) {
  if (v.empty()) return none;
  const T* c = &v[3 * tri];
  return (1.0f - u - v_) * c[0] + u * c[1] + v_ * c[2];
}
}  // namespace

void TriangleMesh::fit_extras() {
  fit(corner_tangents_, 3 * size(), kNoTangent);
  fit(corner_colours_, 3 * size(), kWhite);
  fit(corner_uvs1_, 3 * size(), kNoUv);
}

glm::vec4 TriangleMesh::tangent(size_t tri, float u, float v) const {
  if (corner_tangents_.empty()) return kNoTangent;
  glm::vec4 t = interpolate(corner_tangents_, tri, u, v, kNoTangent);
  t.w = corner_tangents_[3 * tri].w;
  return t;
}

glm::vec4 TriangleMesh::colour(size_t tri, float u, float v) const {
  return interpolate(corner_colours_, tri, u, v, kWhite);
}

glm::vec2 TriangleMesh::uv1(size_t tri, float u, float v) const {
  return interpolate(corner_uvs1_, tri, u, v, kNoUv);
}

void TriangleMesh::make_extras(bool tangents, bool colours, bool uvs1) {
  const size_t n = 3 * size();
  if (tangents && corner_tangents_.empty()) corner_tangents_.assign(n, kNoTangent);
  if (colours && corner_colours_.empty()) corner_colours_.assign(n, kWhite);
  if (uvs1 && corner_uvs1_.empty()) corner_uvs1_.assign(n, kNoUv);
}

void TriangleMesh::set_extras(size_t i, const glm::vec4* tangents, const glm::vec4* colours,
                              const glm::vec2* uvs1) {
  make_extras(tangents != nullptr, colours != nullptr, uvs1 != nullptr);
  for (size_t k = 0; k < 3; ++k) {
    if (tangents != nullptr) corner_tangents_[3 * i + k] = tangents[k];
    if (colours != nullptr) corner_colours_[3 * i + k] = colours[k];
    if (uvs1 != nullptr) corner_uvs1_[3 * i + k] = uvs1[k];
  }
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
  fit_extras();
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
  // The extras: `other`'s where it has them, defaults for the other side's triangles.
  const size_t my_corners = 3 * (size() - other.size());
  const auto join = [&](auto& dst, const auto& src, const auto& fill) {
    if (src.empty() && dst.empty()) return;
    if (dst.empty()) dst.assign(my_corners, fill);
    if (src.empty()) {
      dst.insert(dst.end(), 3 * other.size(), fill);
    } else {
      dst.insert(dst.end(), src.begin(), src.end());
    }
  };
  join(corner_tangents_, other.corner_tangents_, kNoTangent);
  join(corner_colours_, other.corner_colours_, kWhite);
  join(corner_uvs1_, other.corner_uvs1_, kNoUv);
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
