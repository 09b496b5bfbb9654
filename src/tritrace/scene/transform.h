// Moving a whole scene, camera and lights included, by a uniform scale and a translation: the same
// picture at another size or place, which is how the robustness of secondary rays is tested.
#pragma once

#include <glm/vec3.hpp>

#include "tritrace/scene/scene.h"

namespace tritrace {

// p -> scale * p + translation, scale > 0.
struct Similarity {
  float scale = 1.0f;
  glm::vec3 translation{0.0f};

  glm::vec3 apply(glm::vec3 p) const { return scale * p + translation; }
};

// Every vertex, instance placement, light position and the camera position moved by `xf`; the
// camera keeps its orientation and focal length. Light power is multiplied by scale^2, so that the
// inverse-square falloff leaves the direct light at corresponding points unchanged: the image is
// the same up to rounding.
Scene transformed(const Scene& scene, const Similarity& xf);

}  // namespace tritrace
