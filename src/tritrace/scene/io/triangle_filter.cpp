// Triangle validity in the same float arithmetic TriangleMesh::add uses, so an accepted triangle
// has finite edges and a finite, non-zero normal.
#include "tritrace/scene/io/triangle_filter.h"

#include <cmath>
#include <glm/geometric.hpp>

namespace tritrace {
namespace {

bool finite(glm::vec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

}  // namespace

TriangleCheck check_triangle(glm::vec3 a, glm::vec3 b, glm::vec3 c) {
  if (!finite(a) || !finite(b) || !finite(c)) return TriangleCheck::kNonFinite;
  const glm::vec3 e1 = b - a;
  const glm::vec3 e2 = c - a;
  if (!finite(e1) || !finite(e2)) return TriangleCheck::kNonFinite;
  const glm::vec3 n = glm::cross(e2, e1);
  const float len = glm::length(n);
  if (!std::isfinite(len)) return TriangleCheck::kNonFinite;
  return len > 0.0f ? TriangleCheck::kOk : TriangleCheck::kDegenerate;
}

bool add_checked(TriangleMesh& mesh, glm::vec3 a, glm::vec3 b, glm::vec3 c, uint32_t material,
                 LoadStats& stats) {
  return add_checked(mesh, a, b, c, material, nullptr, nullptr, stats);
}

bool add_checked(TriangleMesh& mesh, glm::vec3 a, glm::vec3 b, glm::vec3 c, uint32_t material,
                 const glm::vec3* normals, const glm::vec2* uvs, LoadStats& stats) {
  switch (check_triangle(a, b, c)) {
    case TriangleCheck::kOk:
      break;
    case TriangleCheck::kDegenerate:
      ++stats.dropped_degenerate;
      return false;
    case TriangleCheck::kNonFinite:
      ++stats.dropped_non_finite;
      return false;
  }
  if (normals == nullptr && uvs == nullptr) {
    mesh.add(a, b, c, material);
    return true;
  }
  std::array<glm::vec3, 3> unit;
  if (normals != nullptr) {
    const glm::vec3 geometric = glm::normalize(glm::cross(c - a, b - a));
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 n = normals[k];
      const float len = glm::length(n);
      unit[k] = finite(n) && std::isfinite(len) && len > 0.0f ? n / len : geometric;
    }
  }
  std::array<glm::vec2, 3> t;
  if (uvs != nullptr) {
    for (int k = 0; k < 3; ++k) {
      t[k] = std::isfinite(uvs[k].x) && std::isfinite(uvs[k].y) ? uvs[k] : glm::vec2(0.0f);
    }
  }
  mesh.add(a, b, c, material, normals != nullptr ? &unit : nullptr, uvs != nullptr ? &t : nullptr);
  return true;
}

}  // namespace tritrace
