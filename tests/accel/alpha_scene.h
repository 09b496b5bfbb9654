// Test scenes for cut-outs: a unit quad with an alpha texture of eight columns in front of a big
// wall, so that the share of rays that pass it is known by hand.
#pragma once

#include <array>
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "tritrace/image/texture.h"
#include "tritrace/scene/scene.h"

namespace tritrace::alpha_test {

// Columns 2, 3 and 4 of 8 are transparent: with bilinear filtering, clamped edges and the cutoff
// halfway between 0 and 1, alpha < 0.5 exactly where 2/8 < u < 5/8 (the 0.5 level of a blend of
// two neighbouring texels lies on the border between them), a share of 3/8 of the quad.
inline constexpr std::array<uint8_t, 8> kColumns = {255, 255, 0, 0, 0, 255, 255, 255};
inline constexpr double kTransparentShare = 3.0 / 8.0;

// The square [x0, x0 + side] x [y0, y0 + side] at depth z (facing -z), texture coordinates
// running from uv0 at (x0, y0) to uv1 at the opposite corner.
inline void add_square(TriangleMesh& mesh, float x0, float y0, float side, float z,
                       uint32_t material, int axis = 2, float uv0 = 0.0f, float uv1 = 1.0f) {
  auto point = [&](float a, float b) {
    const glm::vec3 p{x0 + a * side, y0 + b * side, z};
    // axis 1: the square lies in the plane y = z (x, z from a, b), for floors.
    return axis == 1 ? glm::vec3(p.x, z, p.y) : p;
  };
  const glm::vec2 lo(uv0), hi(uv1);
  const std::array<glm::vec2, 3> first = {lo, glm::vec2(hi.x, lo.y), hi};
  const std::array<glm::vec2, 3> second = {lo, hi, glm::vec2(lo.x, hi.y)};
  mesh.add(point(0, 0), point(1, 0), point(1, 1), material, nullptr, &first);
  mesh.add(point(0, 0), point(1, 1), point(0, 1), material, nullptr, &second);
}

// The eight-column texture, RGB grey.
inline Texture column_texture() {
  TextureImage image{static_cast<int>(kColumns.size()), 1, {}, {}};
  for (uint8_t a : kColumns) {
    image.rgb.insert(image.rgb.end(), {128, 128, 128});
    image.alpha.push_back(a);
  }
  return Texture::from_srgb8(image);
}

// Material 0: the wall (opaque); material 1: the quad, `mode` with the column texture when
// `textured`, else a constant `alpha`. The quad is [0, 1]^2 at z = 1, the wall [-2, 3]^2 at z = 2.
inline Scene quad_before_wall(AlphaMode mode, bool textured, float alpha = 1.0f) {
  Scene s;
  Material wall{glm::vec3(0.5f)};
  Material quad{glm::vec3(0.5f)};
  quad.alpha_mode = mode;
  quad.alpha = alpha;
  if (textured) {
    s.textures.push_back(column_texture());
    quad.albedo_texture = {0, WrapMode::kClamp, WrapMode::kClamp};
  }
  s.materials = {wall, quad};
  add_square(s.mesh, 0.0f, 0.0f, 1.0f, 1.0f, 1);
  add_square(s.mesh, -2.0f, -2.0f, 5.0f, 2.0f, 0);
  return s;
}

}  // namespace tritrace::alpha_test
