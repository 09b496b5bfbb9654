// Scene: everything a render reads, built once and then read-only: triangles, materials, point,
// spot and directional lights, the constant indirect (ambient) term, the environment, textures and
// the camera, plus instanced meshes.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/image/texture.h"
#include "tritrace/scene/camera.h"

namespace tritrace {

// What a surface does with light (render/material/bsdf.h builds its BSDF from this). The lab
// integrator reads only `albedo` (and shades every type as diffuse, with the lab's one-sided rule).
enum class MaterialType : uint8_t {
  kDiffuse,    // two-sided Lambert, reflectance `albedo`
  kConductor,  // metal: GGX microfacets (a mirror at roughness 0), Schlick Fresnel from F0 = albedo
               // or the exact Fresnel of a complex index (conductor_eta, conductor_k)
  kDielectric,  // glass: GGX reflection and refraction with exact Fresnel, index `ior` inside
  kPrincipled,  // glTF metallic-roughness: conductor, glass and coated diffuse mixed by weights
};

// One of Scene::textures, looked up through the mesh's texture coordinates with these wrap modes
// (a glTF sampler's; repeat by default). `texcoord` picks the coordinate set (glTF's TEXCOORD_0 or
// TEXCOORD_1), and `transform` moves the coordinates before the lookup: uv' = (m[0] u + m[2] v +
// m[4], m[1] u + m[3] v + m[5]) in tritrace's (OpenGL's, v up) convention, KHR_texture_transform's
// matrix carried over from glTF's (v down) convention by the importer; the identity by default.
struct TextureRef {
  int32_t index = -1;  // none
  WrapMode wrap_s = WrapMode::kRepeat;
  WrapMode wrap_t = WrapMode::kRepeat;
  uint8_t texcoord = 0;
  float transform[6] = {1.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f};
  bool present() const { return index >= 0; }
  bool moves() const {
    return transform[0] != 1.0f || transform[1] != 0.0f || transform[2] != 0.0f ||
           transform[3] != 1.0f || transform[4] != 0.0f || transform[5] != 0.0f;
  }
  glm::vec2 apply(glm::vec2 uv) const {
    return {transform[0] * uv.x + transform[2] * uv.y + transform[4],
            transform[1] * uv.x + transform[3] * uv.y + transform[5]};
  }
};

// How a material's alpha (Material::alpha times its base colour texture's alpha) hides parts of its
// surface, as glTF's alphaMode: kOpaque ignores alpha; kMask is a cut-out, transparent where alpha
// < alpha_cutoff; kBlend is stochastic transparency, each ray passing with probability 1 - alpha
// (accel/alpha_tested_accel.h). Rays of every kind pass through the transparent parts.
enum class AlphaMode : uint8_t { kOpaque, kMask, kBlend };

// A surface material that may also emit light.
struct Material {
  glm::vec3 albedo{0.75f};  // diffuse reflectance rho (or F0, or transmission tint), linear RGB
  // Emitted radiance Le (linear RGB, W/(m^2 sr) per channel), from the triangle's front (the side
  // its lab normal, normalize(cross(e2, e1)), points to), or from both sides when two_sided.
  glm::vec3 emission{0.0f};
  bool two_sided = false;
  MaterialType type = MaterialType::kDiffuse;
  // Perceptual roughness in [0, 1]; the GGX width is alpha = roughness^2 (glTF's and Blender's
  // convention). Below kSmoothAlpha the surface is treated as perfectly smooth (a delta lobe).
  float roughness = 0.0f;
  // Index of refraction of the material's inside (the side opposite its lab normal) relative to
  // the outside; dielectric and principled only. See ior_supported.
  float ior = 1.5f;
  float metallic = 0.0f;      // principled only: the conductor's weight
  float transmission = 0.0f;  // principled only: the glass lobe's share of the non-metal weight
  // Conductor only: the metal's complex index of refraction n + i k per channel (relative to the
  // outside). When conductor_eta.x > 0 the exact conductor Fresnel of this index replaces Schlick's
  // from `albedo`.
  glm::vec3 conductor_eta{0.0f};
  glm::vec3 conductor_k{0.0f};
  // Multiply albedo and emission where present (glTF's baseColorTexture times baseColorFactor,
  // emissiveTexture times emissiveFactor). The lab integrator ignores them.
  TextureRef albedo_texture{};
  TextureRef emission_texture{};
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  float alpha = 1.0f;         // glTF's base colour factor's alpha, in [0, 1]
  float alpha_cutoff = 0.5f;  // kMask only
  // glTF's data textures (linear, not sRGB), each scaling a parameter where present (principled
  // only): metallic times the texture's blue channel and roughness times its green
  // (metallicRoughnessTexture), transmission times its red (KHR_materials_transmission).
  TextureRef metallic_roughness_texture{};
  TextureRef transmission_texture{};
  // A tangent-space normal map (glTF's normalTexture, +y up in the image as OpenGL's): texel t
  // gives the normal (2 t - 1) with x and y times `normal_scale`, in the frame of the mesh's
  // tangent, bitangent and shading normal (shading_normal.h).
  TextureRef normal_texture{};
  float normal_scale = 1.0f;

  // Every texture reference, for code that renumbers or checks them all.
  std::array<TextureRef*, 5> texture_refs() {
    return {&albedo_texture, &emission_texture, &metallic_roughness_texture, &transmission_texture,
            &normal_texture};
  }
  std::array<const TextureRef*, 5> texture_refs() const {
    return {&albedo_texture, &emission_texture, &metallic_roughness_texture, &transmission_texture,
            &normal_texture};
  }
  // Whether a texture changes the BSDF's parameters (not only its albedo).
  bool has_parameter_textures() const {
    return metallic_roughness_texture.present() || transmission_texture.present();
  }

  bool emits() const { return emission.x > 0.0f || emission.y > 0.0f || emission.z > 0.0f; }
  bool is_diffuse() const { return type == MaterialType::kDiffuse; }
  bool has_complex_ior() const { return conductor_eta.x > 0.0f; }
};

// Whether the BSDFs handle a relative index of refraction: exactly 1 (an invisible interface, a
// delta lobe whatever the roughness), or at least kMinIorOffset away from 1. In between, a rough
// interface's refraction half vector wo + eta wi (Walter et al. 2007, eq. 16) is a difference of
// nearly equal floats: measured, sampling loses up to half the transmitted light at 1 + 2^-23 and
// is exact to 0.1% from 1 +- 1e-5 on; the bound keeps a factor 10 from that.
inline constexpr float kMinIorOffset = 1e-4f;
inline bool ior_supported(float ior) {
  return ior == 1.0f || std::abs(ior - 1.0f) >= kMinIorOffset;
}

// Radiates intensity power / (4 pi) in every direction (the lab's light).
struct PointLight {
  glm::vec3 position{0.0f};
  glm::vec3 power{0.0f};  // P, radiant power per channel
};

// How a spot light's intensity falls off between its inner and outer cone, as a function of the
// cosine c of the angle from its axis (both are 1 inside the inner cone and 0 outside the outer):
//   kGltf:       t^2 with t = clamp((c - cos_outer) / (cos_inner - cos_outer), 0, 1), the
//                KHR_lights_punctual specification's recommended falloff (its lightAngleScale and
//                lightAngleOffset form, squared);
//   kSmoothstep: 3 t^2 - 2 t^3 with the same t, pbrt-v4's SpotLight (SmoothStep of the cosine).
enum class SpotFalloff : uint8_t { kGltf, kSmoothstep };

// A point light that shines into a cone: intensity I(w) = intensity * falloff(dot(direction, w))
// towards unit direction w (W/sr per channel).
struct SpotLight {
  glm::vec3 position{0.0f};
  glm::vec3 direction{0.0f, 0.0f, 1.0f};  // the cone's axis, unit length
  glm::vec3 intensity{0.0f};              // I on the axis, W/sr
  float cos_inner = 1.0f;                 // full intensity for cosines >= cos_inner
  float cos_outer = 0.0f;                 // dark for cosines <= cos_outer (< cos_inner)
  SpotFalloff falloff = SpotFalloff::kGltf;
};

// The factor of a spot light's axis intensity in the direction whose cosine to the axis is
// `cos_theta` (SpotFalloff).
inline float spot_falloff(const SpotLight& l, float cos_theta) {
  if (cos_theta >= l.cos_inner) return 1.0f;
  if (cos_theta <= l.cos_outer) return 0.0f;
  const float t = (cos_theta - l.cos_outer) / (l.cos_inner - l.cos_outer);
  return l.falloff == SpotFalloff::kGltf ? t * t : t * t * (3.0f - 2.0f * t);
}

// The power a spot light emits, by channel: I 2 pi (1 - cos_inner + k (cos_inner - cos_outer)),
// the integral of its intensity over the sphere, where k = 1/3 for the glTF falloff (the integral
// of t^2 over t in [0, 1]) and 1/2 for smoothstep (of 3 t^2 - 2 t^3).
inline glm::vec3 spot_light_power(const SpotLight& l) {
  const float k = l.falloff == SpotFalloff::kGltf ? 1.0f / 3.0f : 0.5f;
  return l.intensity * (2.0f * std::numbers::pi_v<float> *
                        ((1.0f - l.cos_inner) + k * (l.cos_inner - l.cos_outer)));
}

// Parallel light from infinitely far away (the sun): `irradiance` E (W/m^2 per channel) on a
// surface facing it, E cos(theta) on one tilted by theta.
struct DirectionalLight {
  glm::vec3 direction{0.0f, 0.0f, 1.0f};  // the way the light travels, unit length
  glm::vec3 irradiance{0.0f};
};

// A directional light's power as seen by a scene inside a sphere of radius `radius`: E pi r^2, the
// flux through the sphere's cross-section (pbrt-v4's DistantLight::Phi does the same).
inline glm::vec3 directional_light_power(const DirectionalLight& l, float radius) {
  return l.irradiance * (std::numbers::pi_v<float> * radius * radius);
}

// The weight the light samplers (the path tracer's, and bdpt's for light subpaths) give a
// directional light: the mean over channels of its power through the scene's bounding sphere, or
// of E where that is not a positive finite number (a scene of no extent, or one too large for a
// float's r^2): any positive weight is unbiased. 0 for a light that emits nothing.
inline float directional_light_weight(const DirectionalLight& l, float radius) {
  const auto mean = [](glm::vec3 c) { return (c.x + c.y + c.z) / 3.0f; };
  float p = mean(directional_light_power(l, radius));
  if (!(p > 0.0f) || !std::isfinite(p)) p = mean(l.irradiance);
  return p > 0.0f && std::isfinite(p) ? p : 0.0f;
}

// p -> linear * p + translation. Points and directions are moved with the same operations
// everywhere (flattening, shading, rays into object space), so that they round alike.
struct Affine {
  glm::mat3 linear{1.0f};  // columns, as glm stores them
  glm::vec3 translation{0.0f};

  glm::vec3 apply_vector(glm::vec3 v) const {
    const glm::mat3& m = linear;
    return {m[0][0] * v.x + m[1][0] * v.y + m[2][0] * v.z,
            m[0][1] * v.x + m[1][1] * v.y + m[2][1] * v.z,
            m[0][2] * v.x + m[1][2] * v.y + m[2][2] * v.z};
  }
  glm::vec3 apply(glm::vec3 p) const { return apply_vector(p) + translation; }
};

// The inverse transform (linear part inverted in double precision, then rounded). `a` must be
// invertible with a finite inverse.
Affine inverse(const Affine& a);

// One placement of a prototype mesh: drawn as if its vertices were to_world.apply(v). Rays are
// moved into object space with to_object (the direction is not renormalised, so a hit's t is the
// same in both spaces).
struct Instance {
  uint32_t prototype = 0;  // into Scene::prototypes
  Affine to_world;
  Affine to_object;  // inverse(to_world)
  // The instance's triangle k is the scene's triangle first_prim + k (Scene::triangle).
  uint32_t first_prim = 0;

  // A unit normal of the prototype in world space: the inverse transpose of to_world's linear
  // part (to_object's, transposed) applied, then normalised.
  glm::vec3 normal_to_world(glm::vec3 n) const {
    const glm::mat3& m = to_object.linear;
    const glm::vec3 w{m[0][0] * n.x + m[0][1] * n.y + m[0][2] * n.z,
                      m[1][0] * n.x + m[1][1] * n.y + m[1][2] * n.z,
                      m[2][0] * n.x + m[2][1] * n.y + m[2][2] * n.z};
    return w / std::sqrt(w.x * w.x + w.y * w.y + w.z * w.z);
  }
};

// A triangle as drawn, in world space: what shading needs from a hit. For a triangle of
// Scene::mesh the stored values; for an instanced one they are computed as TriangleMesh::add
// would from its world vertices, so an instance shades bit for bit like its flattened copy. The
// normal normalize(cross(e2, e1)) of the world edges equals det(L) L^-T n for the object normal n
// and linear part L (cross(La, Lb) = det(L) L^-T (a x b)): the inverse transpose, flipped by a
// mirroring transform, so the "front" stays the side the vertex order makes front.
struct SurfaceTriangle {
  glm::vec3 v0, e1, e2, normal;
  uint32_t material = 0;
};

// Triangle `prim` of `mesh`, as stored.
inline SurfaceTriangle stored_triangle(const TriangleMesh& mesh, uint32_t prim) {
  return {mesh.v0()[prim], mesh.e1(prim), mesh.e2(prim), mesh.normal()[prim],
          mesh.material()[prim]};
}

// A smooth-shaded triangle's corners in world space: vertices and unit vertex normals.
struct SmoothCorners {
  glm::vec3 vertex[3];
  glm::vec3 normal[3];
};

// Triangle `prim` of `mesh` (which has vertex normals), as stored.
inline SmoothCorners stored_corners(const TriangleMesh& mesh, uint32_t prim) {
  SmoothCorners c;
  for (int k = 0; k < 3; ++k) {
    c.vertex[k] = mesh.vertex(prim, k);
    c.normal[k] = mesh.corner_normals()[3 * size_t{prim} + static_cast<size_t>(k)];
  }
  return c;
}

// The most triangles a scene may draw (instances counted once per placement): a hit names its
// triangle with 32 bits, and kNoHit is taken.
inline constexpr uint64_t kMaxDrawnTriangles = 0xFFFFFFFEull;

// An equirectangular (latitude-longitude) radiance map lighting the scene from infinitely far away
// (render/environment_light.h samples it). Row 0 looks up (-y, the lab's world is y-down), the last
// row down (+y); column u = (x + 0.5) / width runs over azimuth phi = 2 pi (u - 1/2) measured from
// +z towards +x, so the map's centre column faces +z (where the default camera looks) and u = 0
// faces -z. `rotate_degrees` turns the map about the up axis, carrying what the centre column
// shows from +z towards +x. Radiance is texel * scale (nearest texel: piecewise constant).
struct EnvironmentMap {
  int width = 0;
  int height = 0;
  std::vector<glm::vec3> texels;  // row-major, row 0 first, linear RGB
  float scale = 1.0f;
  float rotate_degrees = 0.0f;
  std::string path;  // where it was read from, for messages
};

struct Scene {
  // The triangles placed once, in world space. The scene's triangle numbering (Hit::prim) starts
  // with these, then each instance's triangles in instance order: the order of the flattened
  // scene (flattened() below).
  TriangleMesh mesh;
  // Meshes placed by instances only; their material ids index `materials`.
  std::vector<TriangleMesh> prototypes;
  std::vector<Instance> instances;
  std::vector<Material> materials;
  // Point lights (the lab's kind, which every integrator shades) apart from the other delta
  // lights, which only the path tracer shades: the lab and bdpt integrators refuse scenes that
  // have them (lab_unsupported, bdpt_unsupported).
  std::vector<PointLight> lights;
  std::vector<SpotLight> spot_lights;
  std::vector<DirectionalLight> directional_lights;
  glm::vec3 ambient{0.0f};  // the lab's constant indirect light N
  // Radiance arriving from every direction that no surface blocks (the path integrator's constant
  // environment light; the lab integrator ignores it).
  glm::vec3 environment{0.0f};
  // When set, replaces `environment`: radiance from a map, importance-sampled as a light.
  std::shared_ptr<const EnvironmentMap> environment_map;
  std::vector<Texture> textures;  // shared by the materials that refer to them
  Camera camera;

  bool has_instances() const { return !instances.empty(); }
  // Whether the scene has a light of any kind other than emissive triangles and the environment.
  bool has_delta_lights() const {
    return !lights.empty() || !spot_lights.empty() || !directional_lights.empty();
  }
  // Triangles drawn: the mesh's plus each instance's prototype's.
  uint64_t drawn_triangles() const;
  // Triangles stored: the mesh's plus each prototype's once.
  uint64_t stored_triangles() const;
  // Which instance draws triangle `prim` (prim >= mesh.size()).
  const Instance& instance_of(uint32_t prim) const;
  // Triangle `prim` of the scene's numbering, in world space.
  SurfaceTriangle triangle(uint32_t prim) const {
    if (prim < mesh.size()) return stored_triangle(mesh, prim);
    return instanced_triangle(prim);
  }
  uint32_t material_of(uint32_t prim) const {
    return prim < mesh.size() ? mesh.material()[prim] : instanced_triangle(prim).material;
  }
  // Whether triangle `prim` shades smooth: its mesh (or prototype) has vertex normals.
  bool smooth(uint32_t prim) const {
    return prim < mesh.size() ? mesh.has_shading_normals() : instanced_smooth(prim);
  }
  // Triangle `prim`'s corners in world space with their unit vertex normals (smooth(prim) only):
  // an instance's normals moved by its transform's inverse transpose and normalised, as flattened()
  // stores them.
  SmoothCorners corners(uint32_t prim) const {
    if (prim < mesh.size()) return stored_corners(mesh, prim);
    return instanced_corners(prim);
  }
  // Texture coordinates at barycentrics (u, v) of triangle `prim` ((0, 0) without any).
  glm::vec2 uv(uint32_t prim, float u, float v) const {
    return prim < mesh.size() ? mesh.uv(prim, u, v) : instanced_uv(prim, u, v);
  }
  // Coordinates of set `set` (0 or 1, glTF's TEXCOORD_n).
  glm::vec2 uv(uint32_t prim, float u, float v, int set) const {
    if (set == 0) return uv(prim, u, v);
    const TriangleMesh& m = prim < mesh.size() ? mesh : prototypes[instance_of(prim).prototype];
    return m.uv1(prim < mesh.size() ? prim : prim - instance_of(prim).first_prim, u, v);
  }
  // The vertex colour (glTF's COLOR_0, RGBA) at barycentrics (u, v); white without any.
  glm::vec4 vertex_colour(uint32_t prim, float u, float v) const {
    if (prim < mesh.size()) return mesh.colour(prim, u, v);
    const Instance& inst = instance_of(prim);
    return prototypes[inst.prototype].colour(prim - inst.first_prim, u, v);
  }
  // The tangent at barycentrics (u, v) in world space, unnormalised, with the bitangent's sign in
  // w (TriangleMesh::tangent); zero where the mesh has none.
  glm::vec4 tangent(uint32_t prim, float u, float v) const;
  // corners(prim) for any triangle: a flat one gets its geometric normal at each corner.
  SmoothCorners any_corners(uint32_t prim) const;

 private:
  SurfaceTriangle instanced_triangle(uint32_t prim) const;
  bool instanced_smooth(uint32_t prim) const;
  SmoothCorners instanced_corners(uint32_t prim) const;
  glm::vec2 instanced_uv(uint32_t prim, float u, float v) const;
};

// Appends an instance of prototype `prototype` placed by `to_world`, numbering its triangles after
// the ones before it. Throws Error("instances", ...) when the scene would draw more than
// kMaxDrawnTriangles or `to_world` is not invertible.
void add_instance(Scene& scene, uint32_t prototype, const Affine& to_world);

// The world box of an instance: its prototype's box (`prototype_bounds`, computed once per
// prototype by the caller: a box costs a pass over the mesh) with the eight corners moved to
// world space.
Bounds3 instance_bounds(const Bounds3& prototype_bounds, const Instance& instance);
// The box of everything the scene draws.
Bounds3 scene_bounds(const Scene& scene);

// The same scene with every instance copied into `mesh` (in the scene's triangle numbering), its
// vertices moved by to_world.apply, its vertex normals by Instance::normal_to_world, its texture
// coordinates kept: the oracle that instanced rendering is tested against. (Where the prototypes
// have vertex normals and the scene's own mesh has none, the flattened mesh gives its own
// triangles their face normals at the corners, and shades them smooth.)
Scene flattened(const Scene& scene);
// Whether `material` hides any part of its surface: a mask or blend mode with an alpha factor
// below 1 or a base colour texture with an alpha channel (alpha_tested_accel.h tests its hits).
bool alpha_tested(const Scene& scene, const Material& material);
// Whether any material of `scene` is alpha_tested.
bool has_alpha_tested_materials(const Scene& scene);
// The alpha of `material` at barycentrics (u, v) of triangle `prim`: Material::alpha times the
// base colour texture's alpha there, in that texture's coordinate set and transform, as the colour
// is looked up (1 for a texture without an alpha channel).
float material_alpha(const Scene& scene, const Material& material, uint32_t prim, float u, float v);

// `factor` times the texture `ref` at texture coordinates uv, or `factor` alone without a texture.
// `uv` is of the reference's coordinate set and not yet moved by its transform.
inline glm::vec3 textured(const Scene& scene, const TextureRef& ref, glm::vec3 factor,
                          glm::vec2 uv) {
  if (!ref.present()) return factor;
  if (ref.moves()) uv = ref.apply(uv);
  return factor * scene.textures[static_cast<size_t>(ref.index)].lookup(uv, ref.wrap_s, ref.wrap_t);
}

// The same at barycentrics (u, v) of triangle `prim`, in the reference's coordinate set.
inline glm::vec3 textured(const Scene& scene, const TextureRef& ref, glm::vec3 factor,
                          uint32_t prim, float u, float v) {
  if (!ref.present()) return factor;
  return textured(scene, ref, factor, scene.uv(prim, u, v, ref.texcoord));
}

// The reflectance a surface shades with at barycentrics (u, v) of `prim`: the material's albedo
// times its base colour texture times the vertex colour (glTF: baseColorFactor *
// baseColorTexture * COLOR_0).
inline glm::vec3 surface_albedo(const Scene& scene, const Material& m, uint32_t prim, float u,
                                float v) {
  glm::vec3 albedo = textured(scene, m.albedo_texture, m.albedo, prim, u, v);
  if (prim >= scene.mesh.size() || scene.mesh.has_colours()) {
    albedo *= glm::vec3(scene.vertex_colour(prim, u, v));
  }
  return albedo;
}

// The material at barycentrics (u, v) of `prim` with its parameter textures applied (metallic,
// roughness, transmission); `m` itself for a material without them.
Material material_at(const Scene& scene, const Material& m, uint32_t prim, float u, float v);

}  // namespace tritrace
