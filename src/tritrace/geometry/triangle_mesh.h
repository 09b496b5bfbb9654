// TriangleMesh: triangles stored as structure-of-arrays (the vertices v0, v1, v2 exactly as given,
// which the watertight kernel reads; the edges e1 = v1 - v0, e2 = v2 - v0 the other kernels read
// are computed from them when read, the same bits for every reader), plus the geometric normal
// and a material id per triangle, and optionally per-corner shading normals and texture
// coordinates.
// The arrays live on huge pages (huge_page_allocator.h): a 10-million-triangle mesh is 485 MiB.
#pragma once

#include <array>
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <vector>

#include "tritrace/geometry/intersect.h"
#include "tritrace/huge_page_allocator.h"
#include "tritrace/math/bounds.h"

namespace tritrace {

class TriangleMesh {
 public:
  // The normal follows the lab's convention, normalize(cross(e2, e1)); a zero-area triangle gets a
  // zero normal (it can never be hit).
  void add(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, uint32_t material);
  // The same with a unit shading normal per corner (a file's vertex normals, for smooth shading).
  // The first such triangle gives every earlier triangle its geometric normal at each corner, so
  // that meshes without vertex normals store none (and pay nothing for them).
  void add(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, uint32_t material,
           const std::array<glm::vec3, 3>& normals);
  // The same with optional normals and texture coordinates per corner (null: none). Texture
  // coordinates work as normals do: the first triangle that has them gives every earlier one (0, 0)
  // at each corner, and so does every later triangle without them.
  void add(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, uint32_t material,
           const std::array<glm::vec3, 3>* normals, const std::array<glm::vec2, 3>* uvs);
  // Appends `other`'s triangles exactly as stored, adding `material_offset` to their material ids.
  void append(const TriangleMesh& other, uint32_t material_offset);

  void reserve(size_t triangles);
  // Room for `more` triangles after those held, each then filled by set(): how a loader adds many
  // triangles in parallel instead of add(). Corner normals (texture coordinates) are kept where
  // the mesh has them and made where `corner_normals` (`corner_uvs`) asks, the held triangles then
  // getting their geometric normal ((0, 0)) at each corner, as add() gives them.
  void grow(size_t more, bool corner_normals, bool corner_uvs);
  // Stores triangle i exactly as add() with the same arguments would have (normals and uvs may be
  // given only when resize() made room for them).
  void set(size_t i, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, uint32_t material,
           const std::array<glm::vec3, 3>* normals, const std::array<glm::vec2, 3>* uvs);
  size_t size() const { return v0_.size(); }
  bool empty() const { return v0_.empty(); }

  const HugePageVector<glm::vec3>& v0() const { return v0_; }
  // The vertices exactly as given to add(): v0 + e1 rounds, and the watertight kernel needs
  // neighbouring triangles to see bit-identical shared vertices.
  const HugePageVector<glm::vec3>& v1() const { return v1_; }
  const HugePageVector<glm::vec3>& v2() const { return v2_; }
  // The edges v1 - v0 and v2 - v0 of triangle `tri`, computed on each call; the BVH's SIMD blocks
  // make them with the same subtraction, so every reader gets the same bits.
  glm::vec3 e1(size_t tri) const { return v1_[tri] - v0_[tri]; }
  glm::vec3 e2(size_t tri) const { return v2_[tri] - v0_[tri]; }
  const HugePageVector<glm::vec3>& normal() const { return normal_; }
  const HugePageVector<uint32_t>& material() const { return material_; }
  // Three per triangle (corners in the order given to add()), or empty when no triangle has any.
  const HugePageVector<glm::vec3>& corner_normals() const { return corner_normals_; }
  bool has_shading_normals() const { return !corner_normals_.empty(); }
  // The corner normals interpolated at barycentrics (u, v) (weights 1 - u - v, u, v for corners
  // 0, 1, 2, as in v0 + u e1 + v e2) and normalised; the geometric normal when the mesh has no
  // shading normals or the interpolation vanishes. Not yet turned to any side.
  glm::vec3 shading_normal(size_t tri, float u, float v) const;
  // Three per triangle, or empty when no triangle has any.
  const HugePageVector<glm::vec2>& corner_uvs() const { return corner_uvs_; }
  bool has_uvs() const { return !corner_uvs_.empty(); }
  // The corner texture coordinates interpolated at barycentrics (u, v); (0, 0) without any.
  glm::vec2 uv(size_t tri, float u, float v) const;

  // glTF's further corner attributes, each three per triangle or empty when no triangle has any;
  // triangles added without them get the defaults: tangent (0, 0, 0, 0) (none: shading computes
  // one), colour (1, 1, 1, 1), second texture coordinates (0, 0).
  // Tangents: xyz the direction of increasing u, w = +1 or -1 the sign that makes the bitangent
  // w cross(normal, tangent) point along increasing v (glTF's TANGENT).
  const HugePageVector<glm::vec4>& corner_tangents() const { return corner_tangents_; }
  const HugePageVector<glm::vec4>& corner_colours() const { return corner_colours_; }
  const HugePageVector<glm::vec2>& corner_uvs1() const { return corner_uvs1_; }
  bool has_tangents() const { return !corner_tangents_.empty(); }
  bool has_colours() const { return !corner_colours_.empty(); }
  // Interpolated at barycentrics (u, v), the defaults without any. The tangent's xyz is not
  // normalised; its w is corner 0's.
  glm::vec4 tangent(size_t tri, float u, float v) const;
  glm::vec4 colour(size_t tri, float u, float v) const;
  glm::vec2 uv1(size_t tri, float u, float v) const;
  // Makes room for the attributes asked for (defaults for every triangle held), so that set_extras
  // may then be called from several threads.
  void make_extras(bool tangents, bool colours, bool uvs1);
  // Stores triangle i's attributes (each null: keep what it has), making an array on first use.
  void set_extras(size_t i, const glm::vec4* tangents, const glm::vec4* colours,
                  const glm::vec2* uvs1);

  // Corner 0, 1 or 2, exactly as added (inline: the BVH builds read every vertex through it).
  glm::vec3 vertex(size_t tri, int corner) const {
    return corner == 1 ? v1_[tri] : corner == 2 ? v2_[tri] : v0_[tri];
  }
  Bounds3 bounds() const;  // of the whole mesh; all zero when empty
  Bounds3 triangle_bounds(size_t tri) const {
    Bounds3 b = Bounds3::empty();
    for (int c = 0; c < 3; ++c) b.extend(vertex(tri, c));
    return b;
  }
  TriangleArrays arrays() const { return {v0_.data(), v1_.data(), v2_.data()}; }

 private:
  HugePageVector<glm::vec3> v0_, v1_, v2_, normal_;
  HugePageVector<uint32_t> material_;
  HugePageVector<glm::vec3> corner_normals_;
  HugePageVector<glm::vec2> corner_uvs_;
  HugePageVector<glm::vec4> corner_tangents_;
  HugePageVector<glm::vec4> corner_colours_;
  HugePageVector<glm::vec2> corner_uvs1_;
  // Every extra attribute array at the length the triangles held need, new entries defaulted.
  void fit_extras();
};

}  // namespace tritrace
