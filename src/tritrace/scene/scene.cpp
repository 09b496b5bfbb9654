// Instances: their triangle numbering, their world-space triangles and boxes, and flattening;
// per-hit surface attributes (tangents, textured material parameters).
#include "tritrace/scene/scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <string>

#include "tritrace/error.h"

namespace tritrace {

Affine inverse(const Affine& a) {
  // Cofactors in double: the inverse of a float matrix, rounded once per entry.
  double m[3][3];
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) m[r][c] = a.linear[c][r];
  }
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  double inv[3][3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      // inv = adj / det, adj[r][c] = cofactor of m[c][r].
      const int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
      inv[r][c] = (m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]) / det;
    }
  }
  Affine out;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) out.linear[c][r] = static_cast<float>(inv[r][c]);
  }
  for (int r = 0; r < 3; ++r) {
    double t = 0.0;
    for (int c = 0; c < 3; ++c) t -= inv[r][c] * a.translation[c];
    out.translation[r] = static_cast<float>(t);
  }
  return out;
}

uint64_t Scene::drawn_triangles() const {
  uint64_t n = mesh.size();
  for (const Instance& i : instances) n += prototypes[i.prototype].size();
  return n;
}

uint64_t Scene::stored_triangles() const {
  uint64_t n = mesh.size();
  for (const TriangleMesh& p : prototypes) n += p.size();
  return n;
}

const Instance& Scene::instance_of(uint32_t prim) const {
  // The last instance whose first triangle is at or before prim.
  const auto it = std::upper_bound(instances.begin(), instances.end(), prim,
                                   [](uint32_t p, const Instance& i) { return p < i.first_prim; });
  return *(it - 1);
}

SurfaceTriangle Scene::instanced_triangle(uint32_t prim) const {
  const Instance& inst = instance_of(prim);
  const TriangleMesh& proto = prototypes[inst.prototype];
  const uint32_t k = prim - inst.first_prim;
  // TriangleMesh::add's arithmetic on the world vertices, so flattened() stores the same bits.
  const glm::vec3 a = inst.to_world.apply(proto.v0()[k]);
  const glm::vec3 b = inst.to_world.apply(proto.v1()[k]);
  const glm::vec3 c = inst.to_world.apply(proto.v2()[k]);
  SurfaceTriangle t;
  t.v0 = a;
  t.e1 = b - a;
  t.e2 = c - a;
  const glm::vec3 n = glm::cross(t.e2, t.e1);
  const float len = glm::length(n);
  t.normal = len > 0.0f ? n / len : glm::vec3(0.0f);
  t.material = proto.material()[k];
  return t;
}

bool Scene::instanced_smooth(uint32_t prim) const {
  return prototypes[instance_of(prim).prototype].has_shading_normals();
}

SmoothCorners Scene::instanced_corners(uint32_t prim) const {
  const Instance& inst = instance_of(prim);
  const TriangleMesh& proto = prototypes[inst.prototype];
  const uint32_t k = prim - inst.first_prim;
  SmoothCorners c = stored_corners(proto, k);
  for (int j = 0; j < 3; ++j) {
    c.vertex[j] = inst.to_world.apply(c.vertex[j]);
    c.normal[j] = inst.normal_to_world(c.normal[j]);
  }
  return c;
}

glm::vec2 Scene::instanced_uv(uint32_t prim, float u, float v) const {
  const Instance& inst = instance_of(prim);
  return prototypes[inst.prototype].uv(prim - inst.first_prim, u, v);
}

glm::vec4 Scene::tangent(uint32_t prim, float u, float v) const {
  if (prim < mesh.size()) return mesh.tangent(prim, u, v);
  const Instance& inst = instance_of(prim);
  const glm::vec4 t = prototypes[inst.prototype].tangent(prim - inst.first_prim, u, v);
  // A tangent is a direction along the surface: it moves with the linear part itself. A mirroring
  // transform turns cross(normal, tangent) around, so the bitangent's sign turns with it.
  const float det = glm::determinant(inst.to_world.linear);
  return {inst.to_world.apply_vector(glm::vec3(t)), det < 0.0f ? -t.w : t.w};
}

SmoothCorners Scene::any_corners(uint32_t prim) const {
  if (smooth(prim)) return corners(prim);
  const SurfaceTriangle t = triangle(prim);
  SmoothCorners c;
  c.vertex[0] = t.v0;
  c.vertex[1] = t.v0 + t.e1;
  c.vertex[2] = t.v0 + t.e2;
  for (glm::vec3& n : c.normal) n = t.normal;
  return c;
}

Material material_at(const Scene& scene, const Material& m, uint32_t prim, float u, float v) {
  if (!m.has_parameter_textures()) return m;
  Material out = m;
  if (m.metallic_roughness_texture.present()) {
    // glTF 2.0, section 3.9.2: roughness in the green channel, metalness in the blue.
    const glm::vec3 t = textured(scene, m.metallic_roughness_texture, glm::vec3(1.0f), prim, u, v);
    out.roughness = std::clamp(m.roughness * t.y, 0.0f, 1.0f);
    out.metallic = std::clamp(m.metallic * t.z, 0.0f, 1.0f);
  }
  if (m.transmission_texture.present()) {
    const glm::vec3 t = textured(scene, m.transmission_texture, glm::vec3(1.0f), prim, u, v);
    out.transmission = std::clamp(m.transmission * t.x, 0.0f, 1.0f);
  }
  return out;
}

void add_instance(Scene& scene, uint32_t prototype, const Affine& to_world) {
  const uint64_t drawn = scene.drawn_triangles();
  const uint64_t added = scene.prototypes.at(prototype).size();
  if (drawn + added > kMaxDrawnTriangles) {
    throw Error("instances", "the scene would draw more than " +
                                 std::to_string(kMaxDrawnTriangles) + " triangles");
  }
  Instance inst;
  inst.prototype = prototype;
  inst.to_world = to_world;
  inst.to_object = inverse(to_world);
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) {
      if (!std::isfinite(inst.to_object.linear[c][r]) || !std::isfinite(to_world.linear[c][r])) {
        throw Error("instances", "the transform is not invertible");
      }
    }
    if (!std::isfinite(inst.to_object.translation[c]) || !std::isfinite(to_world.translation[c])) {
      throw Error("instances", "the transform is not invertible");
    }
  }
  inst.first_prim = static_cast<uint32_t>(drawn);
  scene.instances.push_back(inst);
}

Bounds3 instance_bounds(const Bounds3& b, const Instance& instance) {
  Bounds3 out = Bounds3::empty();
  for (int corner = 0; corner < 8; ++corner) {
    const glm::vec3 p((corner & 1) ? b.hi.x : b.lo.x, (corner & 2) ? b.hi.y : b.lo.y,
                      (corner & 4) ? b.hi.z : b.lo.z);
    out.extend(instance.to_world.apply(p));
  }
  return out;
}

Bounds3 scene_bounds(const Scene& scene) {
  Bounds3 b = scene.mesh.empty() ? Bounds3::empty() : scene.mesh.bounds();
  std::vector<Bounds3> prototype_bounds;
  for (const TriangleMesh& p : scene.prototypes) prototype_bounds.push_back(p.bounds());
  for (const Instance& i : scene.instances)
    b.extend(instance_bounds(prototype_bounds[i.prototype], i));
  return b.is_empty() ? Bounds3{} : b;
}

Scene flattened(const Scene& scene) {
  Scene out = scene;
  out.prototypes.clear();
  out.instances.clear();
  out.mesh.reserve(scene.drawn_triangles());
  for (const Instance& inst : scene.instances) {
    const TriangleMesh& proto = scene.prototypes[inst.prototype];
    const bool mirrors = glm::determinant(inst.to_world.linear) < 0.0f;
    for (uint32_t k = 0; k < proto.size(); ++k) {
      // Vertex normals as Scene::corners gives them, texture coordinates as they are.
      std::array<glm::vec3, 3> normals;
      std::array<glm::vec2, 3> uvs;
      for (size_t j = 0; j < 3 && proto.has_shading_normals(); ++j) {
        normals[j] = inst.normal_to_world(proto.corner_normals()[3 * size_t{k} + j]);
      }
      for (size_t j = 0; j < 3 && proto.has_uvs(); ++j)
        uvs[j] = proto.corner_uvs()[3 * size_t{k} + j];
      out.mesh.add(inst.to_world.apply(proto.v0()[k]), inst.to_world.apply(proto.v1()[k]),
                   inst.to_world.apply(proto.v2()[k]), proto.material()[k],
                   proto.has_shading_normals() ? &normals : nullptr,
                   proto.has_uvs() ? &uvs : nullptr);
      // glTF's corner attributes as Scene::tangent and Scene::vertex_colour give them.
      glm::vec4 tangents[3], colours[3];
      glm::vec2 uvs1[3];
      for (size_t j = 0; j < 3; ++j) {
        const size_t c = 3 * size_t{k} + j;
        if (proto.has_tangents()) {
          const glm::vec4 t = proto.corner_tangents()[c];
          tangents[j] = {inst.to_world.apply_vector(glm::vec3(t)), mirrors ? -t.w : t.w};
        }
        if (proto.has_colours()) colours[j] = proto.corner_colours()[c];
        if (!proto.corner_uvs1().empty()) uvs1[j] = proto.corner_uvs1()[c];
      }
      if (proto.has_tangents() || proto.has_colours() || !proto.corner_uvs1().empty()) {
        out.mesh.set_extras(out.mesh.size() - 1, proto.has_tangents() ? tangents : nullptr,
                            proto.has_colours() ? colours : nullptr,
                            proto.corner_uvs1().empty() ? nullptr : uvs1);
      }
    }
  }
  return out;
}

}  // namespace tritrace

namespace tritrace {

bool alpha_tested(const Scene& scene, const Material& material) {
  if (material.alpha_mode == AlphaMode::kOpaque) return false;
  const TextureRef& t = material.albedo_texture;
  const bool texture_alpha = t.present() && static_cast<size_t>(t.index) < scene.textures.size() &&
                             scene.textures[static_cast<size_t>(t.index)].has_alpha();
  // A mask whose factor passes the cutoff and that has no alpha texture is opaque everywhere.
  if (!texture_alpha) {
    return material.alpha_mode == AlphaMode::kMask ? material.alpha < material.alpha_cutoff
                                                   : material.alpha < 1.0f;
  }
  return true;
}

bool has_alpha_tested_materials(const Scene& scene) {
  for (const Material& m : scene.materials) {
    if (alpha_tested(scene, m)) return true;
  }
  return false;
}

float material_alpha(const Scene& scene, const Material& material, uint32_t prim, float u,
                     float v) {
  const TextureRef& t = material.albedo_texture;
  if (!t.present()) return material.alpha;
  glm::vec2 uv = scene.uv(prim, u, v, t.texcoord);
  if (t.moves()) uv = t.apply(uv);
  return material.alpha *
         scene.textures[static_cast<size_t>(t.index)].alpha(uv, t.wrap_s, t.wrap_t);
}

}  // namespace tritrace
