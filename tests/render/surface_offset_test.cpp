// leave_surface and stop_short_of_surface against exact geometry: the height of the moved point
// above the triangle's plane, computed in double from the triangle's float vertices, is positive
// on the side asked for, wherever the triangle sits and however it is tilted.
#include "tritrace/render/surface_offset.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <random>

namespace tritrace {
namespace {

// The signed distance of p from the plane through the triangle, along its unit normal n (double).
double height(const SurfaceTriangle& t, glm::vec3 p, glm::dvec3 n) {
  return glm::dot(glm::dvec3(p) - glm::dvec3(t.v0), n);
}

// Small tilted triangles (edges about 0.006, as a 256-segment sphere of radius 0.25 has) at the
// origin and far from it; points from the barycentrics, as the renderers compute them.
TEST(LeaveSurface, EndsOnTheAskedSideOfTiltedTrianglesFarFromTheOrigin) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f), s(-1.0f, 1.0f);
  for (const glm::vec3 centre : {glm::vec3(0.0f), glm::vec3(300.0f, -200.0f, 100.0f)}) {
    int below = 0, total = 0;
    for (int k = 0; k < 20000; ++k) {
      const glm::vec3 a = centre + glm::vec3(s(rng), s(rng), s(rng)) * 0.25f;
      const glm::vec3 b = a + glm::vec3(s(rng), s(rng), s(rng)) * 0.006f;
      const glm::vec3 c = a + glm::vec3(s(rng), s(rng), s(rng)) * 0.006f;
      SurfaceTriangle t{a, b - a, c - a, glm::vec3(0.0f)};
      const glm::dvec3 nd =
          glm::cross(glm::dvec3(c) - glm::dvec3(a), glm::dvec3(b) - glm::dvec3(a));
      if (!(glm::length(nd) > 1e-7)) continue;
      const glm::dvec3 n = glm::normalize(nd);
      t.normal = glm::vec3(n);
      float b1 = u(rng), b2 = u(rng);
      if (b1 + b2 > 1.0f) {
        b1 = 1.0f - b1;
        b2 = 1.0f - b2;
      }
      const glm::vec3 x = t.v0 + b1 * t.e1 + b2 * t.e2;
      for (const float side : {1.0f, -1.0f}) {
        const glm::vec3 p = leave_surface(t, x, side * t.normal, RayOffsetParams{});
        ++total;
        if (!(side * height(t, p, n) > 0.0)) ++below;
      }
    }
    EXPECT_EQ(below, 0) << "of " << total << " about (" << centre.x << ", " << centre.y << ", "
                        << centre.z << ")";
  }
}

TEST(StopShortOfSurface, MovesOnAlongTheSideByAMillionthOfTheLength) {
  const glm::vec3 from(0.0f, 0.0f, 0.0f), end(0.0f, 0.0f, 4.0f), side(0.0f, 0.0f, -1.0f);
  const glm::vec3 p = stop_short_of_surface(end, side, from);
  EXPECT_EQ(p.x, 0.0f);
  EXPECT_EQ(p.y, 0.0f);
  EXPECT_EQ(p.z, 4.0f - 4.0f / 1048576.0f);  // exact: 4 - 2^-18 is a float
}

}  // namespace
}  // namespace tritrace
