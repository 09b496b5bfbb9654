// Scene transformation: rebuilds the mesh from its exact vertices.
#include "tritrace/scene/transform.h"

#include <algorithm>
#include <array>

namespace tritrace {

Scene transformed(const Scene& scene, const Similarity& xf) {
  Scene out;
  const TriangleMesh& m = scene.mesh;
  for (size_t i = 0; i < m.size(); ++i) {
    // A uniform scale and a translation leave normals as they are; texture coordinates stay too.
    std::array<glm::vec3, 3> normals;
    std::array<glm::vec2, 3> uvs;
    if (m.has_shading_normals()) std::copy_n(&m.corner_normals()[3 * i], 3, normals.begin());
    if (m.has_uvs()) std::copy_n(&m.corner_uvs()[3 * i], 3, uvs.begin());
    out.mesh.add(xf.apply(m.v0()[i]), xf.apply(m.v1()[i]), xf.apply(m.v2()[i]), m.material()[i],
                 m.has_shading_normals() ? &normals : nullptr, m.has_uvs() ? &uvs : nullptr);
    // glTF's corner attributes stay too (a positive uniform scale keeps tangent directions).
    const bool uvs1 = !m.corner_uvs1().empty();
    if (m.has_tangents() || m.has_colours() || uvs1) {
      out.mesh.set_extras(i, m.has_tangents() ? &m.corner_tangents()[3 * i] : nullptr,
                          m.has_colours() ? &m.corner_colours()[3 * i] : nullptr,
                          uvs1 ? &m.corner_uvs1()[3 * i] : nullptr);
    }
  }
  // Instances keep their prototypes; the similarity is composed into each placement.
  out.prototypes = scene.prototypes;
  for (const Instance& inst : scene.instances) {
    Affine a = inst.to_world;
    a.linear *= xf.scale;
    a.translation = xf.apply(a.translation);
    add_instance(out, inst.prototype, a);
  }
  out.environment = scene.environment;
  out.environment_map = scene.environment_map;
  out.textures = scene.textures;
  out.materials = scene.materials;
  for (const PointLight& light : scene.lights) {
    out.lights.push_back({xf.apply(light.position), light.power * (xf.scale * xf.scale)});
  }
  // A spot light's intensity scales as a point light's power, keeping the irradiance it gives at
  // the moved points; a directional light's irradiance and every direction stay.
  for (SpotLight light : scene.spot_lights) {
    light.position = xf.apply(light.position);
    light.intensity *= xf.scale * xf.scale;
    out.spot_lights.push_back(light);
  }
  out.directional_lights = scene.directional_lights;
  out.ambient = scene.ambient;
  out.camera = scene.camera.with_position(xf.apply(scene.camera.position()));
  return out;
}

}  // namespace tritrace
