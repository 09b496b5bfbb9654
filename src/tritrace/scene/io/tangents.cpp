// MikkTSpace-style per-corner tangents (tangents.h).
#include "tritrace/scene/io/tangents.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

namespace tritrace {
namespace {

// v minus its part along unit n, normalised; zero when nothing is left.
glm::vec3 perpendicular_unit(glm::vec3 v, glm::vec3 n) {
  const glm::vec3 p = v - glm::dot(v, n) * n;
  const float len = glm::length(p);
  return len > 0.0f && std::isfinite(len) ? p / len : glm::vec3(0.0f);
}

glm::vec3 unit_or_zero(glm::vec3 v) {
  const float len = glm::length(v);
  return len > 0.0f && std::isfinite(len) ? v / len : glm::vec3(0.0f);
}

// The angle between the edges from p towards a and towards b.
float corner_angle(glm::vec3 p, glm::vec3 a, glm::vec3 b) {
  const glm::vec3 x = unit_or_zero(a - p), y = unit_or_zero(b - p);
  return std::acos(std::clamp(glm::dot(x, y), -1.0f, 1.0f));
}

}  // namespace

std::vector<glm::vec4> mikktspace_tangents(std::span<const glm::vec3> positions,
                                           std::span<const glm::vec3> normals,
                                           std::span<const glm::vec2> uvs,
                                           std::span<const uint32_t> indices) {
  const size_t faces = indices.size() / 3;
  const size_t vertices = positions.size();
  std::vector<glm::vec4> out(indices.size(), glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
  // Per face: dp/du and its orientation (+1, -1; 0 for no texture area). Per vertex and
  // orientation: the weighted sum of unit projected tangents.
  std::vector<glm::vec3> face_tangent(faces, glm::vec3(0.0f));
  std::vector<float> face_sign(faces, 0.0f);
  std::vector<glm::vec3> sum(2 * vertices, glm::vec3(0.0f));
  const auto valid = [&](size_t f) {
    return indices[3 * f] < vertices && indices[3 * f + 1] < vertices &&
           indices[3 * f + 2] < vertices && indices[3 * f] < uvs.size() &&
           indices[3 * f + 1] < uvs.size() && indices[3 * f + 2] < uvs.size();
  };
  const auto normal_at = [&](size_t f, int k) {
    const uint32_t i = indices[3 * f + static_cast<size_t>(k)];
    if (i < normals.size()) {
      const glm::vec3 n = unit_or_zero(normals[i]);
      if (n != glm::vec3(0.0f)) return n;
    }
    const glm::vec3 p0 = positions[indices[3 * f]], p1 = positions[indices[3 * f + 1]],
                    p2 = positions[indices[3 * f + 2]];
    return unit_or_zero(glm::cross(p1 - p0, p2 - p0));
  };
  for (size_t f = 0; f < faces; ++f) {
    if (!valid(f)) continue;
    const uint32_t i0 = indices[3 * f], i1 = indices[3 * f + 1], i2 = indices[3 * f + 2];
    const glm::vec3 e1 = positions[i1] - positions[i0], e2 = positions[i2] - positions[i0];
    const glm::vec2 d1 = uvs[i1] - uvs[i0], d2 = uvs[i2] - uvs[i0];
    const float r = d1.x * d2.y - d2.x * d1.y;  // twice the signed texture area
    if (!(std::abs(r) > 0.0f) || !std::isfinite(r)) continue;
    const glm::vec3 t = (e1 * d2.y - e2 * d1.y) / r;
    if (!std::isfinite(t.x + t.y + t.z)) continue;
    face_tangent[f] = t;
    face_sign[f] = r > 0.0f ? 1.0f : -1.0f;
    const size_t side = r > 0.0f ? 0 : 1;
    const uint32_t corner[3] = {i0, i1, i2};
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 p = positions[corner[k]];
      const float angle =
          corner_angle(p, positions[corner[(k + 1) % 3]], positions[corner[(k + 2) % 3]]);
      sum[2 * corner[k] + side] += angle * perpendicular_unit(t, normal_at(f, k));
    }
  }
  for (size_t f = 0; f < faces; ++f) {
    if (!valid(f)) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = indices[3 * f + static_cast<size_t>(k)];
      const glm::vec3 n = normal_at(f, k);
      glm::vec4& t = out[3 * f + static_cast<size_t>(k)];
      if (face_sign[f] != 0.0f) {
        const size_t side = face_sign[f] > 0.0f ? 0 : 1;
        glm::vec3 dir = perpendicular_unit(sum[2 * i + side], n);
        if (dir == glm::vec3(0.0f)) dir = perpendicular_unit(face_tangent[f], n);
        t = glm::vec4(dir, face_sign[f]);
      } else {
        for (size_t side = 0; side < 2; ++side) {
          const glm::vec3 dir = perpendicular_unit(sum[2 * i + side], n);
          if (dir != glm::vec3(0.0f)) {
            t = glm::vec4(dir, side == 0 ? 1.0f : -1.0f);
            break;
          }
        }
      }
    }
  }
  return out;
}

}  // namespace tritrace
