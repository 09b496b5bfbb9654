// Edge counts that decide whether a mesh is closed: hand-counted boxes with a face missing, a
// flipped triangle and a fin, and a box whose triangles repeat their shared corners.
#include "tritrace/geometry/mesh_edges.h"

#include <gtest/gtest.h>

#include "../accel/query_meshes.h"

namespace tritrace {
namespace {

TEST(MeshEdges, BoxIsClosed) {
  const TriangleMesh box = box_mesh(glm::dvec3(0), glm::dvec3(1)).mesh();
  const EdgeReport r = count_edges(box, 0, box.size());
  // 12 box edges and one diagonal per face.
  EXPECT_EQ(r.edges, 18u);
  EXPECT_TRUE(r.closed());
}

TEST(MeshEdges, MissingFaceLeavesFourBoundaryEdges) {
  const TriangleMesh box = box_mesh(glm::dvec3(0), glm::dvec3(1)).mesh();
  const EdgeReport r = count_edges(box, 2, box.size() - 2);  // without the first face
  EXPECT_EQ(r.edges, 17u);
  EXPECT_EQ(r.boundary, 4u);
  EXPECT_EQ(r.non_manifold, 0u);
  EXPECT_FALSE(r.closed());
}

TEST(MeshEdges, FlippedTriangleIsMisoriented) {
  IndexedMesh m = box_mesh(glm::dvec3(0), glm::dvec3(1));
  std::swap(m.triangles[0][1], m.triangles[0][2]);
  const TriangleMesh box = m.mesh();
  const EdgeReport r = count_edges(box, 0, box.size());
  EXPECT_EQ(r.misoriented, 3u);
  EXPECT_EQ(r.boundary, 0u);
  EXPECT_FALSE(r.closed());
}

TEST(MeshEdges, FinMakesANonManifoldEdge) {
  IndexedMesh m = box_mesh(glm::dvec3(0), glm::dvec3(1));
  m.vertices.emplace_back(0.5, -1.0, -1.0);
  // A fin on the edge between corners 0 and 1: that edge now has three triangles, and the fin's
  // two other edges are boundary.
  m.triangles.push_back({0, 1, 8});
  const TriangleMesh box = m.mesh();
  const EdgeReport r = count_edges(box, 0, box.size());
  EXPECT_EQ(r.non_manifold, 1u);
  EXPECT_EQ(r.boundary, 2u);
}

TEST(MeshEdges, DegenerateTrianglesAddNoZeroLengthEdges) {
  TriangleMesh m = box_mesh(glm::dvec3(0), glm::dvec3(1)).mesh();
  m.add(glm::vec3(0), glm::vec3(0), glm::vec3(0), 0);
  EXPECT_EQ(count_edges(m, 0, m.size()).edges, 18u);
}

}  // namespace
}  // namespace tritrace
