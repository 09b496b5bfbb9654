// GeometrySet: the checks on added geometries, and the BVH over all of them with zero-area
// triangles made unhittable in its triangle blocks.
#include "tritrace/accel/geometry_set.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>

#include "tritrace/error.h"

namespace tritrace {
namespace {

// Zero area, decided in double: the corners' differences and the cross product's products are
// exact there for all but extreme coordinate ranges, so this is the exact test of collinear or
// coincident corners in practice, and a sliver of tiny but non-zero area stays a triangle.
bool zero_area(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  const glm::dvec3 e1 = glm::dvec3(b) - glm::dvec3(a);
  const glm::dvec3 e2 = glm::dvec3(c) - glm::dvec3(a);
  const double x = e1.y * e2.z - e1.z * e2.y;
  const double y = e1.z * e2.x - e1.x * e2.z;
  const double z = e1.x * e2.y - e1.y * e2.x;
  return x == 0.0 && y == 0.0 && z == 0.0;
}

// Text that reads back as the same float: nine significant digits round-trip every float.
std::string float_text(float x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.9g", static_cast<double>(x));
  return buffer;
}

std::string vector_text(const glm::vec3& v) {
  return "(" + float_text(v.x) + ", " + float_text(v.y) + ", " + float_text(v.z) + ")";
}

}  // namespace

GeometrySet::GeometrySet() : mesh_(std::make_unique<TriangleMesh>()) {}
GeometrySet::~GeometrySet() = default;
GeometrySet::GeometrySet(GeometrySet&&) noexcept = default;
GeometrySet& GeometrySet::operator=(GeometrySet&&) noexcept = default;

uint32_t GeometrySet::add(std::span<const glm::vec3> vertices,
                          std::span<const glm::uvec3> triangles) {
  for (size_t i = 0; i < vertices.size(); ++i) {
    const glm::vec3& p = vertices[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      throw Error("vertices", "vertex " + std::to_string(i) + " is not finite: " + vector_text(p));
    }
  }
  for (size_t i = 0; i < triangles.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      if (triangles[i][c] >= vertices.size()) {
        throw Error("triangles", "triangle " + std::to_string(i) + " has vertex index " +
                                     std::to_string(triangles[i][c]) + ", but there are " +
                                     std::to_string(vertices.size()) + " vertices");
      }
    }
  }
  // Every concatenated index, and kNoHit besides, must fit in 32 bits.
  constexpr size_t kMostTriangles = std::numeric_limits<uint32_t>::max() - 1;
  if (triangles.size() > kMostTriangles - mesh_->size()) {
    throw Error("triangles", "more than " + std::to_string(kMostTriangles) +
                                 " triangles in all cannot be indexed in 32 bits");
  }
  if (first_prim_.size() >= std::numeric_limits<uint32_t>::max()) {
    throw Error("vertices", "too many geometries");
  }
  const auto id = static_cast<uint32_t>(first_prim_.size());
  first_prim_.push_back(static_cast<uint32_t>(mesh_->size()));
  accel_.reset();
  mesh_->reserve(mesh_->size() + triangles.size());
  degenerate_.reserve(degenerate_.size() + triangles.size());
  for (const glm::uvec3& t : triangles) {
    const glm::vec3 &a = vertices[t[0]], &b = vertices[t[1]], &c = vertices[t[2]];
    mesh_->add(a, b, c, id);
    degenerate_.push_back(zero_area(a, b, c) ? 1 : 0);
  }
  return id;
}

void GeometrySet::build() {
  if (accel_) return;
  bvh::WideBvh tree = bvh::build_wide_bvh(*mesh_, bvh::default_build_config(mesh_->size()));
  // A zero-area triangle projects onto a segment or a point in exact arithmetic, but the kernels'
  // rounded shear can open it into a sliver that a ray passing the segment "hits". With its
  // corners all equal every edge function is exactly zero, so the determinant is zero and every
  // kernel rejects it.
  for (bvh::TriangleBlock& block : tree.blocks) {
    for (int l = 0; l < bvh::kWidth; ++l) {
      if (block.prim[l] == kNoHit || !degenerate_[block.prim[l]]) continue;
      for (int c = 1; c < 3; ++c) {
        for (int a = 0; a < 3; ++a) block.vertex[c][a][l] = block.vertex[0][a][l];
      }
    }
  }
  accel_ = std::make_unique<BvhAccel>(*mesh_, std::move(tree), Kernel::kWatertight);
}

}  // namespace tritrace
