// The bidirectional path tracer, one camera sample at a time: its camera subpath, its light
// subpath, then every connection (s, t) with t >= 2, and with light tracing every (s, 1) with
// s >= 2 splatted onto the pixel it projects to, weighted by the power heuristic. The notation
// (s light vertices, t camera vertices; pdf_fwd / pdf_rev as area densities) is Veach's (1997,
// chapter 10), as pbrt's BDPT chapter also uses it; docs/BDPT.md has the definitions.
#include "tritrace/render/bdpt_integrator.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <glm/geometric.hpp>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/render/light_sampler.h"
#include "tritrace/render/material/bsdf.h"
#include "tritrace/render/shading_normal.h"
#include "tritrace/render/surface_offset.h"

namespace tritrace {
namespace {

float max_component(glm::vec3 c) {
  return std::max({c.x, c.y, c.z});
}

float mean(glm::vec3 c) {
  return (c.x + c.y + c.z) / 3.0f;
}

// kEnvironment: the light at infinity, as a light subpath's first vertex or as the end of a camera
// subpath that escaped; its `w_env` is the direction from the scene towards it.
enum class VertexType : uint8_t { kCamera, kLight, kSurface, kEnvironment };

// One vertex of a subpath. Light vertices are a subpath's first (on a point light or an emissive
// triangle); surface vertices carry the Bsdf of the hit.
struct Vertex {
  VertexType type = VertexType::kSurface;
  bool delta = false;        // scattered by a delta lobe here
  bool point_light = false;  // a light vertex on a point light
  bool connectible = false;  // a surface with a non-delta lobe, or any light vertex
  bool smooth = false;       // shades with interpolated vertex normals
  bool two_sided = false;    // its material emits (or would emit) from both sides
  bool emits = false;
  glm::vec3 p{0.0f};
  glm::vec3 ng{0.0f};     // the triangle's lab normal (zero for the camera and point lights)
  glm::vec3 ns{0.0f};     // the shading normal on ng's side (the Bsdf frame's z)
  glm::vec3 wo{0.0f};     // towards the previous vertex of its subpath (surface vertices)
  glm::vec3 w_env{0.0f};  // an environment vertex's direction, from the scene towards it
  glm::vec3 beta{0.0f};
  glm::vec3 le{0.0f};        // a light vertex's emission (radiance, or a point light's intensity)
  glm::vec3 albedo{0.0f};    // the material's albedo here (textured), for the albedo AOV
  glm::vec3 aov_tint{1.0f};  // the sampled bounce's weight without 1/eta^2 (the AOVs' tint)
  bool specular = false;     // every lobe a delta lobe: the AOVs look through it
  // Ray starts on the front (ng) and back side, computed when first needed (ray_start).
  mutable uint8_t start_known = 0;
  mutable glm::vec3 start[2]{};
  float pdf_fwd = 0.0f;
  float pdf_rev = 0.0f;
  float env_pdf_pos = 0.0f;  // an environment vertex's density per area across w_env
  uint32_t prim = 0;
  float u = 0.0f, v = 0.0f;  // barycentrics on the triangle
  SurfaceTriangle tri{};
  SmoothCorners corners{};
  Frame frame{};
  Bsdf bsdf{Material{}};
  const Material* material = nullptr;
};

bool infinite(const Vertex& x) {
  return x.type == VertexType::kEnvironment;
}

// Whether direction w (world, leaving the vertex) lies on the same side of the shading and the
// geometric surface: where it does not, the vertex carries nothing that way (docs/BDPT.md).
bool agrees(const Vertex& x, glm::vec3 w) {
  return !x.smooth || shading_agrees(w, x.ns, x.ng);
}

// f_s(w_cam, w_light) of Veach 1997, section 5.3: the Bsdf's value with the shading normal's
// cosine moved onto the geometric one, so that the geometry terms use geometric normals.
glm::vec3 surface_f(const Vertex& x, glm::vec3 w_cam, glm::vec3 w_light) {
  if (!agrees(x, w_cam) || !agrees(x, w_light)) return glm::vec3(0.0f);
  const float cos_g = std::abs(glm::dot(x.ng, w_light));
  if (!(cos_g > 0.0f)) return glm::vec3(0.0f);
  const glm::vec3 f = x.bsdf.eval(x.frame.to_local(w_cam), x.frame.to_local(w_light));
  return f * (std::abs(glm::dot(x.ns, w_light)) / cos_g);
}

// The solid-angle density with which a surface vertex samples w_sampled from w_given (both
// subpaths sample with the direction they arrived from as the Bsdf's wo).
float surface_pdf(const Vertex& x, glm::vec3 w_given, glm::vec3 w_sampled) {
  if (!agrees(x, w_given) || !agrees(x, w_sampled)) return 0.0f;
  return x.bsdf.pdf(x.frame.to_local(w_given), x.frame.to_local(w_sampled));
}

// The solid-angle density with which light vertex (or emitting surface) x emits towards w.
float emission_pdf(const Vertex& x, glm::vec3 w) {
  if (x.point_light) return uniform_sphere_pdf();
  const float c = glm::dot(x.ng, w);
  if (x.two_sided) return 0.5f * std::abs(c) * kInvPi;
  return c > 0.0f ? c * kInvPi : 0.0f;
}

// The radiance light vertex (or emitting surface) x sends along w.
glm::vec3 emission(const Scene& scene, const Vertex& x, glm::vec3 w) {
  if (x.point_light || infinite(x)) return x.le;
  glm::vec3 le = emitted_radiance(*x.material, x.ng, w);
  if (x.material->emission_texture.present() && max_component(le) > 0.0f) {
    le = textured(scene, x.material->emission_texture, le, x.prim, x.u, x.v);
  }
  return le;
}

// A solid-angle density at `from` towards `to`, as an area density at `to`. An environment vertex
// keeps solid angle (it has no area); from an environment vertex the density is already per area
// of the plane across the direction, so only `to`'s cosine converts it (pbrt's BDPT chapter does
// the same).
float to_area(float pdf_dir, const Vertex& from, const Vertex& to) {
  if (infinite(to)) return pdf_dir;
  if (infinite(from)) return pdf_dir * std::abs(glm::dot(to.ng, from.w_env));
  const glm::vec3 d = to.p - from.p;
  const float dist2 = glm::dot(d, d);
  if (!(dist2 > 0.0f)) return 0.0f;
  float pdf = pdf_dir / dist2;
  if (to.type != VertexType::kCamera && !to.point_light) {
    pdf *= std::abs(glm::dot(to.ng, d)) / std::sqrt(dist2);
  }
  return pdf;
}

glm::vec3 direction(const Vertex& from, const Vertex& to) {
  if (infinite(to)) return to.w_env;
  if (infinite(from)) return -from.w_env;
  return glm::normalize(to.p - from.p);
}

// The area density with which vertex x, reached from `prev` (null for a light vertex), samples
// `next`.
float pdf_area(const Vertex& x, const Vertex* prev, const Vertex& next) {
  if (infinite(x)) return to_area(x.env_pdf_pos, x, next);
  const glm::vec3 w_next = direction(x, next);
  if (x.type == VertexType::kLight) return to_area(emission_pdf(x, w_next), x, next);
  return to_area(surface_pdf(x, direction(x, *prev), w_next), x, next);
}

// Where a ray from vertex x towards w starts (on the side w leaves to). A vertex takes part in
// many connections: each side's point is computed once and kept.
glm::vec3 ray_start(const Vertex& x, glm::vec3 w, const RayOffsetParams& offset) {
  const bool front = glm::dot(x.ng, w) >= 0.0f;
  const uint8_t bit = front ? 1 : 2;
  glm::vec3& start = x.start[front ? 0 : 1];
  if (!(x.start_known & bit)) {
    const glm::vec3 side = front ? x.ng : -x.ng;
    const glm::vec3 at = x.smooth ? terminator_safe_point(x.corners, x.u, x.v, x.p, side) : x.p;
    start = leave_surface(x.tri, at, side, offset);
    x.start_known |= bit;
  }
  return start;
}

// The pinhole camera's density of choosing direction w (unit, from the camera) with the samples
// of every pixel together: each pixel's samples are uniform over its unit area on the image plane
// at distance f (the focal length in pixels), where dA = f^2 / cos^3(theta) dw, and the film has
// W H pixels, so p(w) = f^2 / (W H cos^3 theta) (Veach 1997, sec. 10.3.4; pbrt's BDPT chapter
// writes the same with the area of the film at distance 1). It is also the importance the light
// image needs: a pixel's measurement has importance f^2 / cos^3(theta) over its own solid angle,
// and the light image divides by W H spp light subpaths (Film's resolve divides by spp). Only the
// cosine is tested (0 behind the camera): the callers know the direction lies inside the film.
float camera_pdf(const Camera& camera, glm::vec3 w) {
  const float c = glm::dot(w, camera.forward());
  if (!(c > 0.0f)) return 0.0f;
  const float f = camera.focal_px();
  return f * f /
         (static_cast<float>(camera.width()) * static_cast<float>(camera.height()) * c * c * c);
}

// Where direction w (unit, from the camera) meets the image, in pixels from its top-left corner
// (Camera::ray_through inverted); false where it misses the film.
bool project(const Camera& camera, glm::vec3 w, int& x, int& y) {
  const float c = glm::dot(w, camera.forward());
  if (!(c > 0.0f)) return false;
  const float f = camera.focal_px();
  const float px = glm::dot(w, camera.right()) / c * f + static_cast<float>(camera.width() / 2);
  const float py = glm::dot(w, camera.down()) / c * f + static_cast<float>(camera.height() / 2);
  if (!(px >= 0.0f && py >= 0.0f && px < static_cast<float>(camera.width()) &&
        py < static_cast<float>(camera.height()))) {
    return false;
  }
  x = std::min(static_cast<int>(px), camera.width() - 1);
  y = std::min(static_cast<int>(py), camera.height() - 1);
  return true;
}

// Per thread: the two subpaths. They grow (doubling) as long subpaths need, up to the depth limit,
// rather than to it at once: --max-depth 65536 would otherwise take tens of megabytes per thread.
inline constexpr size_t kInitialSubpathVertices = 16;
struct Subpaths {
  std::vector<Vertex> camera, light;
};

Subpaths& thread_subpaths() {
  thread_local Subpaths subpaths;
  return subpaths;
}

}  // namespace

// The per-sample work, with the integrator's data at hand.
class BdptTracer {
 public:
  BdptTracer(const BdptIntegrator& integrator, const Scene& scene, const Accel& accel)
      : it_(integrator), scene_(scene), accel_(accel) {}

  // The sample's own pixel's radiance; with light tracing, the (s, 1) connections are added to
  // `splats` (not null then).
  glm::vec3 sample(const Ray& camera_ray, Sampler& sampler, Hit& first_hit, SplatBuffer* splats);
  uint64_t traced() const { return traced_; }
  // The albedo and normal AOVs of the last sample's camera subpath, as the path tracer writes them
  // (path_integrator.cpp): those of the first surface that is not specular, seen through perfect
  // mirrors and smooth glass with their tint; a specular surface's own where the subpath ends
  // there; zero where it escapes.
  void surface_aovs(glm::vec3& albedo, glm::vec3& normal) const;

 private:
  // Fills vertex x from a hit of ray `ray`.
  bool make_surface(Vertex& x, const Ray& ray, const Hit& hit) const;
  // Extends `path` (count vertices, the last the walk starts from) with vertices sampled from
  // `ray`, whose direction has density pdf_dir at the last vertex; beta is the throughput the
  // next vertex receives. `light` selects the adjoint (importance) transport. Returns the count.
  int walk(std::vector<Vertex>& path, int count, int max_vertices, Ray ray, glm::vec3 beta,
           float pdf_dir, bool light, Sampler& sampler, Hit* first_hit);
  // Light subpath: returns its vertex count (0 when the scene has no emitter).
  int light_subpath(std::vector<Vertex>& path, int max_vertices, Sampler& sampler);
  // Whether nothing blocks the segment between camera-side vertex c and light-side vertex l.
  bool visible(const Vertex& c, const Vertex& l);
  // Whether nothing blocks the segment between surface vertex l and the camera at `eye`.
  bool visible_to_camera(const Vertex& l, glm::vec3 eye);
  bool unblocked(glm::vec3 from, glm::vec3 dir, float length);
  // Light tracing: the (s, 1) connections of the light subpath's vertices to the camera.
  void splat_light_subpath(Vertex* light, Vertex* camera, int nl, Sampler& sampler,
                           SplatBuffer& splats);
  float mis_weight(Vertex* light, Vertex* camera, int s, int t) const;

  const BdptIntegrator& it_;
  const Scene& scene_;
  const Accel& accel_;
  uint64_t traced_ = 0;
  int camera_count_ = 0;
  bool camera_escaped_ = false;
};

void BdptTracer::surface_aovs(glm::vec3& albedo, glm::vec3& normal) const {
  albedo = normal = glm::vec3(0.0f);
  const Vertex* camera = thread_subpaths().camera.data();
  glm::vec3 tint(1.0f);
  for (int i = 1; i < camera_count_; ++i) {
    const Vertex& x = camera[i];
    if (infinite(x)) break;
    // The path tracer's AOV normal: the face on the side the subpath arrived from, or the shading
    // normal turned to that side where it agrees with it about wo.
    const glm::vec3 n_face = glm::dot(x.ng, x.wo) >= 0.0f ? x.ng : -x.ng;
    glm::vec3 n = n_face;
    if (x.smooth) {
      const glm::vec3 ns = n_face == x.ng ? x.ns : -x.ns;
      if (shading_agrees(x.wo, ns, n_face)) n = ns;
    }
    albedo = tint * x.albedo;
    normal = n;
    if (!x.specular) return;
    tint *= x.aov_tint;
  }
  // Every surface met was specular: the provisional values stay where the subpath ended at one,
  // and are zero where it escaped.
  if (camera_escaped_) albedo = normal = glm::vec3(0.0f);
}

bool BdptTracer::make_surface(Vertex& x, const Ray& ray, const Hit& hit) const {
  x.type = VertexType::kSurface;
  x.point_light = false;
  x.start_known = 0;
  x.prim = hit.prim;
  x.u = hit.u;
  x.v = hit.v;
  x.tri = scene_.triangle(hit.prim);
  x.material = &scene_.materials[x.tri.material];
  x.p = x.tri.v0 + hit.u * x.tri.e1 + hit.v * x.tri.e2;
  x.ng = x.tri.normal;
  x.smooth = shades_smooth(scene_, *x.material, hit.prim);
  x.ns = x.ng;
  if (x.smooth) {
    x.corners = scene_.any_corners(hit.prim);
    x.ns = surface_normal(scene_, *x.material, hit.prim, x.corners, hit.u, hit.v, x.ng);
  }
  x.frame = Frame::from_normal(x.ns);
  const glm::vec3 albedo = surface_albedo(scene_, *x.material, hit.prim, hit.u, hit.v);
  x.bsdf = x.material->has_parameter_textures()
               ? Bsdf(material_at(scene_, *x.material, hit.prim, hit.u, hit.v), albedo)
               : Bsdf(*x.material, albedo);
  x.albedo = albedo;
  x.connectible = !x.bsdf.all_delta();
  x.specular = !x.material->is_diffuse() && !x.connectible;
  x.two_sided = x.material->two_sided;
  x.emits = x.material->emits();
  x.delta = false;
  x.wo = -glm::normalize(ray.dir);
  return true;
}

int BdptTracer::walk(std::vector<Vertex>& path, int count, int max_vertices, Ray ray,
                     glm::vec3 beta, float pdf_dir, bool light, Sampler& sampler, Hit* first_hit) {
  const int roulette_depth = it_.settings_.roulette_depth;
  glm::vec3 rr_beta(1.0f);  // the throughput since the subpath's start, for Russian roulette
  while (count < max_vertices) {
    // Room for vertex `count` (references into `path` are taken after this only).
    if (static_cast<size_t>(count) >= path.size()) {
      path.resize(std::min(2 * path.size(), static_cast<size_t>(max_vertices)));
    }
    // One ray at a time: the accel's incoherent query (a packet of one would cost a third more).
    Hit hit;
    accel_.intersect_incoherent(std::span<const Ray>(&ray, 1), std::span<Hit>(&hit, 1));
    ++traced_;
    if (first_hit != nullptr) {
      *first_hit = hit;
      first_hit = nullptr;
    }
    if (!hit.found()) {
      if (!light) camera_escaped_ = true;
      // A camera subpath that escapes meets the environment (strategy s = 0).
      if (!light && it_.has_environment_) {
        Vertex& e = path[count];
        e.type = VertexType::kEnvironment;
        e.delta = e.point_light = e.smooth = false;
        e.connectible = false;
        e.emits = true;
        e.w_env = glm::normalize(ray.dir);
        e.le = it_.environment_radiance(e.w_env);
        e.env_pdf_pos = it_.environment_pdf_pos_;
        e.beta = beta;
        e.pdf_fwd = pdf_dir;  // solid angle
        e.pdf_rev = 0.0f;
        ++count;
      }
      break;
    }
    Vertex& prev = path[count - 1];
    Vertex& x = path[count];
    make_surface(x, ray, hit);
    x.beta = beta;
    x.pdf_fwd = to_area(pdf_dir, prev, x);
    x.pdf_rev = 0.0f;
    ++count;
    if (count >= max_vertices) break;

    const auto [u_choice, u_dir] = sampler.get_2d_groups<2>();
    const glm::vec3 w_prev = x.wo;
    if (!agrees(x, w_prev)) break;
    const glm::vec3 wo_local = x.frame.to_local(w_prev);
    const BsdfSample bs = x.bsdf.sample(wo_local, u_choice.x, u_dir);
    if (!bs.valid()) break;
    const glm::vec3 w_next = x.frame.to_world(bs.wi);
    if (!agrees(x, w_next)) break;
    glm::vec3 factor = bs.weight;
    if (light) {
      // The adjoint: f_s(w_next, w_prev) |n_g . w_next| / pdf (Veach 1997, sections 5.2-5.3).
      const float cos_g_prev = std::abs(glm::dot(x.ng, w_prev));
      const float cos_s_next = std::abs(bs.wi.z);
      if (!(cos_g_prev > 0.0f && cos_s_next > 0.0f)) break;
      const float shading =
          std::abs(wo_local.z) * std::abs(glm::dot(x.ng, w_next)) / (cos_g_prev * cos_s_next);
      if (bs.delta) {
        // A delta refraction's weight carries radiance's 1 / eta^2; importance does not.
        factor = bs.weight * (shading / bs.radiance_scale);
      } else {
        factor = x.bsdf.eval(bs.wi, wo_local) * (cos_s_next * shading / bs.pdf);
      }
    }
    x.delta = bs.delta;
    x.aov_tint = bs.weight * (1.0f / bs.radiance_scale);
    const float pdf_rev_dir = bs.delta ? 0.0f : x.bsdf.pdf(bs.wi, wo_local);
    prev.pdf_rev = to_area(pdf_rev_dir, x, prev);
    beta *= factor;
    rr_beta *= factor;
    if (count - 1 >= roulette_depth) {
      const float survive = std::min(1.0f, std::sqrt(max_component(rr_beta)));
      if (!(u_choice.y < survive)) break;
      beta *= 1.0f / survive;
      rr_beta *= 1.0f / survive;
    }
    if (!(max_component(beta) > 0.0f) || !std::isfinite(max_component(beta))) break;
    pdf_dir = bs.delta ? 0.0f : bs.pdf;
    ray.origin = ray_start(x, w_next, it_.offset_);
    ray.dir = w_next;
    ray.tmin = 0.0f;
    ray.tmax = kRayTMax;
  }
  return count;
}

int BdptTracer::light_subpath(std::vector<Vertex>& path, int max_vertices, Sampler& sampler) {
  const auto [u_choice, u_point, u_dir] = sampler.get_2d_groups<3>();
  if (it_.table_.empty() || max_vertices < 1) return 0;
  const AliasTable::Sample pick = it_.table_.sample(u_choice.x);
  const BdptIntegrator::Emitter& e = it_.emitters_[pick.index];
  Vertex& x = path[0];
  x.type = VertexType::kLight;
  x.start_known = 0;
  x.connectible = true;
  x.wo = glm::vec3(0.0f);
  x.pdf_rev = 0.0f;
  Ray ray;
  glm::vec3 beta;
  float pdf_dir;
  if (e.environment) {
    // A direction towards the environment (the map's importance sampling, or uniform for a
    // constant colour), then a point on the disk of the scene's bounding sphere across it, from
    // which the ray enters the scene (pbrt's BDPT chapter, infinite area lights).
    x.type = VertexType::kEnvironment;
    x.point_light = x.delta = x.smooth = false;
    x.emits = true;
    float dir_pdf = 0.0f;
    x.w_env = it_.sample_environment(u_dir, dir_pdf);
    x.le = it_.environment_radiance(x.w_env);
    x.env_pdf_pos = it_.environment_pdf_pos_;
    // The origin density is the direction's (solid angle), as the escaped camera subpath's is.
    x.pdf_fwd = pick.pmf * dir_pdf;
    if (!(x.pdf_fwd > 0.0f) || !(max_component(x.le) > 0.0f)) return 1;
    x.beta = glm::vec3(1.0f / x.pdf_fwd);
    const Frame frame = Frame::from_normal(x.w_env);
    const glm::vec2 d = sample_uniform_disk_concentric(u_point);
    const float r = it_.environment_radius_;
    ray.origin = it_.environment_centre_ + r * (x.w_env + d.x * frame.x + d.y * frame.y);
    ray.dir = -x.w_env;
    ray.tmin = 0.0f;
    ray.tmax = kRayTMax;
    beta = x.le * (1.0f / (x.pdf_fwd * x.env_pdf_pos));
    return walk(path, 1, max_vertices, ray, beta, x.env_pdf_pos, true, sampler, nullptr);
  }
  if (e.point) {
    // Not delta in the MIS sense: a point light can be connected to (its position is a delta,
    // which no camera subpath can hit: the weights test point_light for that).
    x.point_light = true;
    x.delta = false;
    x.smooth = false;
    x.p = e.position;
    x.ng = x.ns = glm::vec3(0.0f);
    x.le = e.intensity;
    x.pdf_fwd = pick.pmf;
    x.beta = glm::vec3(1.0f / pick.pmf);
    const glm::vec3 w = sample_uniform_sphere(u_dir);
    pdf_dir = uniform_sphere_pdf();
    beta = e.intensity * (1.0f / (pick.pmf * pdf_dir));
    ray.origin = x.p;
    ray.dir = w;
  } else {
    x.point_light = false;
    x.delta = false;
    x.prim = e.prim;
    x.tri = scene_.triangle(e.prim);
    x.material = &scene_.materials[x.tri.material];
    x.two_sided = x.material->two_sided;
    x.emits = true;
    // Emission is taken flat (the lab normal), as the path tracer's light sampling does.
    x.smooth = false;
    const glm::vec3 b = sample_uniform_triangle(u_point);
    x.u = b.y;
    x.v = b.z;
    x.p = x.tri.v0 + b.y * x.tri.e1 + b.z * x.tri.e2;
    x.ng = x.ns = x.tri.normal;
    x.pdf_fwd = pick.pmf / e.area;
    x.beta = glm::vec3(1.0f / x.pdf_fwd);
    const bool back = x.two_sided && u_choice.y >= 0.5f;
    const glm::vec3 n = back ? -x.ng : x.ng;
    const glm::vec3 local = sample_cosine_hemisphere(u_dir);
    const glm::vec3 w = Frame::from_normal(n).to_world(local);
    pdf_dir = emission_pdf(x, w);
    const glm::vec3 le = emission(scene_, x, w);
    x.le = le;
    if (!(pdf_dir > 0.0f) || !(max_component(le) > 0.0f)) return 1;
    beta = le * (std::abs(glm::dot(x.ng, w)) / (x.pdf_fwd * pdf_dir));
    ray.origin = offset_ray_origin(x.p, n, triangle_extent(x.tri.e1, x.tri.e2), it_.offset_);
    ray.dir = w;
  }
  ray.tmin = 0.0f;
  ray.tmax = kRayTMax;
  return walk(path, 1, max_vertices, ray, beta, pdf_dir, true, sampler, nullptr);
}

// One shadow ray: nothing between from and from + dir * length.
bool BdptTracer::unblocked(glm::vec3 from, glm::vec3 dir, float length) {
  Ray r;
  r.origin = from;
  r.dir = dir;
  r.tmin = 0.0f;
  r.tmax = length;
  ++traced_;
  uint8_t blocked = 0;
  accel_.occluded_incoherent(std::span<const Ray>(&r, 1), std::span<uint8_t>(&blocked, 1));
  return blocked == 0;
}

bool BdptTracer::visible(const Vertex& c, const Vertex& l) {
  const glm::vec3 w = direction(c, l);
  const glm::vec3 from = ray_start(c, w, it_.offset_);
  if (infinite(l)) {
    return unblocked(from, w, kRayTMax);
  }
  // A surface vertex's end, as the path tracer's shadow rays end at a light: moved off its
  // surface along its geometric normal only, on the side the ray arrives from, then on by the
  // connection's own rounding (stop_short_of_surface). It was ray_start (leave_surface), whose
  // step towards the centroid then sank 1.1% of ends under a sphere light at (300, -200, 100)
  // behind their own triangle (bdpt rendered it 2.5% dark); that step is fixed too, but an end
  // needs no move off a neighbour's plane that the path tracer's light ends do without.
  glm::vec3 to;
  if (l.point_light) {
    to = offset_ray_origin(l.p, -w, triangle_extent(c.tri.e1, c.tri.e2), it_.offset_);
  } else {
    const glm::vec3 side = glm::dot(l.ng, w) <= 0.0f ? l.ng : -l.ng;
    to = stop_short_of_surface(
        offset_ray_origin(l.p, side, triangle_extent(l.tri.e1, l.tri.e2), it_.offset_), side, from);
  }
  const glm::vec3 segment = to - from;
  const float length = std::sqrt(glm::dot(segment, segment));
  // Nothing fits between the two offset points (the path tracer's rule).
  if (!(length > 0.0f && glm::dot(segment, w) > 0.0f)) return true;
  return unblocked(from, segment * (1.0f / length), length);
}

bool BdptTracer::visible_to_camera(const Vertex& l, glm::vec3 eye) {
  const glm::vec3 d = eye - l.p;
  const glm::vec3 from = ray_start(l, glm::normalize(d), it_.offset_);
  const glm::vec3 segment = eye - from;
  const float length = std::sqrt(glm::dot(segment, segment));
  if (!(length > 0.0f)) return true;
  return unblocked(from, segment * (1.0f / length), length);
}

// The power heuristic over the strategies with t >= 2 that can sample the path of light vertices
// [0, s) and camera vertices [0, t), by the ratio walk of Veach 1997, section 10.2: moving the
// connection one vertex multiplies the strategy's density by pdf_rev / pdf_fwd of the vertex that
// changes sides. The connection's four neighbouring pdf_rev values are set for this path and
// restored afterwards.
float BdptTracer::mis_weight(Vertex* light, Vertex* camera, int s, int t) const {
  if (s + t == 2) return 1.0f;  // an emitter seen by the camera: (1, 1) is not a strategy here
  const bool balance = it_.settings_.balance;
  const auto remap = [balance](float f) { return f != 0.0f ? (balance ? f : f * f) : 1.0f; };
  Vertex& pt = camera[t - 1];
  // For t = 1 (pt the camera) there is no pt_minus: its slot stands in, written and restored.
  Vertex& pt_minus = t > 1 ? camera[t - 2] : camera[0];
  Vertex* qs = s > 0 ? &light[s - 1] : nullptr;
  Vertex* qs_minus = s > 1 ? &light[s - 2] : nullptr;
  const float saved_pt = pt.pdf_rev, saved_pt_minus = pt_minus.pdf_rev;
  const float saved_qs = qs ? qs->pdf_rev : 0.0f,
              saved_qs_minus = qs_minus ? qs_minus->pdf_rev : 0.0f;
  const bool saved_pt_delta = pt.delta, saved_qs_delta = qs ? qs->delta : false;
  pt.delta = false;
  if (qs != nullptr) qs->delta = false;
  if (t == 1) {
    // Light tracing: the camera's density of sampling qs (camera_pdf) is its pdf_rev. The
    // camera's own pdf_rev is never read (no strategy has t = 0).
    qs->pdf_rev = to_area(camera_pdf(scene_.camera, direction(pt, *qs)), pt, *qs);
    if (qs_minus != nullptr) qs_minus->pdf_rev = pdf_area(*qs, &pt, *qs_minus);
  } else if (s > 0) {
    pt.pdf_rev = pdf_area(*qs, qs_minus, pt);
    pt_minus.pdf_rev = pdf_area(pt, qs, pt_minus);
    qs->pdf_rev = pdf_area(pt, &pt_minus, *qs);
    if (qs_minus != nullptr) qs_minus->pdf_rev = pdf_area(*qs, &pt, *qs_minus);
  } else {
    if (infinite(pt)) {
      pt.pdf_rev = it_.environment_pmf_ * it_.environment_dir_pdf(pt.w_env);
      pt_minus.pdf_rev = pdf_area(pt, nullptr, pt_minus);
    } else {
      pt.pdf_rev = it_.origin_pdf(pt.prim);
      pt_minus.pdf_rev = to_area(emission_pdf(pt, direction(pt, pt_minus)), pt, pt_minus);
    }
  }

  float sum = 0.0f;
  float r = 1.0f;
  // Moving the connection to camera vertex i - 1 gives strategy (s + t - i, i). i = 1 is light
  // tracing, a strategy only with it on and with at least two light vertices ((1, 1), an emitter
  // seen by the camera, is left to (0, 2)).
  const int last_i = it_.settings_.light_tracing && s + t >= 3 ? 1 : 2;
  for (int i = t - 1; i >= last_i; --i) {
    r *= remap(camera[i].pdf_rev) / remap(camera[i].pdf_fwd);
    if (!camera[i].delta && !camera[i - 1].delta) sum += r;
  }
  r = 1.0f;
  for (int i = s - 1; i >= 0; --i) {
    r *= remap(light[i].pdf_rev) / remap(light[i].pdf_fwd);
    const bool delta_light_side = i > 0 ? light[i - 1].delta : light[0].point_light;
    if (!light[i].delta && !delta_light_side) sum += r;
  }

  pt.pdf_rev = saved_pt;
  pt_minus.pdf_rev = saved_pt_minus;
  pt.delta = saved_pt_delta;
  if (qs != nullptr) {
    qs->pdf_rev = saved_qs;
    qs->delta = saved_qs_delta;
  }
  if (qs_minus != nullptr) qs_minus->pdf_rev = saved_qs_minus;
  return 1.0f / (1.0f + sum);
}

void BdptTracer::splat_light_subpath(Vertex* light, Vertex* camera, int nl, Sampler& sampler,
                                     SplatBuffer& splats) {
  const BdptSettings& settings = it_.settings_;
  const bool only = settings.only_s >= 0 && settings.only_t >= 0;
  if (only && settings.only_t != 1) return;
  const Camera& cam = scene_.camera;
  const Vertex& eye = camera[0];
  // One number per sample for the splats' stochastic rounding (SplatBuffer::add), drawn after
  // every dimension the subpaths use; each further splat shifts it by the golden ratio, which
  // keeps each one uniform.
  float u_round = sampler.get_1d();
  for (int s = 2; s <= nl && s + 1 <= settings.max_depth + 2; ++s) {
    if (only && s != settings.only_s) continue;
    const Vertex& qs = light[s - 1];
    if (!qs.connectible || infinite(qs)) continue;
    const glm::vec3 d = eye.p - qs.p;
    const float dist2 = glm::dot(d, d);
    if (!(dist2 > 0.0f)) continue;
    const glm::vec3 w = d * (1.0f / std::sqrt(dist2));  // from qs towards the camera
    int px = 0, py = 0;
    if (!project(cam, -w, px, py)) continue;
    const glm::vec3 f_light = surface_f(qs, w, qs.wo);
    if (!(max_component(f_light) > 0.0f)) continue;
    const float g = std::abs(glm::dot(qs.ng, w)) / dist2;
    const glm::vec3 contribution = qs.beta * f_light * (g * camera_pdf(cam, -w));
    if (!(max_component(contribution) > 0.0f)) continue;
    if (!visible_to_camera(qs, eye.p)) continue;
    const float weight = settings.unweighted ? 1.0f : mis_weight(light, camera, s, 1);
    const glm::vec3 term = contribution * weight;
    if (!std::isfinite(term.x + term.y + term.z)) continue;
    splats.add(px, py, term, u_round);
    u_round += 0.618034f;
    if (u_round >= 1.0f) u_round -= 1.0f;
  }
}

glm::vec3 BdptTracer::sample(const Ray& camera_ray, Sampler& sampler, Hit& first_hit,
                             SplatBuffer* splats) {
  const BdptSettings& settings = it_.settings_;
  const int max_camera = settings.max_depth + 2;
  const int max_light = settings.max_depth + 1;
  Subpaths& sub = thread_subpaths();
  if (sub.camera.empty()) {
    sub.camera.resize(kInitialSubpathVertices);
    sub.light.resize(kInitialSubpathVertices);
  }
  Vertex& c0 = sub.camera[0];
  c0.type = VertexType::kCamera;
  c0.p = camera_ray.origin;
  c0.delta = false;
  c0.point_light = false;
  c0.beta = glm::vec3(1.0f);
  c0.pdf_fwd = c0.pdf_rev = 0.0f;
  first_hit = Hit{};
  camera_escaped_ = false;
  // The camera's density of the ray: the first camera vertex's pdf_fwd, read by the weights of
  // light tracing (1 stands for it without).
  const float camera_dir_pdf =
      settings.light_tracing ? camera_pdf(scene_.camera, glm::normalize(camera_ray.dir)) : 1.0f;
  const int nc = walk(sub.camera, 1, max_camera, camera_ray, glm::vec3(1.0f), camera_dir_pdf, false,
                      sampler, &first_hit);
  camera_count_ = nc;
  const int nl = light_subpath(sub.light, max_light, sampler);
  // The subpaths no longer grow: plain pointers from here.
  Vertex* camera = sub.camera.data();
  Vertex* light = sub.light.data();

  const bool only = settings.only_s >= 0 && settings.only_t >= 0;
  glm::vec3 total(0.0f);
  for (int t = 2; t <= nc; ++t) {
    for (int s = 0; s <= nl && s + t <= settings.max_depth + 2; ++s) {
      if (only && (s != settings.only_s || t != settings.only_t)) continue;
      const Vertex& pt = camera[t - 1];
      glm::vec3 contribution(0.0f);
      if (s == 0) {
        if (!pt.emits) continue;
        contribution = pt.beta * emission(scene_, pt, pt.wo);
      } else {
        const Vertex& qs = light[s - 1];
        if (!pt.connectible || !qs.connectible) continue;
        // The environment is at infinity: no distance, and no cosine on its side.
        const glm::vec3 d = infinite(qs) ? qs.w_env : qs.p - pt.p;
        const float dist2 = infinite(qs) ? 1.0f : glm::dot(d, d);
        if (!(dist2 > 0.0f)) continue;
        const glm::vec3 w = d * (1.0f / std::sqrt(dist2));  // from pt towards qs
        const glm::vec3 f_camera = surface_f(pt, pt.wo, w);
        if (!(max_component(f_camera) > 0.0f)) continue;
        const glm::vec3 f_light = s == 1 ? emission(scene_, qs, -w) : surface_f(qs, -w, qs.wo);
        if (!(max_component(f_light) > 0.0f)) continue;
        const float cos_light =
            qs.point_light || infinite(qs) ? 1.0f : std::abs(glm::dot(qs.ng, w));
        const float g = std::abs(glm::dot(pt.ng, w)) * cos_light / dist2;
        contribution = pt.beta * f_camera * (g * f_light) * qs.beta;
        if (!(max_component(contribution) > 0.0f)) continue;
        if (!visible(pt, qs)) continue;
      }
      if (!(max_component(contribution) > 0.0f)) continue;
      const float weight = settings.unweighted ? 1.0f : mis_weight(light, camera, s, t);
      const glm::vec3 term = contribution * weight;
      // Density ratios of vertices a few ULPs apart can overflow; such a term (measure zero) is
      // dropped rather than let a NaN or infinity into the pixel.
      if (!std::isfinite(term.x + term.y + term.z)) continue;
      total += term;
    }
  }
  // The renderer always gives an integrator that splats its film's light image
  // (SampleOutput::splats); without one the light image is missing, never written out of bounds.
  assert(!settings.light_tracing || splats != nullptr);
  if (settings.light_tracing && splats != nullptr) {
    splat_light_subpath(light, camera, nl, sampler, *splats);
  }
  return total;
}

std::string bdpt_unsupported(const Scene& scene) {
  // Light subpaths start on the lights, and emission sampling exists for point lights only.
  if (!scene.spot_lights.empty() || !scene.directional_lights.empty()) {
    return "bdpt does not yet start light subpaths on spot or directional lights; render this "
           "scene with --integrator path";
  }
  uint64_t instanced = 0;
  for (const Instance& inst : scene.instances) {
    const TriangleMesh& proto = scene.prototypes[inst.prototype];
    for (uint32_t k = 0; k < proto.size(); ++k) {
      if (scene.materials[proto.material()[k]].emits()) ++instanced;
    }
    if (instanced > kMaxInstancedLights) {
      return "bdpt needs every emissive triangle as a light; the instances have more than " +
             std::to_string(kMaxInstancedLights);
    }
  }
  return {};
}

BdptIntegrator::BdptIntegrator(const Scene& scene, const BdptSettings& settings,
                               const RayOffsetParams& offset)
    : settings_(settings), offset_(offset) {
  if (const std::string why = bdpt_unsupported(scene); !why.empty()) throw Error("integrator", why);
  std::vector<float> power;
  for (uint32_t i = 0; i < scene.lights.size(); ++i) {
    const PointLight& l = scene.lights[i];
    const float p = mean(l.power);
    if (!(p > 0.0f)) continue;
    Emitter e;
    e.point = true;
    e.prim = i;
    e.position = l.position;
    e.intensity = l.power / (4.0f * kPi);
    emitters_.push_back(e);
    power.push_back(p);
  }
  // Emissive triangles in the scene's numbering, each chosen in proportion to its flux
  // (Le area pi per emitting side), as the path tracer's light sampler weighs them.
  std::vector<std::pair<uint32_t, uint32_t>> prims;  // (prim, emitter index)
  const auto add_triangle = [&](uint32_t prim, const SurfaceTriangle& t) {
    const Material& m = scene.materials[t.material];
    if (!m.emits()) return;
    const float area = 0.5f * glm::length(glm::cross(t.e1, t.e2));
    const float p = mean(m.emission) * area * kPi * (m.two_sided ? 2.0f : 1.0f);
    if (!(p > 0.0f) || !std::isfinite(p)) return;
    Emitter e;
    e.prim = prim;
    e.area = area;
    prims.emplace_back(prim, static_cast<uint32_t>(emitters_.size()));
    emitters_.push_back(e);
    power.push_back(p);
  };
  for (uint32_t prim = 0; prim < scene.mesh.size(); ++prim) {
    if (scene.materials[scene.mesh.material()[prim]].emits()) {
      add_triangle(prim, stored_triangle(scene.mesh, prim));
    }
  }
  for (const Instance& inst : scene.instances) {
    const TriangleMesh& proto = scene.prototypes[inst.prototype];
    for (uint32_t k = 0; k < proto.size(); ++k) {
      if (scene.materials[proto.material()[k]].emits()) {
        add_triangle(inst.first_prim + k, scene.triangle(inst.first_prim + k));
      }
    }
  }
  if (scene.environment_map) {
    environment_ = EnvironmentLight(*scene.environment_map);
    has_environment_ = environment_map_ = !environment_.black();
  } else {
    environment_colour_ = scene.environment;
    has_environment_ = max_component(environment_colour_) > 0.0f;
  }
  if (has_environment_) {
    // Chosen half the time beside other emitters, as the path tracer's light sampler does (a
    // light at infinity has no finite power to compare).
    double others = 0.0;
    for (float p : power) others += static_cast<double>(p);
    Emitter e;
    e.environment = true;
    emitters_.push_back(e);
    power.push_back(others > 0.0 ? static_cast<float>(others) : 1.0f);
    // The bounding sphere, a little larger so that rays from its disk start outside everything.
    const Bounds3 b = scene_bounds(scene);
    environment_centre_ = 0.5f * (b.lo + b.hi);
    environment_radius_ = std::max(1e-3f, 0.5f * glm::length(b.hi - b.lo) * 1.01f);
    environment_pdf_pos_ = 1.0f / (kPi * environment_radius_ * environment_radius_);
  }
  table_ = AliasTable(power);
  if (has_environment_) {
    environment_pmf_ = table_.pmf(static_cast<uint32_t>(emitters_.size() - 1));
  }
  for (size_t k = 0; k < emitters_.size(); ++k) {
    emitters_[k].pmf = table_.pmf(static_cast<uint32_t>(k));
  }
  std::sort(prims.begin(), prims.end());
  for (const auto& [prim, index] : prims) {
    emissive_prims_.push_back(prim);
    emissive_index_.push_back(index);
  }
}

glm::vec3 BdptIntegrator::environment_radiance(glm::vec3 w) const {
  return environment_map_ ? environment_.radiance(w) : environment_colour_;
}

float BdptIntegrator::environment_dir_pdf(glm::vec3 w) const {
  return environment_map_ ? environment_.pdf(w) : uniform_sphere_pdf();
}

glm::vec3 BdptIntegrator::sample_environment(glm::vec2 u, float& pdf) const {
  if (environment_map_) {
    const EnvironmentLight::Sample e = environment_.sample(u);
    pdf = e.pdf;
    return e.wi;
  }
  pdf = uniform_sphere_pdf();
  return sample_uniform_sphere(u);
}

float BdptIntegrator::origin_pdf(uint32_t prim) const {
  const auto it = std::lower_bound(emissive_prims_.begin(), emissive_prims_.end(), prim);
  if (it == emissive_prims_.end() || *it != prim) return 0.0f;
  const Emitter& e = emitters_[emissive_index_[static_cast<size_t>(it - emissive_prims_.begin())]];
  return e.pmf / e.area;
}

uint64_t BdptIntegrator::radiance(const SampleBatch& batch, const SampleOutput& out,
                                  const Scene& scene, const Accel& accel) const {
  const size_t n = batch.rays.size();
  assert(n <= kMaxBatch && batch.samplers.size() == n && out.radiance.size() == n);
  BdptTracer tracer(*this, scene, accel);
  std::array<Hit, kMaxBatch> first_hits;
  for (size_t i = 0; i < n; ++i) {
    out.radiance[i] = tracer.sample(batch.rays[i], batch.samplers[i], first_hits[i], out.splats);
    if (!out.albedo.empty() || !out.normal.empty()) {
      glm::vec3 albedo, normal;
      tracer.surface_aovs(albedo, normal);
      if (!out.albedo.empty()) out.albedo[i] = albedo;
      if (!out.normal.empty()) out.normal[i] = normal;
    }
  }
  // Depth is the first hit's, whatever it is.
  write_first_hit_aovs(scene, batch.rays, std::span<const Hit>(first_hits.data(), n),
                       SampleOutput{.depth = out.depth});
  return tracer.traced();
}

}  // namespace tritrace
