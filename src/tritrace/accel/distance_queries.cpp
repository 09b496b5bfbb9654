// The distance queries on a GeometrySet: the BVH traversals of bvh/closest_point and
// bvh/winding_number over the set's tree, with their answers turned into geometry and triangle ids.
#include "tritrace/accel/distance_queries.h"

#include <cassert>
#include <cmath>

#include "tritrace/accel/bvh/closest_point.h"
#include "tritrace/parallel.h"

namespace tritrace {
namespace {

constexpr size_t kGrain = 256;

SurfacePoint surface_point(const GeometrySet& set, const bvh::ClosestPoint& c) {
  SurfacePoint out;
  if (c.prim == kNoHit) return out;
  const GeometrySet::Location at = set.locate(c.prim);
  out.point = c.point;
  out.distance = c.distance;
  out.geometry = at.geometry;
  out.prim = at.prim;
  out.u = c.u;
  out.v = c.v;
  // The mesh stores the lab's normalize(cross(e2, e1)); the caller's counter-clockwise normal is
  // its opposite (+0, not -0, for a zero normal).
  out.normal = glm::vec3(0.0f) - set.mesh().normal()[c.prim];
  return out;
}

}  // namespace

void closest_points(const GeometrySet& set, std::span<const glm::vec3> points,
                    std::span<SurfacePoint> out) {
  assert(points.size() == out.size());
  parallel::for_range(tbb::blocked_range<size_t>(0, points.size(), kGrain), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      out[i] = surface_point(set, bvh::closest_point(set.tree(), set.mesh(), points[i]));
    }
  });
}

InsideTest::InsideTest(const GeometrySet& set) : winding_(set.tree(), set.mesh()) {
  edges_.reserve(set.geometry_count());
  for (size_t g = 0; g < set.geometry_count(); ++g) {
    const uint32_t first = set.first_prim(static_cast<uint32_t>(g));
    const size_t end = g + 1 < set.geometry_count() ? set.first_prim(static_cast<uint32_t>(g + 1))
                                                    : set.triangle_count();
    edges_.push_back(count_edges(set.mesh(), first, end - first));
  }
}

double InsideTest::winding_number(const GeometrySet& set, const glm::vec3& p) const {
  return winding_.at(set.tree(), p);
}

void InsideTest::occupancy(const GeometrySet& set, std::span<const glm::vec3> points,
                           std::span<uint8_t> out) const {
  winding_.inside(set.tree(), points, out);
}

void InsideTest::signed_distance(const GeometrySet& set, std::span<const glm::vec3> points,
                                 std::span<float> out) const {
  assert(points.size() == out.size());
  parallel::for_range(tbb::blocked_range<size_t>(0, points.size(), kGrain), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const float d = bvh::closest_point(set.tree(), set.mesh(), points[i]).distance;
      // A point on the surface (d = 0) gets +0 whatever its winding number.
      out[i] = d > 0.0f && std::abs(winding_.at(set.tree(), points[i])) > 0.5 ? -d : d;
    }
  });
}

}  // namespace tritrace
