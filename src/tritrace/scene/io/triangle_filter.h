// The one gate every loaded triangle passes: triangles with a NaN or infinite vertex (or whose
// edges or area overflow a float) and zero-area triangles are dropped and counted, so that a
// render never sees them and `tritrace info` can report how many there were.
#pragma once

#include <array>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <limits>
#include <optional>
#include <span>

#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/scene/io/loaded_scene.h"
#include "tritrace/scene/io/transform.h"

namespace tritrace {

// A scene larger than this is refused at load time rather than exhausting memory (about 64 bytes
// per triangle).
inline constexpr size_t kMaxSceneTriangles = size_t{64} << 20;

enum class TriangleCheck { kOk, kDegenerate, kNonFinite };

TriangleCheck check_triangle(glm::vec3 a, glm::vec3 b, glm::vec3 c);

// Adds the triangle when check_triangle accepts it, else counts it in `stats`. Returns whether it
// was added.
bool add_checked(TriangleMesh& mesh, glm::vec3 a, glm::vec3 b, glm::vec3 c, uint32_t material,
                 LoadStats& stats);
// The same with the file's normal and texture coordinates at each corner (null: none). The normals
// are normalised; one that is not finite or has zero length is replaced by the triangle's geometric
// normal (a file's broken normal must not turn into NaN shading). Non-finite texture coordinates
// become (0, 0).
bool add_checked(TriangleMesh& mesh, glm::vec3 a, glm::vec3 b, glm::vec3 c, uint32_t material,
                 const glm::vec3* normals, const glm::vec2* uvs, LoadStats& stats);

// How add_all_checked adds a loaded mesh: a scene file's transform and material choice for the
// mesh, and the scene's triangle limit. The defaults add the mesh as it is.
struct AddOptions {
  // Moves the corners with apply() and the file's normals with apply_normal(), before the checks.
  std::optional<Transform> transform;
  std::optional<uint32_t> material;  // every triangle's material, in place of the file's
  uint32_t material_offset = 0;      // added to the file's material ids
  // The file's material count: a larger id is an error (not checked with `material`).
  size_t materials = std::numeric_limits<size_t>::max();
  // The scene holds `stored` triangles before this mesh and may hold at most `max_triangles`: a
  // triangle (kept or dropped) met when the scene is full is an error.
  size_t stored = 0;
  size_t max_triangles = std::numeric_limits<size_t>::max();
  // glTF's further corner attributes (TriangleMesh::set_extras), each three per triangle or empty.
  // Tangents move with the transform's linear part (their sign turns where it mirrors); a
  // non-finite value becomes the attribute's default.
  std::span<const glm::vec4> tangents;
  std::span<const glm::vec4> colours;
  std::span<const glm::vec2> uvs1;
};

// The first error adding the triangles one by one would meet: the material id is checked before
// the limit, triangle after triangle.
enum class AddResult { kOk, kMaterialOutOfRange, kTooManyTriangles };

// A loaded mesh's corners, three per triangle: stored one by one, or as indices into the file's
// vertices (ImportedMesh's two forms).
struct CornerView {
  // Implicit, so that any array of corners passes as it is.
  template <typename Corners>
  requires std::convertible_to<const Corners&, std::span<const glm::vec3>> CornerView(
      const Corners& each)  // NOLINT(google-explicit-constructor)
      : corners(std::span<const glm::vec3>(each)) {}
  CornerView(std::span<const glm::vec3> vertices, std::span<const uint32_t> three_per_triangle)
      : positions(vertices), indices(three_per_triangle) {}
  glm::vec3 operator[](size_t k) const {
    return indices.empty() ? corners[k] : positions[indices[k]];
  }
  size_t size() const { return indices.empty() ? corners.size() : indices.size(); }

  std::span<const glm::vec3> corners;
  std::span<const glm::vec3> positions;
  std::span<const uint32_t> indices;
};

// add_checked for every triangle of a loaded mesh (corners three per triangle; normals and uvs
// three per triangle or empty), in order, after the triangles `mesh` holds: the same mesh and
// counts as calling it triangle by triangle, computed in parallel. On an error nothing is added
// or counted. Reports "adding triangles" to the thread's LoadProgress.
[[nodiscard]] AddResult add_all_checked(TriangleMesh& mesh, CornerView corners,
                                        std::span<const uint32_t> material,
                                        std::span<const glm::vec3> normals,
                                        std::span<const glm::vec2> uvs, const AddOptions& options,
                                        LoadStats& stats);
// The same with the default options, which meet no error.
void add_all_checked(TriangleMesh& mesh, CornerView corners, std::span<const uint32_t> material,
                     std::span<const glm::vec3> normals, std::span<const glm::vec2> uvs,
                     LoadStats& stats);

}  // namespace tritrace
