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

namespace {

bool finite(glm::vec4 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && std::isfinite(v.w);
}

// Triangle k's extra corner attributes from `options`, checked and moved, into place `place`.
void set_checked_extras(TriangleMesh& mesh, size_t place, size_t k, const AddOptions& options,
                        const Transform* transform, float handedness) {
  glm::vec4 tangents[3], colours[3];
  glm::vec2 uvs1[3];
  for (size_t i = 0; i < 3; ++i) {
    if (!options.tangents.empty()) {
      glm::vec4 t = options.tangents[3 * k + i];
      if (transform != nullptr) {
        t = glm::vec4(transform->rotate * (transform->scale * glm::vec3(t)), t.w * handedness);
      }
      tangents[i] = finite(t) ? t : glm::vec4(0.0f);
    }
    if (!options.colours.empty()) {
      const glm::vec4 c = options.colours[3 * k + i];
      colours[i] = finite(c) ? c : glm::vec4(1.0f);
    }
    if (!options.uvs1.empty()) {
      const glm::vec2 t = options.uvs1[3 * k + i];
      uvs1[i] = std::isfinite(t.x) && std::isfinite(t.y) ? t : glm::vec2(0.0f);
    }
  }
  mesh.set_extras(place, options.tangents.empty() ? nullptr : tangents,
                  options.colours.empty() ? nullptr : colours,
                  options.uvs1.empty() ? nullptr : uvs1);
}

}  // namespace

AddResult add_all_checked(TriangleMesh& mesh, CornerView corners,
                          std::span<const uint32_t> material, std::span<const glm::vec3> normals,
                          std::span<const glm::vec2> uvs, const AddOptions& options,
                          LoadStats& stats) {
  assert(corners.size() == 3 * material.size() &&
         (normals.empty() || normals.size() == corners.size()) &&
         (uvs.empty() || uvs.size() == corners.size()));
  const size_t n = material.size();
  const Transform* transform = options.transform ? &*options.transform : nullptr;
  // Triangle k's corners as add() is given them.
  const auto corners_of = [&](size_t k, glm::vec3(&v)[3]) {
    for (size_t i = 0; i < 3; ++i) {
      v[i] = transform != nullptr ? transform->apply(corners[3 * k + i]) : corners[3 * k + i];
    }
  };
  const bool check_ids = !options.material;
  constexpr size_t kChunk = size_t{1} << 16;
  const size_t chunks = (n + kChunk - 1) / kChunk;
  // First pass: what each chunk keeps and drops, and its first material id out of range; then
  // each chunk's first place in the mesh.
  struct Counts {
    size_t kept = 0, degenerate = 0, non_finite = 0;
    size_t bad_material = std::numeric_limits<size_t>::max();
  };
  std::vector<Counts> counts(chunks);
  // The workers report to the caller's progress, a unit per triangle and pass.
  LoadProgress* progress = load_progress();
  if (progress != nullptr) progress->begin("adding triangles", 2 * n);
  const tbb::blocked_range<size_t> all_chunks(0, chunks, 1);
  parallel::for_range(all_chunks, [&](const tbb::blocked_range<size_t>& r) {
    for (size_t c = r.begin(); c != r.end(); ++c) {
      const size_t end = std::min(n, (c + 1) * kChunk);
      if (progress != nullptr) progress->advance(end - c * kChunk);
      Counts& out = counts[c];
      for (size_t k = c * kChunk; k < end; ++k) {
        if (check_ids && material[k] >= options.materials)
          out.bad_material = std::min(out.bad_material, k);
        glm::vec3 v[3];
        corners_of(k, v);
        switch (check_triangle(v[0], v[1], v[2])) {
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
  size_t bad_material = std::numeric_limits<size_t>::max();
  size_t too_many = std::numeric_limits<size_t>::max();  // the first triangle met when full
  for (size_t c = 0; c < chunks; ++c) {
    first[c] = kept;
    bad_material = std::min(bad_material, counts[c].bad_material);
    if (too_many == std::numeric_limits<size_t>::max() &&
        options.stored + kept + counts[c].kept >= options.max_triangles) {
      // The scene fills up in this chunk, or is full at the next one's start: find the triangle.
      size_t in_scene = options.stored + kept;
      for (size_t k = c * kChunk; k < std::min(n, (c + 1) * kChunk); ++k) {
        if (in_scene >= options.max_triangles) {
          too_many = k;
          break;
        }
        glm::vec3 v[3];
        corners_of(k, v);
        in_scene += check_triangle(v[0], v[1], v[2]) == TriangleCheck::kOk ? 1 : 0;
      }
      if (too_many == std::numeric_limits<size_t>::max() && c + 1 < chunks) {
        too_many = (c + 1) * kChunk;
      }
    }
    kept += counts[c].kept;
  }
  if (bad_material < n && bad_material <= too_many) return AddResult::kMaterialOutOfRange;
  if (too_many < n) return AddResult::kTooManyTriangles;
  for (const Counts& c : counts) {
    stats.dropped_degenerate += c.degenerate;
    stats.dropped_non_finite += c.non_finite;
  }
  const size_t held = mesh.size();
  mesh.grow(kept, !normals.empty() && kept > 0, !uvs.empty() && kept > 0);
  mesh.make_extras(!options.tangents.empty() && kept > 0, !options.colours.empty() && kept > 0,
                   !options.uvs1.empty() && kept > 0);
  const bool extras =
      !options.tangents.empty() || !options.colours.empty() || !options.uvs1.empty();
  // A mirroring transform (negative scale product) turns the bitangent cross(n, t) around.
  const float handedness =
      transform != nullptr && transform->scale.x * transform->scale.y * transform->scale.z < 0.0f
          ? -1.0f
          : 1.0f;
  // Second pass: each chunk fills its places, exactly as add_checked would have in order.
  parallel::for_range(all_chunks, [&](const tbb::blocked_range<size_t>& r) {
    for (size_t c = r.begin(); c != r.end(); ++c) {
      size_t place = held + first[c];
      const size_t end = std::min(n, (c + 1) * kChunk);
      for (size_t k = c * kChunk; k < end; ++k) {
        glm::vec3 v[3];
        corners_of(k, v);
        if (check_triangle(v[0], v[1], v[2]) != TriangleCheck::kOk) continue;
        std::array<glm::vec3, 3> unit;
        if (!normals.empty()) {
          glm::vec3 moved[3];
          for (size_t i = 0; i < 3; ++i) {
            moved[i] = transform != nullptr ? transform->apply_normal(normals[3 * k + i])
                                            : normals[3 * k + i];
          }
          unit = checked_normals(v[0], v[1], v[2], moved);
        }
        std::array<glm::vec2, 3> t;
        if (!uvs.empty()) t = checked_uvs(&uvs[3 * k]);
        const uint32_t id =
            options.material ? *options.material : options.material_offset + material[k];
        if (extras) set_checked_extras(mesh, place, k, options, transform, handedness);
        mesh.set(place++, v[0], v[1], v[2], id, normals.empty() ? nullptr : &unit,
                 uvs.empty() ? nullptr : &t);
      }
      if (progress != nullptr) progress->advance(end - c * kChunk);
    }
  });
  return AddResult::kOk;
}

void add_all_checked(TriangleMesh& mesh, CornerView corners, std::span<const uint32_t> material,
                     std::span<const glm::vec3> normals, std::span<const glm::vec2> uvs,
                     LoadStats& stats) {
  [[maybe_unused]] const AddResult result =
      add_all_checked(mesh, corners, material, normals, uvs, AddOptions{}, stats);
  assert(result == AddResult::kOk);
}

}  // namespace tritrace
