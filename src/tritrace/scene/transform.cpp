// Scene transformation: rebuilds the mesh from its exact vertices.
#include "tritrace/scene/transform.h"

namespace tritrace {

Scene transformed(const Scene& scene, const Similarity& xf) {
  Scene out;
  const TriangleMesh& m = scene.mesh;
  for (size_t i = 0; i < m.size(); ++i) {
    // A uniform scale and a translation leave normals as they are.
    if (m.has_shading_normals()) {
      const glm::vec3* n = &m.corner_normals()[3 * i];
      out.mesh.add(xf.apply(m.v0()[i]), xf.apply(m.v1()[i]), xf.apply(m.v2()[i]), m.material()[i],
                   {n[0], n[1], n[2]});
    } else {
      out.mesh.add(xf.apply(m.v0()[i]), xf.apply(m.v1()[i]), xf.apply(m.v2()[i]), m.material()[i]);
    }
  }
  out.environment = scene.environment;
  out.materials = scene.materials;
  for (const PointLight& light : scene.lights) {
    out.lights.push_back({xf.apply(light.position), light.power * (xf.scale * xf.scale)});
  }
  out.ambient = scene.ambient;
  out.camera = scene.camera.with_position(xf.apply(scene.camera.position()));
  return out;
}

}  // namespace tritrace
