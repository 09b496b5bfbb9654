// Edge counting by sorting: corners get vertex ids by sorting their positions, directed edges are
// 64-bit keys (smaller id, larger id) with their direction aside, and sorting those puts the uses
// of each edge side by side.
#include "tritrace/geometry/mesh_edges.h"

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <vector>

namespace tritrace {
namespace {

using Key = std::array<uint32_t, 3>;

Key position_key(const glm::vec3& p) {
  // +0 and -0 are one position.
  const auto bits = [](float x) { return std::bit_cast<uint32_t>(x == 0.0f ? 0.0f : x); };
  return {bits(p.x), bits(p.y), bits(p.z)};
}

}  // namespace

EdgeReport count_edges(const TriangleMesh& mesh, size_t first, size_t count) {
  const size_t corners = 3 * count;
  struct Corner {
    Key key;
    uint32_t index;
  };
  std::vector<Corner> sorted(corners);
  for (size_t i = 0; i < corners; ++i) {
    sorted[i] = {position_key(mesh.vertex(first + i / 3, static_cast<int>(i % 3))),
                 static_cast<uint32_t>(i)};
  }
  tbb::parallel_sort(sorted.begin(), sorted.end(),
                     [](const Corner& a, const Corner& b) { return a.key < b.key; });
  std::vector<uint32_t> id(corners);
  uint32_t next = 0;
  for (size_t i = 0; i < corners; ++i) {
    if (i > 0 && sorted[i].key != sorted[i - 1].key) ++next;
    id[sorted[i].index] = next;
  }
  sorted = {};
  // Edge (a -> b) as (min, max) << 1 | (a > b).
  std::vector<uint64_t> edges;
  edges.reserve(corners);
  for (size_t t = 0; t < count; ++t) {
    for (int e = 0; e < 3; ++e) {
      const uint32_t a = id[3 * t + e], b = id[3 * t + (e + 1) % 3];
      if (a == b) continue;
      const uint64_t lo = std::min(a, b), hi = std::max(a, b);
      edges.push_back((lo << 33) | (hi << 1) | (a > b ? 1u : 0u));
    }
  }
  tbb::parallel_sort(edges.begin(), edges.end());
  EdgeReport report;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i, reversed = 0;
    while (j < edges.size() && (edges[j] >> 1) == (edges[i] >> 1)) reversed += edges[j++] & 1u;
    const size_t uses = j - i;
    ++report.edges;
    if (uses == 1) {
      ++report.boundary;
    } else if (uses > 2) {
      ++report.non_manifold;
    } else if (reversed != 1) {
      ++report.misoriented;
    }
    i = j;
  }
  return report;
}

}  // namespace tritrace
