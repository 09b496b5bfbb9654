// render_identity: a 64-bit hash over the settings text, the build and every array of the scene
// that a pixel reads (own mesh, instanced prototypes with their normals and UVs, placements,
// materials, textures, lights, environment, camera).
#include "tritrace/distributed/render_identity.h"

#include <charconv>
#include <cstdio>
#include <cstring>
#include <vector>

#include "tritrace/accel/make_accel.h"
#include "tritrace/build_info.h"
#include "tritrace/math/random.h"
#include "tritrace/render/make_integrator.h"

namespace tritrace {
namespace {

// A 64-bit hash of bytes, eight at a time through hash_combine (math/random.h), with the length
// absorbed last so that trailing zeros count.
class Hasher {
 public:
  void add(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
      uint64_t w;
      std::memcpy(&w, p + i, 8);
      h_ = hash_combine(h_, w);
    }
    uint64_t tail = 0;
    // Not for n - i == 0: an empty vector's data() may be null, which memcpy must not be given.
    if (n > i) std::memcpy(&tail, p + i, n - i);
    h_ = hash_combine(hash_combine(h_, tail), n);
  }
  template <typename T>
  void add_vector(const T& v) {  // any contiguous container
    add(v.data(), v.size() * sizeof(v[0]));
  }
  void add_value(const auto& v) { add(&v, sizeof v); }
  void add_text(std::string_view s) { add(s.data(), s.size()); }
  uint64_t value() const { return h_; }

 private:
  uint64_t h_ = 0x74726974726163ull;
};

std::string hex(uint64_t v) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(v));
  return text;
}

// Every array of a mesh that a hit or its shading reads.
void add_mesh(Hasher& h, const TriangleMesh& m) {
  h.add_vector(m.v0());
  h.add_vector(m.v1());
  h.add_vector(m.v2());
  h.add_vector(m.material());
  h.add_vector(m.corner_normals());
  h.add_vector(m.corner_uvs());
  // glTF's extra corner attributes only where present, so that other meshes' identities stay.
  if (m.has_tangents() || m.has_colours() || !m.corner_uvs1().empty()) {
    h.add_vector(m.corner_tangents());
    h.add_vector(m.corner_colours());
    h.add_vector(m.corner_uvs1());
  }
}

// A texture reference's coordinate set and transform, only where they are not the defaults.
void add_texture_ref(Hasher& h, const TextureRef& r) {
  h.add_value(r.index);
  h.add_value(static_cast<uint8_t>(r.wrap_s));
  h.add_value(static_cast<uint8_t>(r.wrap_t));
  if (r.texcoord != 0 || r.moves()) {
    h.add_value(r.texcoord);
    for (float f : r.transform) h.add_value(f);
  }
}

void add_affine(Hasher& h, const Affine& a) {
  for (int c = 0; c < 3; ++c) h.add_value(a.linear[c]);
  h.add_value(a.translation);
}

std::vector<std::string_view> words(std::string_view text) {
  std::vector<std::string_view> out;
  while (!text.empty()) {
    const size_t space = text.find(' ');
    if (space != 0) out.push_back(text.substr(0, space));
    if (space == std::string_view::npos) break;
    text.remove_prefix(space + 1);
  }
  return out;
}

// The words of `a` that `b` lacks ("spp=20 seed=3"), or all of `a` when none differ alone.
std::string words_not_in(std::string_view a, std::string_view b) {
  const std::vector<std::string_view> wb = words(b);
  std::string out;
  for (std::string_view w : words(a)) {
    if (std::find(wb.begin(), wb.end(), w) != wb.end()) continue;
    if (!out.empty()) out += ' ';
    out += w;
  }
  return out.empty() ? std::string(a) : out;
}

// The shortest text that reads back as exactly `v`.
std::string shortest(float v) {
  char text[32];
  const auto [end, ec] = std::to_chars(text, text + sizeof text, v);
  return ec == std::errc() ? std::string(text, end) : std::string("?");
}

}  // namespace

std::string hit_rule(std::string_view accel, std::string_view kernel) {
  const std::optional<AccelKind> kind = parse_accel(accel);
  const bool ours = kind && (*kind == AccelKind::kBrute || *kind == AccelKind::kBvh ||
                             *kind == AccelKind::kBvhSingle);
  return ours ? std::string(kernel) : std::string(accel);
}

std::string aov_list(const AovSet& a) {
  std::string s;
  for (auto [on, name] :
       {std::pair{a.albedo, "albedo"}, std::pair{a.normal, "normal"}, std::pair{a.depth, "depth"},
        std::pair{a.variance, "variance"}, std::pair{a.spp, "spp"}}) {
    if (!on) continue;
    if (!s.empty()) s += ",";
    s += name;
  }
  return s;
}

RenderIdentity render_identity(const Scene& scene, const IntegratorSpec& spec,
                               const RenderOptions& options, std::string_view accel,
                               std::string_view kernel, const AovSet& aovs) {
  RenderIdentity id;
  const bool path = spec.kind != IntegratorSpec::Kind::kLab;  // path or bdpt
  id.integrator = std::string(integrator_name(spec.kind));
  id.seed = path ? options.seed : 0;
  id.spp = path ? options.spp : 1;
  id.width = scene.camera.width();
  id.height = scene.camera.height();
  id.aovs = aovs;
  id.build = build_text();
  id.settings = "integrator=" + id.integrator;
  if (path) {
    id.settings += " spp=" + std::to_string(id.spp) +
                   " max_depth=" + std::to_string(spec.max_depth) +
                   " seed=" + std::to_string(id.seed) +
                   " sampler=" + std::string(sampler_name(options.sampler)) +
                   " filter=" + std::string(filter_name(options.filter));
    // Only when on, so that the settings text (and the hash) of unclamped renders is as before.
    if (spec.clamp > 0.0f) id.settings += " clamp=" + shortest(spec.clamp);
    // bdpt's share of samples with a light subpath: only when below 1, as for clamp.
    // With auto, the pilot's choice is a function of the scene, the seed and the sampler, which
    // the identity holds already: every part chooses the same share.
    if (spec.kind == IntegratorSpec::Kind::kBdpt && spec.light_paths_auto) {
      id.settings += " light_paths=auto";
    } else if (spec.kind == IntegratorSpec::Kind::kBdpt && spec.light_paths < 1.0f) {
      id.settings += " light_paths=" + shortest(spec.light_paths);
    }
    // Adaptive sampling changes which samples each pixel takes; absent when off, so that the
    // identities of uniform renders stay what they were.
    if (options.noise_threshold > 0.0f) {
      char threshold[32];
      std::snprintf(threshold, sizeof threshold, "%.7g",
                    static_cast<double>(options.noise_threshold));
      id.settings += " noise_threshold=" + std::string(threshold);
    }
  }
  id.settings += " kernel=" + hit_rule(accel, kernel) + " size=" + std::to_string(id.width) + "x" +
                 std::to_string(id.height);

  Hasher h;
  h.add_text(id.settings);
  h.add_text(id.build);
  add_mesh(h, scene.mesh);
  for (const TriangleMesh& p : scene.prototypes) add_mesh(h, p);
  for (const Instance& inst : scene.instances) {
    h.add_value(inst.prototype);
    add_affine(h, inst.to_world);
    add_affine(h, inst.to_object);
    h.add_value(inst.first_prim);
  }
  for (const Texture& t : scene.textures) {
    h.add_value(t.width());
    h.add_value(t.height());
    h.add_vector(t.texels());
    // Alpha channels only where present, so that other scenes' identities stay as they were.
    if (t.has_alpha()) h.add_vector(t.alpha_texels());
    // A procedural checkerboard's definition (its one texel is only the mean of its colours).
    if (const auto& c = t.checker()) {
      h.add_value(c->scale);
      h.add_value(c->delta);
      h.add_value(c->even);
      h.add_value(c->odd);
    }
  }
  for (const Material& mat : scene.materials) {
    h.add_value(mat.albedo);
    h.add_value(mat.emission);
    h.add_value(static_cast<uint8_t>(mat.two_sided));
    h.add_value(static_cast<uint8_t>(mat.type));
    h.add_value(mat.roughness);
    h.add_value(mat.ior);
    h.add_value(mat.metallic);
    h.add_value(mat.transmission);
    h.add_value(mat.conductor_eta);
    h.add_value(mat.conductor_k);
    add_texture_ref(h, mat.albedo_texture);
    add_texture_ref(h, mat.emission_texture);
    // glTF's data textures only where present.
    for (const TextureRef* r :
         {&mat.metallic_roughness_texture, &mat.transmission_texture, &mat.normal_texture}) {
      if (r->present()) add_texture_ref(h, *r);
    }
    if (mat.alpha_mode != AlphaMode::kOpaque) {  // likewise only where a material has one
      h.add_value(static_cast<uint8_t>(mat.alpha_mode));
      h.add_value(mat.alpha);
      h.add_value(mat.alpha_cutoff);
    }
    if (mat.normal_texture.present()) h.add_value(mat.normal_scale);
  }
  for (const PointLight& l : scene.lights) {
    h.add_value(l.position);
    h.add_value(l.power);
  }
  // Only where present, so that the identities of scenes without them stay as they were; each
  // list after its length, so that one kind's values cannot pass for the other's.
  if (!scene.spot_lights.empty()) h.add_value(static_cast<uint64_t>(scene.spot_lights.size()));
  for (const SpotLight& l : scene.spot_lights) {
    h.add_value(l.position);
    h.add_value(l.direction);
    h.add_value(l.intensity);
    h.add_value(l.cos_inner);
    h.add_value(l.cos_outer);
    h.add_value(static_cast<uint8_t>(l.falloff));
  }
  if (!scene.directional_lights.empty()) {
    h.add_value(static_cast<uint64_t>(scene.directional_lights.size()));
  }
  for (const DirectionalLight& l : scene.directional_lights) {
    h.add_value(l.direction);
    h.add_value(l.irradiance);
  }
  h.add_value(scene.ambient);
  h.add_value(scene.environment);
  if (const EnvironmentMap* env = scene.environment_map.get()) {
    h.add_value(env->width);
    h.add_value(env->height);
    h.add_vector(env->texels);
    h.add_value(env->scale);
    h.add_value(env->rotate_degrees);
  }
  const Camera& c = scene.camera;
  for (glm::vec3 v : {c.position(), c.right(), c.down(), c.forward()}) h.add_value(v);
  h.add_value(c.focal_px());
  // Only when set, so that a pinhole render's identity is what it was before lenses existed.
  if (c.has_lens()) {
    h.add_value(c.lens_radius());
    h.add_value(c.focus_distance());
  }
  if (c.is_orthographic()) h.add_value(c.ortho_scale());
  id.hash = hex(h.value());
  return id;
}

std::string identity_difference(const RenderIdentity& a, const RenderIdentity& b) {
  if (a.build != b.build) {
    return "another build (" + words_not_in(a.build, b.build) + ", not " +
           words_not_in(b.build, a.build) + ")";
  }
  if (a.settings != b.settings) {
    return "other settings (" + words_not_in(a.settings, b.settings) + ", not " +
           words_not_in(b.settings, a.settings) + ")";
  }
  if (a.hash != b.hash) return "another scene (render " + a.hash + ", not " + b.hash + ")";
  if (!(a == b)) return "other AOVs (" + aov_list(a.aovs) + ", not " + aov_list(b.aovs) + ")";
  return {};
}

}  // namespace tritrace
