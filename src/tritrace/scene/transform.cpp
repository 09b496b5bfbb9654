// Scene transformation: rebuilds the mesh from its exact vertices.
#include "tritrace/scene/transform.h"

namespace tritrace {

Scene transformed(const Scene& scene, const Similarity& xf) {
  Scene out;
  const TriangleMesh& m = scene.mesh;
  for (size_t i = 0; i < m.size(); ++i) {
    out.mesh.add(xf.apply(m.v0()[i]), xf.apply(m.v1()[i]), xf.apply(m.v2()[i]), m.material()[i]);
  }
  // Instances keep their prototypes; the similarity is composed into each placement.
  out.prototypes = scene.prototypes;
  for (const Instance& inst : scene.instances) {
    Affine a = inst.to_world;
    a.linear *= xf.scale;
    a.translation = xf.apply(a.translation);
    add_instance(out, inst.prototype, a);
  }
  out.materials = scene.materials;
  for (const PointLight& light : scene.lights) {
    out.lights.push_back({xf.apply(light.position), light.power * (xf.scale * xf.scale)});
  }
  out.ambient = scene.ambient;
  out.camera = scene.camera.with_position(xf.apply(scene.camera.position()));
  return out;
}

}  // namespace tritrace
