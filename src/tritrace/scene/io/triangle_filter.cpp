// Triangle validity in the same float arithmetic TriangleMesh::add uses, so an accepted triangle
// has finite edges and a finite, non-zero normal.
#include "tritrace/scene/io/triangle_filter.h"

#include <tbb/blocked_range.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <glm/geometric.hpp>
#include <vector>

#include "tritrace/parallel.h"
#include "tritrace/scene/io/load_progress.h"

namespace tritrace {
namespace {

bool finite(glm::vec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// The file's corner normals, normalised; one that is not finite or has zero length becomes the
// geometric normal.
std::array<glm::vec3, 3> checked_normals(glm::vec3 a, glm::vec3 b, glm::vec3 c,
                                         const glm::vec3* normals) {
  std::array<glm::vec3, 3> unit;
  const glm::vec3 geometric = glm::normalize(glm::cross(c - a, b - a));
  for (size_t k = 0; k < 3; ++k) {
    const glm::vec3 n = normals[k];
    const float len = glm::length(n);
    unit[k] = finite(n) && std::isfinite(len) && len > 0.0f ? n / len : geometric;
  }
  return unit;
}

// The file's texture coordinates, non-finite ones made (0, 0).
std::array<glm::vec2, 3> checked_uvs(const glm::vec2* uvs) {
  std::array<glm::vec2, 3> t;
  for (size_t k = 0; k < 3; ++k) {
    t[k] = std::isfinite(uvs[k].x) && std::isfinite(uvs[k].y) ? uvs[k] : glm::vec2(0.0f);
  }
  return t;
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
  if (normals != nullptr) unit = checked_normals(a, b, c, normals);
  std::array<glm::vec2, 3> t;
  if (uvs != nullptr) t = checked_uvs(uvs);
  mesh.add(a, b, c, material, normals != nullptr ? &unit : nullptr, uvs != nullptr ? &t : nullptr);
  return true;
}

void add_all_checked(TriangleMesh& mesh, std::span<const glm::vec3> corners,
                     std::span<const uint32_t> material, std::span<const glm::vec3> normals,
                     std::span<const glm::vec2> uvs, LoadStats& stats) {
  assert(mesh.empty() && corners.size() == 3 * material.size() &&
         (normals.empty() || normals.size() == corners.size()) &&
         (uvs.empty() || uvs.size() == corners.size()));
  const size_t n = material.size();
  constexpr size_t kChunk = size_t{1} << 16;
  const size_t chunks = (n + kChunk - 1) / kChunk;
  // First pass: what each chunk keeps and drops; then each chunk's first place in the mesh.
  struct Counts {
    size_t kept = 0, degenerate = 0, non_finite = 0;
  };
  std::vector<Counts> counts(chunks);
  // The workers report to the caller's progress, a unit per triangle and pass.
  LoadProgress* progress = load_progress();
  if (progress != nullptr) progress->begin("adding triangles", 2 * n);
  const tbb::blocked_range<size_t> all_chunks(0, chunks, 1);
  parallel::for_range(all_chunks, [&](const tbb::blocked_range<size_t>& r) {
    for (size_t c = r.begin(); c != r.end(); ++c) {
      if (progress != nullptr) progress->advance(std::min(n, (c + 1) * kChunk) - c * kChunk);
      Counts& out = counts[c];
      for (size_t k = c * kChunk; k < std::min(n, (c + 1) * kChunk); ++k) {
        switch (check_triangle(corners[3 * k], corners[3 * k + 1], corners[3 * k + 2])) {
          case TriangleCheck::kOk:
            ++out.kept;
            break;
          case TriangleCheck::kDegenerate:
            ++out.degenerate;
            break;
          case TriangleCheck::kNonFinite:
            ++out.non_finite;
            break;
        }
      }
    }
  });
  std::vector<size_t> first(chunks);
  size_t kept = 0;
  for (size_t c = 0; c < chunks; ++c) {
    first[c] = kept;
    kept += counts[c].kept;
    stats.dropped_degenerate += counts[c].degenerate;
    stats.dropped_non_finite += counts[c].non_finite;
  }
  mesh.resize(kept, !normals.empty(), !uvs.empty());
  // Second pass: each chunk fills its places, exactly as add_checked would have in order.
  parallel::for_range(all_chunks, [&](const tbb::blocked_range<size_t>& r) {
    for (size_t c = r.begin(); c != r.end(); ++c) {
      size_t place = first[c];
      const size_t end = std::min(n, (c + 1) * kChunk);
      for (size_t k = c * kChunk; k < end; ++k) {
        const glm::vec3 a = corners[3 * k], b = corners[3 * k + 1], d = corners[3 * k + 2];
        if (check_triangle(a, b, d) != TriangleCheck::kOk) continue;
        std::array<glm::vec3, 3> unit;
        if (!normals.empty()) unit = checked_normals(a, b, d, &normals[3 * k]);
        std::array<glm::vec2, 3> t;
        if (!uvs.empty()) t = checked_uvs(&uvs[3 * k]);
        mesh.set(place++, a, b, d, material[k], normals.empty() ? nullptr : &unit,
                 uvs.empty() ? nullptr : &t);
      }
      if (progress != nullptr) progress->advance(end - c * kChunk);
    }
  });
}

}  // namespace tritrace
