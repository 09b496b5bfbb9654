// Test inputs shared by the accel tests: random triangle soups and rays of every awkward kind.
#pragma once

#include <cmath>
#include <glm/geometric.hpp>
#include <random>
#include <vector>

#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/math/ray.h"

namespace tritrace {

inline TriangleMesh random_soup(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-1.0f, 1.0f), size(0.01f, 0.3f);
  TriangleMesh m;
  for (int i = 0; i < n; ++i) {
    const glm::vec3 c(pos(rng), pos(rng), pos(rng));
    const float s = size(rng);
    m.add(c, c + s * glm::vec3(pos(rng), pos(rng), pos(rng)),
          c + s * glm::vec3(pos(rng), pos(rng), pos(rng)), 0);
  }
  return m;
}

// Triangles whose vertices differ wildly in magnitude (coordinates from 1e-7 to 1e2, crossing
// zero, each vertex drawn on its own: a vertex made as v0 + offset in float always gives back
// v0 + (v1 - v0) == v1), so that for many of them v0 + (v1 - v0) is not v1: a structure that
// rebuilt the vertices from the edges would answer differently from the oracle's exact vertices.
inline TriangleMesh mixed_magnitude_soup(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), exponent(-7.0f, 2.0f);
  auto coordinate = [&] { return unit(rng) * std::pow(10.0f, exponent(rng)); };
  TriangleMesh m;
  for (int i = 0; i < n; ++i) {
    const glm::vec3 a(coordinate(), coordinate(), coordinate());
    const glm::vec3 b(coordinate(), coordinate(), coordinate());
    const glm::vec3 c(coordinate(), coordinate(), coordinate());
    m.add(a, b, c, 0);
  }
  return m;
}

// Rays of every awkward kind: from outside and inside, aimed at vertices and edges, parallel to the
// axes, with zero direction components, and grazing along a coordinate plane.
inline std::vector<Ray> awkward_rays(const TriangleMesh& mesh, int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-1.5f, 1.5f), unit(0.0f, 1.0f);
  std::uniform_int_distribution<size_t> tri(0, mesh.size() - 1);
  std::vector<Ray> rays;
  for (int i = 0; i < n; ++i) {
    Ray r;
    r.origin = glm::vec3(pos(rng), pos(rng), pos(rng)) * (i % 3 == 0 ? 4.0f : 1.0f);
    const size_t t = tri(rng);
    glm::vec3 target;
    switch (i % 6) {
      case 0:  // a vertex
        target = mesh.vertex(t, static_cast<int>(i % 3));
        break;
      case 1: {  // a point on an edge
        const float a = unit(rng);
        target = mesh.v0()[t] + a * mesh.e1(t);
        break;
      }
      default: {  // inside (or near) the triangle
        const float a = unit(rng), b = unit(rng) * (1.0f - a);
        target = mesh.v0()[t] + a * mesh.e1(t) + b * mesh.e2(t);
      }
    }
    r.dir = target - r.origin;
    if (i % 7 == 0) r.dir[i % 3] = 0.0f;  // a zero component
    if (i % 11 == 0) {                    // parallel to an axis
      r.dir = glm::vec3(0.0f);
      r.dir[i % 3] = (i % 2) ? 1.0f : -1.0f;
    }
    if (i % 13 == 0) r.origin.y = target.y, r.dir.y = 0.0f;  // grazing a horizontal plane
    if (glm::dot(r.dir, r.dir) == 0.0f) r.dir = {0.0f, 0.0f, 1.0f};
    r.dir = glm::normalize(r.dir);
    if (i % 5 == 0) r.tmax = unit(rng) * 3.0f;  // a bounded segment, like a shadow ray
    rays.push_back(r);
  }
  return rays;
}

// Coherent packets, as the renderer makes them, aimed at vertices and edges so that boxes and
// triangles are grazed: groups of 16 consecutive rays from one origin (a pinhole camera) through a
// 4 x 4 grid of points around a target, or from 16 nearby origins (hit points) to one point (a
// light) as bounded segments. The packet traversal's whole-packet (frustum) tests run on these.
inline std::vector<Ray> coherent_rays(const TriangleMesh& mesh, int packets, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-1.5f, 1.5f), unit(0.0f, 1.0f);
  std::uniform_int_distribution<size_t> tri(0, mesh.size() - 1);
  std::vector<Ray> rays;
  for (int k = 0; k < packets; ++k) {
    const size_t t = tri(rng);
    const glm::vec3 target =
        k % 2 == 0 ? mesh.vertex(t, k % 3) : mesh.v0()[t] + unit(rng) * mesh.e1(t);
    const glm::vec3 origin = glm::vec3(pos(rng), pos(rng), pos(rng)) * (k % 3 == 0 ? 3.0f : 1.0f);
    const float spread = (k % 4 == 0 ? 1e-6f : 1e-2f) * (1.0f + glm::length(target - origin));
    const bool towards_light = k % 3 == 2;
    for (int l = 0; l < 16; ++l) {
      const glm::vec3 offset(spread * static_cast<float>(l % 4 - 2),
                             spread * static_cast<float>(l / 4 - 2), spread * unit(rng));
      Ray r;
      if (towards_light) {  // many origins around the target, one end point
        r.origin = target + offset;
        const glm::vec3 segment = origin - r.origin;
        r.tmax = glm::length(segment);
        r.dir = segment / r.tmax;
      } else {
        r.origin = origin;
        r.dir = glm::normalize(target + offset - origin);
      }
      rays.push_back(r);
    }
  }
  return rays;
}

}  // namespace tritrace
