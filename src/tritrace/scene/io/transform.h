// The scene file's "transform" of a mesh (scale, then rotate, then translate), shared by the
// parser and add_all_checked, which both move triangles with it and must round alike.
#pragma once

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

namespace tritrace {

struct Transform {
  glm::vec3 translate{0.0f};
  glm::mat3 rotate{1.0f};
  glm::vec3 scale{1.0f};

  glm::vec3 apply(glm::vec3 p) const { return translate + rotate * (scale * p); }
  // The inverse transpose of rotate * diag(scale) (rotate is orthonormal), unnormalised.
  glm::vec3 apply_normal(glm::vec3 n) const { return rotate * (n / scale); }
};

}  // namespace tritrace
