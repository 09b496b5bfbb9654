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
#include <cstddef>
#include <glm/geometric.hpp>
#include <limits>
#include <mutex>
#include <new>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/math/random.h"
#include "tritrace/parallel.h"
#include "tritrace/render/bdpt_pilot.h"
#include "tritrace/render/lanes.h"
#include "tritrace/render/light_sampler.h"
#include "tritrace/render/material/bsdf.h"
#include "tritrace/render/shading_normal.h"
#include "tritrace/render/surface_offset.h"

namespace tritrace {
namespace {

float channel_mean(glm::vec3 c) {
  return (c.x + c.y + c.z) / 3.0f;
}

// kEnvironment: the light at infinity, as a light subpath's first vertex or as the end of a camera
// subpath that escaped; its `w_env` is the direction from the scene towards it. A directional
// light's vertex is one too (`directional`: its direction is a delta).
enum class VertexType : uint8_t { kCamera, kLight, kSurface, kEnvironment };

// One vertex of a subpath. Light vertices are a subpath's first (on a point light or an emissive
// triangle); surface vertices carry the Bsdf of the hit. What the walks, the connections and the
// weights read comes first, in the struct's first four cache lines (a wavefront's subpaths
// outgrow the first-level cache); the Bsdf, which a diffuse vertex does not build, and the
// smooth corners come last.
struct alignas(64) Vertex {
  VertexType type = VertexType::kSurface;
  bool delta = false;        // scattered by a delta lobe here
  bool point_light = false;  // a light vertex on a point or spot light (a delta position)
  bool directional = false;  // a light vertex of a directional light (a delta direction)
  bool connectible = false;  // a surface with a non-delta lobe, or any light vertex
  bool smooth = false;       // shades with interpolated vertex normals
  bool two_sided = false;    // its material emits (or would emit) from both sides
  bool emits = false;
  // A diffuse material's surface (untextured parameters): its Bsdf is one Lambert lobe of colour
  // `albedo`, evaluated, sampled and weighed by the bsdf_* functions below without `bsdf`, which
  // is then not built.
  bool lambert = false;
  bool specular = false;  // every lobe a delta lobe: the AOVs look through it
  // Ray starts on the front (ng) and back side, computed when first needed (ray_start).
  mutable uint8_t start_known = 0;
  // The edge from the previous vertex of its subpath, kept by the walk where both are at finite
  // places (`edge`): its squared length, the direction back along it (direction(x, prev), bit for
  // bit) and the cosine factor at prev that to_area(., x, prev) multiplies in (|n_g . d| / length;
  // 1, which changes no bit, where prev is the camera or a point light). The weights' densities
  // towards prev (to_area_prev, direction_prev) read them rather than measure the edge again.
  bool edge = false;
  glm::vec3 p{0.0f};
  glm::vec3 ng{0.0f};  // the triangle's lab normal (zero for the camera and point lights)
  glm::vec3 ns{0.0f};  // the shading normal on ng's side (the Bsdf frame's z)
  glm::vec3 wo{0.0f};  // towards the previous vertex of its subpath (surface vertices)
  glm::vec3 beta{0.0f};
  glm::vec3 albedo{0.0f};  // the material's albedo here (textured), for the albedo AOV
  float pdf_fwd = 0.0f;
  float pdf_rev = 0.0f;
  // The MIS weights' partial sum up to this vertex (BdptTracer::prepare_weights): over the
  // strategies that move the connection to this vertex or one nearer its subpath's start, the
  // ratio of each one's density to that of the connection just past this vertex. Read only where
  // this vertex's pdf_rev no longer depends on the connection (three or more vertices from it).
  float mis_sum = 0.0f;
  float edge_dist2 = 0.0f;
  float prev_factor = 1.0f;
  glm::vec3 to_prev{0.0f};
  mutable glm::vec3 start[2]{};
  uint32_t prim = 0;
  float u = 0.0f, v = 0.0f;  // barycentrics on the triangle
  const Material* material = nullptr;
  Frame frame{};
  SurfaceTriangle tri{};
  glm::vec3 w_env{0.0f};     // an environment vertex's direction, from the scene towards it
  glm::vec3 le{0.0f};        // a light vertex's emission (radiance, or a point light's intensity)
  glm::vec3 aov_tint{1.0f};  // the sampled bounce's weight without 1/eta^2 (the AOVs' tint)
  float env_pdf_pos = 0.0f;  // an environment vertex's density per area across w_env
  const SpotLight* spot = nullptr;  // a spot light's vertex: its cone (point_light is set too)
  SmoothCorners corners{};
  Bsdf bsdf{Material{}};
};
// The SIMD lanes (walk_scatter_lanes, run_lane_jobs) load runs of eight consecutive floats from
// eight vertices and transpose them (lanes::transpose8): p, ng, ns; wo, beta, albedo; albedo.z
// and the densities; the frame and the triangle. The runs' members must stay in this order.
static_assert(std::is_standard_layout_v<Vertex>);
static_assert(offsetof(Vertex, ng) == offsetof(Vertex, p) + 12 &&
              offsetof(Vertex, ns) == offsetof(Vertex, p) + 24);
static_assert(offsetof(Vertex, wo) == offsetof(Vertex, ns) + 12 &&
              offsetof(Vertex, beta) == offsetof(Vertex, wo) + 12 &&
              offsetof(Vertex, albedo) == offsetof(Vertex, wo) + 24);
static_assert(offsetof(Vertex, pdf_fwd) == offsetof(Vertex, albedo) + 12 &&
              offsetof(Vertex, pdf_rev) == offsetof(Vertex, albedo) + 16 &&
              offsetof(Vertex, edge_dist2) == offsetof(Vertex, albedo) + 24 &&
              offsetof(Vertex, prev_factor) == offsetof(Vertex, albedo) + 28 &&
              offsetof(Vertex, to_prev) == offsetof(Vertex, albedo) + 32);
static_assert(sizeof(Frame) == 36 && offsetof(Frame, y) == 12 && offsetof(Frame, z) == 24 &&
              offsetof(Vertex, tri) == offsetof(Vertex, frame) + 36);
static_assert(offsetof(SurfaceTriangle, e1) == 12 && offsetof(SurfaceTriangle, e2) == 24 &&
              offsetof(SurfaceTriangle, normal) == 36);

// Builds `member` from make()'s value where it stays: `member = make()` builds the value in a
// temporary and copies it, and the copy's 32-byte loads of the temporary's narrower stores stalled
// (store forwarding: about a quarter of the walk's profile for the triangle and the Bsdf).
template <typename T, typename Make>
void build_in_place(T& member, Make&& make) {
  static_assert(std::is_trivially_destructible_v<T>);
  ::new (static_cast<void*>(&member)) T(make());  // a prvalue: constructed at &member
}

bool infinite(const Vertex& x) {
  return x.type == VertexType::kEnvironment;
}

// A light vertex that no camera subpath can hit (a point, spot or directional light): the
// strategy s = 0 does not exist for paths that start on it.
bool delta_light(const Vertex& x) {
  return x.point_light || x.directional;
}

// A spot light's emission as a distribution of directions (its cone with the falloff): the
// integral of spot_falloff over the sphere, spot_light_power / I, which normalises it.
float spot_falloff_integral(const SpotLight& l) {
  const float k = l.falloff == SpotFalloff::kGltf ? 1.0f / 3.0f : 0.5f;
  return 2.0f * kPi * ((1.0f - l.cos_inner) + k * (l.cos_inner - l.cos_outer));
}

// The solid-angle density with which sample_spot_direction chooses w: proportional to the
// intensity, spot_falloff(cos) / its integral.
float spot_direction_pdf(const SpotLight& l, glm::vec3 w) {
  return spot_falloff(l, glm::dot(l.direction, w)) / spot_falloff_integral(l);
}

// A direction from spot light l in proportion to its intensity (the light subpath's throughput
// is then I / pdf = the integral, whatever the direction). Over the cosine c of the angle from
// the axis the density is proportional to spot_falloff(c) (dw = dc dphi): u_region picks the inner
// cone (constant, weight 1 - cos_inner) or the falloff ring (weight k (cos_inner - cos_outer)),
// then u.x inverts the cosine's distribution there: uniform inside; in the ring, with t the ring's
// parameter, the glTF falloff's density 3 t^2 (CDF t^3) and smoothstep's 6 t^2 - 4 t^3 (CDF
// 2 t^3 - t^4, inverted by bisection: it is monotonic on [0, 1]).
glm::vec3 sample_spot_direction(const SpotLight& l, float u_region, glm::vec2 u) {
  const float inner = 1.0f - l.cos_inner;
  const float k = l.falloff == SpotFalloff::kGltf ? 1.0f / 3.0f : 0.5f;
  const float ring = k * (l.cos_inner - l.cos_outer);
  float c;
  if (u_region * (inner + ring) < inner) {
    c = 1.0f - u.x * inner;
  } else {
    float t;
    if (l.falloff == SpotFalloff::kGltf) {
      t = std::cbrt(u.x);
    } else {
      float lo = 0.0f, hi = 1.0f;
      for (int i = 0; i < 24; ++i) {
        const float mid = 0.5f * (lo + hi);
        (mid * mid * mid * (2.0f - mid) < u.x ? lo : hi) = mid;
      }
      t = 0.5f * (lo + hi);
    }
    c = l.cos_outer + t * (l.cos_inner - l.cos_outer);
  }
  c = std::clamp(c, -1.0f, 1.0f);
  const float sin_theta = std::sqrt(std::max(0.0f, 1.0f - c * c));
  const float phi = 2.0f * kPi * u.y;
  return Frame::from_normal(l.direction)
      .to_world(glm::vec3(sin_theta * std::cos(phi), sin_theta * std::sin(phi), c));
}

// Vertex x's Bsdf (Bsdf::eval, pdf and sample). A Lambert vertex's is written out here as Bsdf
// and its one lobe compute it (bsdf.cpp: the side flip, lobe_eval, lobe_pdf and lobe_sample of
// kLambert without a coat; the lobe's weight 1 and the sums over one lobe change no bit), so the
// numbers are the same bits without the Bsdf's construction, its lobe loops, its choice array and
// its calls (a tenth of bdpt's CPU on cornell-area at --light-paths 0.125; the path tracer's
// diffuse vertices skip them likewise).
// A Lambert vertex's value and density read only the local directions' z (their cosines).
glm::vec3 lambert_eval(const Vertex& x, float wo_z, float wi_z) {
  if (wo_z < 0.0f) wo_z = -wo_z, wi_z = -wi_z;
  if (wo_z <= 0.0f || wi_z <= 0.0f) return glm::vec3(0.0f);
  return x.albedo * kInvPi;
}

float lambert_pdf(float wo_z, float wi_z) {
  if (wo_z < 0.0f) wo_z = -wo_z, wi_z = -wi_z;
  return wo_z <= 0.0f ? 0.0f : cosine_hemisphere_pdf(wi_z);
}

glm::vec3 bsdf_eval(const Vertex& x, glm::vec3 wo, glm::vec3 wi) {
  return x.lambert ? lambert_eval(x, wo.z, wi.z) : x.bsdf.eval(wo, wi);
}

float bsdf_pdf(const Vertex& x, glm::vec3 wo, glm::vec3 wi) {
  return x.lambert ? lambert_pdf(wo.z, wi.z) : x.bsdf.pdf(wo, wi);
}

BsdfSample bsdf_sample(const Vertex& x, glm::vec3 wo, float u_lobe, glm::vec2 u) {
  if (!x.lambert) return x.bsdf.sample(wo, u_lobe, u);
  const bool below = wo.z < 0.0f;
  if (below) wo.z = -wo.z;
  if (wo.z <= 0.0f) return {};
  BsdfSample s;
  s.wi = sample_cosine_hemisphere(u);
  s.pdf = cosine_hemisphere_pdf(s.wi.z);
  if (s.pdf > 0.0f) {
    s.weight = (s.wi.z <= 0.0f ? glm::vec3(0.0f) : x.albedo * kInvPi) * (s.wi.z / s.pdf);
  }
  if (!s.valid()) return {};
  if (below) s.wi.z = -s.wi.z;
  return s;
}

// Whether direction w (world, leaving the vertex) lies on the same side of the shading and the
// geometric surface: where it does not, the vertex carries nothing that way (docs/BDPT.md).
bool agrees(const Vertex& x, glm::vec3 w) {
  return !x.smooth || shading_agrees(w, x.ns, x.ng);
}

// Vertex x's Bsdf sampled for the direction onwards from x.wo (the direction back along the path),
// the lobe chosen by u_lobe and the direction by u: the camera walk, the light walk, the caustic
// strategy's chains and the view rays all scatter this way. Invalid (bs) where the sample is, or
// where x.wo or the new direction lies on different sides of the shading and geometric surfaces.
struct Scatter {
  BsdfSample bs;       // in x's shading frame
  glm::vec3 wo_local;  // x.wo in that frame
  glm::vec3 w_next;    // bs.wi in world space
};

Scatter scatter(const Vertex& x, float u_lobe, glm::vec2 u) {
  Scatter s;
  if (!agrees(x, x.wo)) return s;
  s.wo_local = x.frame.to_local(x.wo);
  s.bs = bsdf_sample(x, s.wo_local, u_lobe, u);
  if (!s.bs.valid()) return s;
  s.w_next = x.frame.to_world(s.bs.wi);
  if (!agrees(x, s.w_next)) s.bs = {};
  return s;
}

// f_s(w_cam, w_light) of Veach 1997, section 5.3: the Bsdf's value with the shading normal's
// cosine moved onto the geometric one, so that the geometry terms use geometric normals.
glm::vec3 surface_f(const Vertex& x, glm::vec3 w_cam, glm::vec3 w_light) {
  if (!agrees(x, w_cam) || !agrees(x, w_light)) return glm::vec3(0.0f);
  const float cos_g = std::abs(glm::dot(x.ng, w_light));
  if (!(cos_g > 0.0f)) return glm::vec3(0.0f);
  // (Frame::to_local's z is the dot with the frame's z.)
  const glm::vec3 f =
      x.lambert ? lambert_eval(x, glm::dot(w_cam, x.frame.z), glm::dot(w_light, x.frame.z))
                : x.bsdf.eval(x.frame.to_local(w_cam), x.frame.to_local(w_light));
  // A flat vertex's ns is its ng: the factor is exactly 1.
  if (!x.smooth) return f;
  return f * (std::abs(glm::dot(x.ns, w_light)) / cos_g);
}

// The solid-angle density with which a surface vertex samples w_sampled from w_given (both
// subpaths sample with the direction they arrived from as the Bsdf's wo).
float surface_pdf(const Vertex& x, glm::vec3 w_given, glm::vec3 w_sampled) {
  if (!agrees(x, w_given) || !agrees(x, w_sampled)) return 0.0f;
  if (x.lambert) return lambert_pdf(glm::dot(w_given, x.frame.z), glm::dot(w_sampled, x.frame.z));
  return x.bsdf.pdf(x.frame.to_local(w_given), x.frame.to_local(w_sampled));
}

// The solid-angle density with which light vertex (or emitting surface) x emits towards w.
float emission_pdf(const Vertex& x, glm::vec3 w) {
  if (x.point_light)
    return x.spot != nullptr ? spot_direction_pdf(*x.spot, w) : uniform_sphere_pdf();
  const float c = glm::dot(x.ng, w);
  if (x.two_sided) return 0.5f * std::abs(c) * kInvPi;
  return c > 0.0f ? c * kInvPi : 0.0f;
}

// The radiance light vertex (or emitting surface) x sends along w.
glm::vec3 emission(const Scene& scene, const Vertex& x, glm::vec3 w) {
  if (x.spot != nullptr) return x.le * spot_falloff(*x.spot, glm::dot(x.spot->direction, w));
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

// Measures the edge from `prev` to the new surface vertex x (Vertex::edge) and returns x's
// pdf_fwd, to_area(pdf_dir, prev, x), bit for bit: the two ends' distances are the same numbers
// (d and -d give the same squares, dots of opposite sign and the same magnitude).
float measure_edge(float pdf_dir, const Vertex& prev, Vertex& x) {
  x.edge = !infinite(prev);
  if (!x.edge) return to_area(pdf_dir, prev, x);
  const glm::vec3 d = x.p - prev.p;
  const float dist2 = glm::dot(d, d);
  x.edge_dist2 = dist2;
  if (!(dist2 > 0.0f)) {
    x.edge = false;  // direction() of a zero difference, as before
    return 0.0f;
  }
  const float length = std::sqrt(dist2);
  // glm::normalize(prev.p - x.p): (-d) * (1 / sqrt(d . d)).
  x.to_prev = -(d * (1.0f / length));
  x.prev_factor = prev.type == VertexType::kCamera || prev.point_light
                      ? 1.0f
                      : std::abs(glm::dot(prev.ng, d)) / length;
  return pdf_dir / dist2 * (std::abs(glm::dot(x.ng, d)) / length);
}

// to_area(pdf_dir, x, prev) and direction(x, prev) for x's predecessor prev on its subpath.
float to_area_prev(float pdf_dir, const Vertex& x, const Vertex& prev) {
  if (!x.edge) return to_area(pdf_dir, x, prev);
  return pdf_dir / x.edge_dist2 * x.prev_factor;
}

glm::vec3 direction_prev(const Vertex& x, const Vertex& prev) {
  return x.edge ? x.to_prev : direction(x, prev);
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
// A thin lens has the same density from its point on the lens (pbrt-v4's PerspectiveCamera::PDF_We
// with the lens area's 1 / (pi R^2) left out, as both kinds of strategy sample the lens point
// with it): a pixel's samples are uniform over its image of area (F / f)^2 on the plane in focus
// at distance F along forward, where dA = F^2 / cos^3(theta) dw from any lens point, so the pixel's
// density is again f^2 / cos^3(theta), and the importance (We cos / p(lens point)) is the same.
float camera_pdf(const Camera& camera, glm::vec3 w) {
  const float c = glm::dot(w, camera.forward());
  if (!(c > 0.0f)) return 0.0f;
  const float f = camera.focal_px();
  return f * f /
         (static_cast<float>(camera.width()) * static_cast<float>(camera.height()) * c * c * c);
}

// An orthographic camera with a lens (Camera::lens_ray): a ray leaves the film's point a, uniform
// over its W H s^2 area in the plane through the camera (s: ortho_scale), moved by a lens offset l
// uniform over the disk of radius R, towards a + F forward, its point in focus. Per area of the
// lens point o and solid angle it has the density F^2 / (W H s^2 pi R^2 cos^3(theta)) (dA on the
// plane in focus = F^2 / cos^3 dw). Light tracing joins a vertex q at depth z (along forward) to
// the lens point o = q's foot on the camera's plane + l z / F for a uniform l (the ray from o
// through q then passes a + F forward with a = o - l), density (F / z)^2 / (pi R^2) by area: the
// two kinds of strategy sample o with different densities, and the weights need their ratio. Both
// folded into one "camera density" of the direction from o towards a point at distance d,
// z = d cos(theta), the joint density over light tracing's density of o is
// d^2 / (W H s^2 cos(theta)) per solid angle, which is also the light image's importance, as the
// pinhole's camera_pdf is (docs/BDPT.md).
float ortho_lens_pdf(const Camera& camera, glm::vec3 w, float dist2) {
  const float c = glm::dot(w, camera.forward());
  if (!(c > 0.0f)) return 0.0f;
  const float s = camera.ortho_scale();
  return dist2 /
         (static_cast<float>(camera.width()) * static_cast<float>(camera.height()) * s * s * c);
}

// The camera's density of direction w from its vertex, towards a point dist2 away (only an
// orthographic camera's, which light tracing reaches only with a lens, depends on the distance).
float camera_dir_pdf(const Camera& camera, glm::vec3 w, float dist2) {
  return camera.is_orthographic() ? ortho_lens_pdf(camera, w, dist2) : camera_pdf(camera, w);
}

// Where direction w (unit, from the camera vertex `eye`) meets the image, in pixels from its
// top-left corner (Camera::ray_through inverted; with a lens, Camera::lens_ray: from the lens point
// along w to the plane in focus, then through the pinhole, or along forward to the film's plane
// for an orthographic camera); false where it misses the film.
bool project(const Camera& camera, glm::vec3 eye, glm::vec3 w, int& x, int& y) {
  const float c = glm::dot(w, camera.forward());
  if (!(c > 0.0f)) return false;
  const float f = camera.focal_px();
  float px, py;
  if (camera.is_orthographic()) {
    const glm::vec3 v = eye + w * (camera.focus_distance() / c) - camera.position();
    const float s = camera.ortho_scale();
    px = glm::dot(v, camera.right()) / s + static_cast<float>(camera.width() / 2);
    py = glm::dot(v, camera.down()) / s + static_cast<float>(camera.height() / 2);
  } else if (camera.has_lens()) {
    const glm::vec3 v = eye + w * (camera.focus_distance() / c) - camera.position();
    const float cv = glm::dot(v, camera.forward());
    if (!(cv > 0.0f)) return false;
    px = glm::dot(v, camera.right()) / cv * f + static_cast<float>(camera.width() / 2);
    py = glm::dot(v, camera.down()) / cv * f + static_cast<float>(camera.height() / 2);
  } else {
    px = glm::dot(w, camera.right()) / c * f + static_cast<float>(camera.width() / 2);
    py = glm::dot(w, camera.down()) / c * f + static_cast<float>(camera.height() / 2);
  }
  if (!(px >= 0.0f && py >= 0.0f && px < static_cast<float>(camera.width()) &&
        py < static_cast<float>(camera.height()))) {
    return false;
  }
  x = std::min(static_cast<int>(px), camera.width() - 1);
  y = std::min(static_cast<int>(py), camera.height() - 1);
  return true;
}

// A light-tracing splat's value in its pixel's light image: with adaptive sampling a pass's splats
// onto a pixel are an estimate over count_ratio P m light subpaths (P pixels, m samples each in
// the pass) rather than P m, so they weigh 1 / count_ratio, and the pixel's resolve (the sum over
// its own sample count) is then the sample-weighted mean of its passes' estimates (docs/BDPT.md,
// "Adaptive sampling"). count_ratio is 1 without adaptive sampling: the splat is unchanged.
glm::vec3 splat_value(glm::vec3 term, float count_ratio) {
  return term / count_ratio;
}

// The camera's density as the MIS weights count it against light tracing's: divided by the pixel's
// count ratio (light subpaths per camera sample, over the image's pixels; SplatPass::count_ratio),
// which multiplies light tracing's strategies by the ratio against the camera's (Veach 1997,
// sec. 9.2: the heuristics weigh each strategy's density by its sample count). Where every
// pixel takes every sample the ratio is 1 and the density is camera_pdf's, bit for bit.
float light_tracing_camera_pdf(float pdf, float count_ratio) {
  return pdf / count_ratio;
}

// Whether the current sample of `sampler` traces a light subpath (BdptSettings::light_paths = F <
// 1): sample i of its pixel does when floor((i + 1) F + phi) > floor(i F + phi), phi uniform per
// pixel from the pixel's key. Over phi each sample does with probability exactly F (so dividing its
// light strategies by F is unbiased for any sample count), and a pixel's samples take them in
// even steps (any n consecutive samples hold floor(n F) or ceil(n F)). Deterministic: a function
// of (seed, pixel, sample index), as every other number of the sample.
bool traces_light_subpath(const Sampler& sampler, float light_paths) {
  if (light_paths >= 1.0f) return true;
  const double f = light_paths;
  const double phi =
      static_cast<double>(hash_combine(sampler.pixel_key(), 0x6c69676874706174ull) >> 11) * 0x1p-53;
  const double i = sampler.sample_index();
  return std::floor((i + 1.0) * f + phi) > std::floor(i * f + phi);
}

// Pixel index y width + x as (x, y).
std::array<int, 2> pixel_xy(uint32_t pixel, int width) {
  const uint32_t w = static_cast<uint32_t>(width);
  return {static_cast<int>(pixel % w), static_cast<int>(pixel / w)};
}

// The caustic strategy's directions per guided vertex (BdptTracer::caustic_strategy): its vertices
// are few (the caustics' cells), so several directions each cost little and cut its variance.
inline constexpr int kCausticDirections = 8;

// Samples whose subpaths are walked side by side: each bounce's rays of all of them are traced in
// one query (packets on small trees, interleaved traversal on large ones), as the path tracer
// traces its batch's bounces, instead of one ray per query. Half a batch (kMaxBatch): larger
// queries share more of the traversal than 64 did, and the subpaths (about 2.5 MB per thread at
// 16 vertices each) stay within a few megabytes.
inline constexpr size_t kWavefront = 128;

// Per thread and per sample of a wavefront: the two subpaths. They grow (doubling) as long
// subpaths need, up to the depth limit, rather than to it at once: --max-depth 65536 would
// otherwise take tens of megabytes per thread.
inline constexpr size_t kInitialSubpathVertices = 16;
// The caustic guide's pre-pass traces its light paths in chunks of this many, each from its own
// random stream (BdptTracer::caustic_photons): the unit of its parallel work.
inline constexpr uint32_t kGuideChunk = 2048;
struct Subpaths {
  std::vector<Vertex> camera, light;
};

std::array<Subpaths, kWavefront>& thread_subpaths() {
  thread_local std::array<Subpaths, kWavefront> subpaths;
  return subpaths;
}

// One subpath's walk between its bounces: the ray to trace next and what the next vertex receives.
struct WalkState {
  int count = 0;            // vertices so far
  int max_vertices = 0;     // the subpath's limit
  Ray ray{};                // the next ray (while active)
  glm::vec3 beta{0.0f};     // the throughput the next vertex receives
  glm::vec3 rr_beta{1.0f};  // the throughput since the subpath's start, for Russian roulette
  float pdf_dir = 0.0f;     // the next ray's direction density at the last vertex
  bool light = false;       // the adjoint (importance) transport
  bool active = false;      // a ray to trace
};
// walk_scatter_lanes loads beta, rr_beta and pdf_dir as one run of floats.
static_assert(std::is_standard_layout_v<WalkState> &&
              offsetof(WalkState, rr_beta) == offsetof(WalkState, beta) + 12 &&
              sizeof(WalkState) >= offsetof(WalkState, beta) + 32);

// The next N 2-D groups of each of `count` samplers (count <= kWavefront): exactly what
// get_2d_groups<N> draws for each, with eight samplers sharing each SIMD operation
// (Sampler::get_2d_groups_batch), as the path tracer draws its batch's vertices.
template <size_t N>
void draw_groups(Sampler* const* samplers, size_t count,
                 std::array<std::array<glm::vec2, N>, kWavefront>& out) {
  alignas(32) float rows[2 * N][kWavefront];
  Sampler::get_2d_groups_batch<N>(samplers, count, &rows[0][0], kWavefront);
  for (size_t j = 0; j < count; ++j) {
    for (size_t g = 0; g < N; ++g) out[j][g] = {rows[2 * g][j], rows[2 * g + 1][j]};
  }
}

}  // namespace

// The per-sample work, with the integrator's data at hand.
class BdptTracer {
 public:
  // `tally`: the pilot's (BdptIntegrator::pilot_radiance), or null for a render.
  BdptTracer(const BdptIntegrator& integrator, const Scene& scene, const Accel& accel,
             const CausticGuide* guide = nullptr, LightPathsTally* tally = nullptr)
      : it_(integrator), scene_(scene), accel_(accel), guide_(guide), tally_(tally) {}

  // Chunk `chunk` of the caustic guide's pre-pass of `n` light paths (its paths [chunk *
  // kGuideChunk, (chunk + 1) * kGuideChunk) below n) from the emissive triangles, PCG32 numbers
  // from the chunk's own stream, each followed through specular surfaces to its first non-specular
  // one, which is a photon where the path met at least one specular surface. In path order.
  std::vector<CausticPhoton> caustic_photons(uint32_t chunk, uint32_t n);

  // Samples [first, first + count) of the batch (count <= kWavefront): their subpaths walked
  // side by side, then each sample's connections in order. Radiance and AOVs go to `out` at the
  // batch's indices; with light tracing the (s, 1) connections are added to out.splats (not null
  // then). `first_hits` are the batch's camera rays' first hits (traced together).
  void wavefront(const SampleBatch& batch, const SampleOutput& out, const Hit* first_hits,
                 size_t first, size_t count);
  uint64_t traced() const { return traced_; }
  // The pixels where samples take BdptSettings::specular_view_rays (null: none).
  void set_specular_mask(const BdptIntegrator::SpecularMask* mask) { mask_ = mask; }

 private:
  // The albedo and normal AOVs of sample k's camera subpath, as the path tracer writes them
  // (path_integrator.cpp): those of the first surface that is not specular, seen through perfect
  // mirrors and smooth glass with their tint; a specular surface's own where the subpath ends
  // there; zero where it escapes.
  void surface_aovs(size_t k, glm::vec3& albedo, glm::vec3& normal) const;
  // Adaptive sampling's pass (SplatPass; null: every pixel takes every sample) and the pixel of
  // wavefront sample k: its count ratio.
  void set_pass(size_t k, const SplatPass* pass, uint32_t pixel);
  // Makes wavefront sample k the one whose subpaths, pixel and sums the connections and weights
  // below read and write.
  void select(size_t k);
  // x.tri = triangle prim, x.p its point at barycentrics (b1, b2) and x.ng its normal.
  void set_triangle(Vertex& x, uint32_t prim, float b1, float b2) const;
  // Fills vertex x from a hit of ray `ray`.
  bool make_surface(Vertex& x, const Ray& ray, const Hit& hit) const;
  // A walk from the last of `path`'s w.count vertices: inactive if the subpath is full, else
  // with room for the next vertex.
  static void walk_begin(std::vector<Vertex>& path, WalkState& w);
  // One bounce of a walk in two halves. walk_hit: the vertex at `hit` of w.ray (a miss ends it,
  // with an environment vertex for a camera subpath, setting `escaped`); false where the walk ends
  // there. walk_scatter: the scattering at that (last) vertex and the next ray (w.active) or the
  // walk's end. They extend `path` with vertices sampled from w.ray, whose direction has density
  // w.pdf_dir at the last vertex; w.beta is the throughput the next vertex receives. `u` holds the
  // bounce's two sampler groups (the lobe choice and roulette, the direction), drawn by the caller
  // where the walk continues past the hit (will_draw).
  bool walk_hit(std::vector<Vertex>& path, WalkState& w, const Hit& hit, bool& escaped) const;
  void walk_scatter(std::vector<Vertex>& path, WalkState& w,
                    const std::array<glm::vec2, 2>& u) const;
  // walk_scatter for n <= 8 camera walks (walks[index[i]] on paths[index[i]], numbers *u[i]) whose
  // last vertex is a flat Lambert surface, eight to a SIMD operation (lanes.h), bit for bit.
  void walk_scatter_lanes(std::vector<Vertex>* const* paths, WalkState* walks,
                          const uint32_t* index, const Vertex* const* vertices,
                          const std::array<glm::vec2, 2>* const* u, size_t n) const;
  // One bounce of the walks index[0, n) at hits[0, n): walk_hit and walk_scatter for each, u
  // holding the numbers of those that draw (will_draw), in order; the camera walks' flat Lambert
  // vertices scatter in lanes after the others.
  void step_bounce(std::vector<Vertex>* const* paths, WalkState* walks, const uint32_t* index,
                   const Hit* hits, size_t n, const std::array<glm::vec2, 2>* u,
                   bool* escaped) const;
  // Whether walk_scatter will use its sampler numbers at `hit`.
  static bool will_draw(const WalkState& w, const Hit& hit) {
    return hit.found() && w.count + 1 < w.max_vertices;
  }
  // Walks the wavefront's active walks (walks[k] on paths[k]) to their ends, each bounce's rays
  // traced in one query.
  void walk_all(std::vector<Vertex>* const* paths, WalkState* walks, Sampler* samplers,
                bool* escaped, size_t count);
  // Light subpath: its first vertex, and the walk from it in `w` (w.count 0 when the scene has no
  // emitter).
  // `u`: its first three sampler groups (the emitter and side, the point, the direction).
  // `walk` false (a sample outside BdptSettings::light_paths' share): only the first vertex, for
  // s = 1, without the direction or ray the walk would start from (w stays inactive).
  void light_subpath(std::vector<Vertex>& path, int max_vertices, const std::array<glm::vec2, 3>& u,
                     bool walk, WalkState& w) const;
  // The light subpath from directional light e (light_subpath's choice), its disk point from
  // u_point.
  void directional_light_subpath(std::vector<Vertex>& path, int max_vertices,
                                 const BdptIntegrator::Emitter& e, glm::vec2 u_point, bool walk,
                                 WalkState& w) const;
  // Sample k's connections (s, t), t >= 2, queued; then its light tracing (sampler: the splats'
  // rounding number and an orthographic lens's offset, drawn after the subpaths').
  void connect(size_t k, Sampler& sampler);
  // connect for a sample whose light subpath is its first vertex only (nl <= 1; with
  // BdptSettings::light_paths < 1 most samples): its strategies are s = 0 and s = 1 at each camera
  // vertex, each connection weighted as it is made (the weight does not depend on the shadow ray),
  // the camera side's partial sums carried along the walk rather than prepared in a pass of their
  // own, and the weighted term queued for its shadow ray. The same numbers, in the same order, as
  // connect's: the image is the same bits.
  void connect_camera_only(size_t k);
  // connect_camera_only's connection s = 1 at camera vertex t - 1 of sample k, where that vertex
  // is a flat Lambert surface and the light vertex a point of an emissive triangle without an
  // emission texture, for pending_[pending]: kept (lane_jobs_) and computed eight to a SIMD
  // operation (lanes.h) when eight are kept or before the queue is flushed, bit for bit
  // connect_camera_only's scalar code; its shadow ray, if it has one, is appended to rays_ then
  // (the query's order is no part of its answers).
  struct LaneJob {
    const Vertex* pt = nullptr;     // camera vertex t - 1 (its predecessor is pt - 1)
    const Vertex* light = nullptr;  // light vertex 0
    int pending = 0;
    // mis_weight_recursive's camera-side terms for s = 1 that do not depend on the connection:
    // whether its outer (t - 1 >= m) and inner (t - 2 >= m) terms exist, the inner one's sum
    // (before + c) and what the outer one adds (pt_minus not delta).
    bool has_outer = false, has_inner = false;
    float inner_terms = 0.0f, outer_add = 0.0f;
  };
  std::array<LaneJob, 8> lane_jobs_{};
  size_t lane_job_count_ = 0;
  void run_lane_jobs();
  // The shadow ray of the connection between camera-side vertex c and light-side vertex l, whose
  // direction from c is w (direction(c, l)); false where nothing fits between its two ends (then
  // nothing can block it).
  bool shadow_ray(const Vertex& c, const Vertex& l, glm::vec3 w, Ray& r) const;
  // The same between surface vertex l and the camera at `eye`, w = direction from l to eye.
  bool camera_shadow_ray(const Vertex& l, glm::vec3 eye, glm::vec3 w, Ray& r) const;
  // Queues connection (s, t) with its unweighted contribution (t = 1: onto pixel (px, py)) and
  // its shadow ray, if it needs one; flushes the queue when full.
  void queue(int s, int t, glm::vec3 contribution, bool has_ray, const Ray& ray, int px = 0,
             int py = 0, float count_ratio = 1.0f, glm::vec3 dir = glm::vec3(0.0f));
  // Traces the queued shadow rays in one batch query and adds the unblocked connections, weighted,
  // in the order they were queued (the sums are those of one connection at a time, bit for bit).
  void flush();
  // Light tracing: the (s, 1) connections of the light subpath's vertices to the camera.
  void splat_light_subpath(int nl);
  // The camera's density of sampling vertex q from camera vertex `eye`, by area at q.
  float camera_area_pdf(const Vertex& eye, const Vertex& q) const {
    const glm::vec3 d = q.p - eye.p;
    return to_area(camera_dir_pdf(scene_.camera, direction(eye, q), glm::dot(d, d)), eye, q);
  }
  // Light tracing to an orthographic camera with a lens: the lens point through which it joins
  // point q (ortho_lens_pdf), with this sample's lens offset.
  glm::vec3 ortho_lens_point(glm::vec3 q) const {
    const Camera& cam = scene_.camera;
    const float z = glm::dot(q - cam.position(), cam.forward());
    return q - cam.forward() * z +
           (cam.right() * lens_offset_.x + cam.down() * lens_offset_.y) *
               (z / cam.focus_distance());
  }
  // The weight of a queued connection: mis_weight, with the camera vertex moved to the lens point
  // of light tracing's connection to an orthographic camera with a lens; `ratio` as mis_weight's.
  // `dir`: for t >= 2 and s >= 1 the connection's direction from camera vertex t - 1 towards light
  // vertex s - 1 as connect computed it (direction()'s value, bit for bit), or null.
  // `caustic_q` > 0 (a caustic path): the ratio walk's weight with the caustic strategy among the
  // strategies (mis_weight_walk) instead of the recursion's.
  float connection_weight(int s, int t, float ratio, const glm::vec3* dir = nullptr,
                          float caustic_q = 0.0f);
  // The MIS weights' partial sums (Vertex::mis_sum) along both subpaths, once per sample.
  void prepare_weights(Vertex* light, int nl, Vertex* camera, int nc) const;
  // The weight of strategy (s, t): O(1) from the partial sums (with the settings' weight_check,
  // also compared with mis_weight_walk).
  // `ratio` is the light-tracing count ratio (count_ratio below) of the path's pixel: the splat's
  // pixel for t = 1, the sample's own otherwise (where the recursion has it already, in the
  // camera's density at camera vertex 1).
  float mis_weight(Vertex* light, Vertex* camera, int s, int t, float ratio,
                   const glm::vec3* dir = nullptr) const;
  float mis_weight_recursive(const Vertex* light, const Vertex* camera, int s, int t, float ratio,
                             const glm::vec3* dir = nullptr) const;
  // The ratio walk over the whole path that the recursion replaced: the tests' oracle. It applies
  // the count ratio as a factor of light tracing's strategies (not through the densities).
  // With `strategies` (`--light-paths auto`'s pilot), also lists every other strategy that can
  // sample the path with its density ratio to this one's (remapped: squared for the power
  // heuristic; counts left out) and whether it uses the light subpath past its first vertex (s >=
  // 2).
  // `caustic_q`: the path's caustic_q (> 0 on a caustic path the guide can sample), which adds
  // the caustic strategy (of density q^(1/2) times the density of s = 0, for the power heuristic)
  // to the strategies weighed and listed.
  float mis_weight_walk(Vertex* light, Vertex* camera, int s, int t, float ratio,
                        std::vector<std::pair<float, bool>>* strategies = nullptr,
                        float caustic_q = 0.0f) const;
  // Light tracing's count ratio at pixel (x, y) for the MIS weights (SplatPass::count_ratio,
  // times the tests' BdptSettings::mis_count_scale).
  float mis_count_ratio(int x, int y) const;
  // The heuristic's ratio of two strategies' densities across one vertex: (rev / fwd)^2 for the
  // power heuristic; a zero density (delta scattering, stored as 0) counts as 1.
  float density_ratio(float rev, float fwd) const {
    const auto remap = [this](float f) {
      return f != 0.0f ? (it_.settings_.balance ? f : f * f) : 1.0f;
    };
    return remap(rev) / remap(fwd);
  }
  // One step of prepare_weights' camera-side partial sum: the sum a before vertex x (whose
  // predecessor on the subpath is `before`) carried across x, and stored there.
  float carry_camera_sum(float a, Vertex& x, const Vertex& before) const {
    const float c = !x.delta && !before.delta ? 1.0f : 0.0f;
    a = a + c > 0.0f ? density_ratio(x.pdf_rev, x.pdf_fwd) * (a + c) : 0.0f;
    x.mis_sum = a;
    return a;
  }
  // The smallest camera vertex index i whose strategy (s + t - i, i) exists: 1 (light tracing)
  // or 2.
  int first_camera_strategy() const { return it_.settings_.light_tracing ? 1 : 2; }

  // The caustic strategy (BdptSettings::caustic_paths; docs/BDPT.md). Its paths, "caustic paths",
  // end D S+ L: an emissive triangle L, one or more vertices on specular surfaces (every lobe a
  // delta), and before them a vertex D on a non-specular surface, not the camera, that scatters
  // by a non-delta lobe there and whose guide cell has photons. The strategy samples them from the
  // camera subpath as far as D, then the direction at D from the guide (density p_g) instead of
  // the Bsdf (p_b), then the specular vertices as the camera subpath would. It joins the others in
  // the power heuristic: its density over the camera subpath's own (s = 0) is n p_g / p_b with its
  // n = kCausticDirections samples, so with q = (n p_g / p_b)^2 (caustic_q_of) and w_0 the weight
  // of s = 0 among the other strategies, a path's weights
  // become w / (1 + q w_0) for every other strategy and q w_0 / (1 + q w_0) for this one.
  // q of the path of strategy (s, t) (light vertices [0, s), camera vertices [0, t), the camera
  // at `eye`), 0 where it is not a caustic path or the guide cannot sample it.
  float caustic_q(int s, int t, glm::vec3 eye) const;
  // The guide's strategy for sample k, after its connections are added (flush): at each camera
  // vertex with a guide cell, from the last to the first, kCausticDirections directions from the
  // guide, each followed through specular surfaces, its vertices written over the camera subpath
  // past that vertex (no longer read) so that the ratio walk weighs the path; every emitter met
  // after at least one specular surface adds its weighted term. Its numbers come from samplers
  // of their own, not from the sample's dimensions, so that nothing else the sample draws moves:
  // for camera vertex i a Sobol sequence of the pixel (the render's seed hashed with i), whose
  // point 8 s + j is direction j of the pixel's sample s (photon, direction in its cone, then each
  // specular vertex's lobe and direction). A pixel's guided directions at a vertex are thus
  // stratified together, as its samples are: each is still drawn from the guide's density, so
  // the estimate stays unbiased, and its variance falls. `pixel` is the sample's pixel index
  // (y width + x).
  void caustic_strategy(size_t k, const Sampler& sampler, uint32_t pixel);
  // BdptSettings::specular_view_rays for the wavefront's samples [0, count) that take them (their
  // `views`): each sample's rays from its own sampler of the pixel (a second seed, sample index
  // i n + j for its ray j of n), followed through specular surfaces only, traced a bounce of all of
  // them at a time; every emitter met after at least one specular surface (and the environment,
  // where a ray escapes after one) adds its term over n + 1 to the sample's radiance.
  void specular_views(const SampleBatch& batch, size_t first, size_t count);
  // Adds view ray term `term` of wavefront sample k (the pilot's tally: as an estimate every share
  // weighs alike).
  void add_view_term(size_t k, glm::vec3 term);
  Vertex view_vertex_;  // specular_views' scratch vertex
  // Whether camera vertices [1, t - 1) of the selected sample are all specular surfaces, at least
  // one: a path E S+ L ending at camera vertex t - 1, which specular_views samples too.
  bool seen_through_specular(int t) const {
    if (t < 3) return false;
    for (int i = 1; i < t - 1; ++i) {
      if (camera_[i].type != VertexType::kSurface || !camera_[i].specular) return false;
    }
    return true;
  }
  // The share of its estimate that a sample's own s = 0 term of an E S+ L path keeps.
  float view_share() const {
    return 1.0f / static_cast<float>(1 + it_.settings_.specular_view_rays);
  }
  // One incoherent ray (Accel::intersect's single ray takes the batch path, packets on small
  // trees).
  Hit trace_one(const Ray& ray) const {
    Hit hit;
    accel_.intersect_incoherent(std::span<const Ray>(&ray, 1), std::span<Hit>(&hit, 1));
    return hit;
  }
  // q of a path whose direction at D has guide density pg and Bsdf density pb: the power
  // heuristic's (or the balance heuristic's) ratio of the strategy's density, counting its
  // kCausticDirections samples (Veach 1997, sec. 9.2), to that of s = 0; at most 1e30.
  float caustic_q_of(float pg, float pb) const {
    const double ratio = kCausticDirections * static_cast<double>(pg) / static_cast<double>(pb);
    return static_cast<float>(std::min(it_.settings_.balance ? ratio : ratio * ratio, 1e30));
  }
  // s = 0 at camera vertex t - 1 of the selected sample on a caustic path (q > 0), outside the
  // pilot: queued with its weight w_0 / (1 + q w_0), which needs no shadow ray.
  void queue_caustic_s0(int t, glm::vec3 contribution, float q);

  const BdptIntegrator& it_;
  const Scene& scene_;
  const Accel& accel_;
  const CausticGuide* guide_ = nullptr;
  // The pilot's tally: each sample's contributions and work go there instead of the image.
  LightPathsTally* tally_ = nullptr;
  const BdptIntegrator::SpecularMask* mask_ = nullptr;
  uint64_t traced_ = 0;
  size_t first_ = 0;  // the wavefront's first sample in the batch
  // Per wavefront sample: its vertex counts, whether its camera subpath escaped, its radiance so
  // far, the splats' rounding number, an orthographic camera's lens offset for light tracing
  // (ortho_lens_point), its pixel and its count ratio for the weights.
  struct SampleState {
    int nc = 0, nl = 0;
    bool camera_escaped = false;
    bool views = false;  // takes specular_view_rays (its pixel is in the mask)
    glm::vec3 total{0.0f};
    float u_round = 0.0f;
    glm::vec2 lens_offset{0.0f};
    uint32_t pixel = 0;
    float pixel_ratio = 1.0f;
  };
  std::array<SampleState, kWavefront> state_{};
  // The selected sample's (select): its subpaths and its state.
  Vertex* light_ = nullptr;
  Vertex* camera_ = nullptr;
  SampleState* current_ = nullptr;
  size_t selected_ = kWavefront;
  glm::vec2 lens_offset_{0.0f};
  uint32_t pixel_ = 0;
  float pixel_ratio_ = 1.0f;
  // The wavefront's light image and adaptive sampling's pass.
  SplatBuffer* splats_ = nullptr;
  const SplatPass* pass_ = nullptr;
  // Connections waiting for their shadow rays, of any of the wavefront's samples (each sample's
  // in the order it made them).
  struct Pending {
    glm::vec3 contribution{0.0f};  // unweighted, if unblocked
    int s = 0, t = 0;
    int ray = -1;  // into rays_; -1: no shadow ray
    int px = 0, py = 0;
    float count_ratio = 1.0f;  // t = 1: the splat's pixel's (SplatPass::count_ratio)
    uint32_t sample = 0;       // the wavefront sample's index
    glm::vec3 dir{0.0f};       // t >= 2, s >= 1: the connection's direction (connection_weight)
    bool weighted = false;     // `contribution` is the weighted term (connect_camera_only)
    float caustic_q = 0.0f;    // s >= 1: the path's caustic_q (0: the recursion's weight)
    bool skip = false;         // a lane job's connection that carries nothing
  };
  static constexpr int kMaxPending = 256;
  std::array<Pending, kMaxPending> pending_{};
  std::array<Ray, kMaxPending> rays_{};
  std::array<uint8_t, kMaxPending> blocked_{};
  // The MIS weight of a queued connection, with its pixel's count ratio.
  float weight_of(const Pending& p) {
    return connection_weight(
        p.s, p.t, p.t == 1 ? p.count_ratio * it_.settings_.mis_count_scale : pixel_ratio_,
        p.t >= 2 && p.s >= 1 ? &p.dir : nullptr, p.caustic_q);
  }
  int pending_count_ = 0;
  int ray_count_ = 0;
  std::vector<std::pair<float, bool>> pilot_strategies_;  // pilot_record's
  // `--light-paths auto`'s pilot (BdptSettings::pilot): queued connection p's work, and its
  // contribution weighted at each candidate share, into the tally instead of the image.
  void pilot_record(const Pending& p);
};

void BdptTracer::surface_aovs(size_t k, glm::vec3& albedo, glm::vec3& normal) const {
  albedo = normal = glm::vec3(0.0f);
  const Vertex* camera = thread_subpaths()[k].camera.data();
  glm::vec3 tint(1.0f);
  for (int i = 1; i < state_[k].nc; ++i) {
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
  if (state_[k].camera_escaped) albedo = normal = glm::vec3(0.0f);
}

bool BdptTracer::make_surface(Vertex& x, const Ray& ray, const Hit& hit) const {
  x.type = VertexType::kSurface;
  x.point_light = x.directional = false;
  x.spot = nullptr;
  x.start_known = 0;
  x.prim = hit.prim;
  x.u = hit.u;
  x.v = hit.v;
  set_triangle(x, hit.prim, hit.u, hit.v);
  x.material = &scene_.materials[x.tri.material];
  x.smooth = shades_smooth(scene_, *x.material, hit.prim);
  x.ns = x.ng;
  if (x.smooth) {
    build_in_place(x.corners, [&] { return scene_.any_corners(hit.prim); });
    x.ns = surface_normal(scene_, *x.material, hit.prim, x.corners, hit.u, hit.v, x.ng);
  }
  build_in_place(x.frame, [&] { return Frame::from_normal(x.ns); });
  const glm::vec3 albedo = surface_albedo(scene_, *x.material, hit.prim, hit.u, hit.v);
  x.albedo = albedo;
  // Bsdf(material, albedo) of a diffuse material is one Lambert lobe (bsdf_eval above).
  x.lambert = x.material->is_diffuse() && !x.material->has_parameter_textures();
  if (x.lambert) {
    x.connectible = true;
  } else {
    build_in_place(x.bsdf, [&] {
      return x.material->has_parameter_textures()
                 ? Bsdf(material_at(scene_, *x.material, hit.prim, hit.u, hit.v), albedo)
                 : Bsdf(*x.material, albedo);
    });
    x.connectible = !x.bsdf.all_delta();
  }
  x.specular = !x.material->is_diffuse() && !x.connectible;
  x.two_sided = x.material->two_sided;
  x.emits = x.material->emits();
  x.delta = false;
  x.wo = -glm::normalize(ray.dir);
  return true;
}

void BdptTracer::set_triangle(Vertex& x, uint32_t prim, float b1, float b2) const {
  // A triangle of the scene's own mesh (stored_triangle's members) in registers, stored member by
  // member, and the point and normal computed from the registers: computed from x.tri's members
  // they were loaded as wider words than their stores had just written, and a whole triangle
  // copied through a temporary did the same (store-forwarding stalls, a sixth of the camera
  // walk's profile). Instanced triangles are built in place.
  if (prim < scene_.mesh.size()) {
    const TriangleMesh& mesh = scene_.mesh;
    const glm::vec3 v0 = mesh.v0()[prim], e1 = mesh.e1(prim), e2 = mesh.e2(prim);
    const glm::vec3 normal = mesh.normal()[prim];
    x.tri.v0 = v0;
    x.tri.e1 = e1;
    x.tri.e2 = e2;
    x.tri.normal = normal;
    x.tri.material = mesh.material()[prim];
    x.p = v0 + b1 * e1 + b2 * e2;
    x.ng = normal;
  } else {
    build_in_place(x.tri, [&] { return scene_.triangle(prim); });
    x.p = x.tri.v0 + b1 * x.tri.e1 + b2 * x.tri.e2;
    x.ng = x.tri.normal;
  }
}

void BdptTracer::walk_begin(std::vector<Vertex>& path, WalkState& w) {
  w.active = w.count < w.max_vertices;
  // Room for vertex `count` (references into `path` are taken after this only).
  if (w.active && static_cast<size_t>(w.count) >= path.size()) {
    path.resize(std::min(2 * path.size(), static_cast<size_t>(w.max_vertices)));
  }
}

bool BdptTracer::walk_hit(std::vector<Vertex>& path, WalkState& w, const Hit& hit,
                          bool& escaped) const {
  w.active = false;
  const bool light = w.light;
  if (!hit.found()) {
    if (!light) escaped = true;
    // A camera subpath that escapes meets the environment (strategy s = 0).
    if (!light && it_.has_environment_) {
      Vertex& e = path[static_cast<size_t>(w.count)];
      e.type = VertexType::kEnvironment;
      e.delta = e.point_light = e.directional = e.smooth = false;
      e.spot = nullptr;
      e.connectible = false;
      e.emits = true;
      e.w_env = glm::normalize(w.ray.dir);
      e.le = it_.environment_radiance(e.w_env);
      e.env_pdf_pos = it_.environment_pdf_pos_;
      e.beta = w.beta;
      e.pdf_fwd = w.pdf_dir;  // solid angle
      e.pdf_rev = 0.0f;
      ++w.count;
    }
    return false;
  }
  Vertex& prev = path[static_cast<size_t>(w.count - 1)];
  Vertex& x = path[static_cast<size_t>(w.count)];
  make_surface(x, w.ray, hit);
  x.beta = w.beta;
  x.pdf_fwd = measure_edge(w.pdf_dir, prev, x);
  // Light vertex 1 is where the strategies that light_paths thins out begin (s >= 2): its density
  // as the light subpath samples it counts light_paths times in the weights (prepare_weights and
  // mis_weight_recursive read it; mis_weight_walk divides it out and applies the counts itself).
  if (light && w.count == 1) x.pdf_fwd *= it_.settings_.light_paths;
  x.pdf_rev = 0.0f;
  return ++w.count < w.max_vertices;
}

void BdptTracer::walk_scatter(std::vector<Vertex>& path, WalkState& w,
                              const std::array<glm::vec2, 2>& u) const {
  const bool light = w.light;
  const int count = w.count;
  Vertex& prev = path[static_cast<size_t>(count - 2)];
  Vertex& x = path[static_cast<size_t>(count - 1)];
  const glm::vec2 u_choice = u[0];
  const glm::vec3 w_prev = x.wo;
  const Scatter sc = scatter(x, u_choice.x, u[1]);
  if (!sc.bs.valid()) return;
  const BsdfSample& bs = sc.bs;
  const glm::vec3 wo_local = sc.wo_local, w_next = sc.w_next;
  glm::vec3 factor = bs.weight;
  if (light) {
    // The adjoint: f_s(w_next, w_prev) |n_g . w_next| / pdf (Veach 1997, sections 5.2-5.3).
    const float cos_g_prev = std::abs(glm::dot(x.ng, w_prev));
    const float cos_s_next = std::abs(bs.wi.z);
    if (!(cos_g_prev > 0.0f && cos_s_next > 0.0f)) return;
    const float shading =
        std::abs(wo_local.z) * std::abs(glm::dot(x.ng, w_next)) / (cos_g_prev * cos_s_next);
    if (bs.delta) {
      // A delta refraction's weight carries radiance's 1 / eta^2; importance does not.
      factor = bs.weight * (shading / bs.radiance_scale);
    } else {
      factor = bsdf_eval(x, bs.wi, wo_local) * (cos_s_next * shading / bs.pdf);
    }
  }
  x.delta = bs.delta;
  x.aov_tint = bs.weight * (1.0f / bs.radiance_scale);
  const float pdf_rev_dir = bs.delta ? 0.0f : bsdf_pdf(x, bs.wi, wo_local);
  prev.pdf_rev = to_area_prev(pdf_rev_dir, x, prev);
  w.beta *= factor;
  w.rr_beta *= factor;
  if (count - 1 >= it_.settings_.roulette_depth) {
    const float survive = std::min(1.0f, std::sqrt(max_component(w.rr_beta)));
    if (!(u_choice.y < survive)) return;
    w.beta *= 1.0f / survive;
    w.rr_beta *= 1.0f / survive;
  }
  if (!(max_component(w.beta) > 0.0f) || !std::isfinite(max_component(w.beta))) return;
  w.pdf_dir = bs.delta ? 0.0f : bs.pdf;
  w.ray.origin = ray_start(x, w_next, it_.offset_);
  w.ray.dir = w_next;
  w.ray.tmin = 0.0f;
  w.ray.tmax = kRayTMax;
  walk_begin(path, w);
}

void BdptTracer::walk_all(std::vector<Vertex>* const* paths, WalkState* walks, Sampler* samplers,
                          bool* escaped, size_t count) {
  std::array<Ray, kWavefront> rays;
  std::array<Hit, kWavefront> hits;
  std::array<uint32_t, kWavefront> index;
  std::array<Sampler*, kWavefront> drawing{};
  std::array<std::array<glm::vec2, 2>, kWavefront> u{};
  // The active walks, in order, kept without a branch (which walks are active is random: the
  // branch mispredicted often). A walk that stops never starts again, so each bounce's list is
  // the previous one's walks still active: its later bounces go over the few walks left, not the
  // whole wavefront.
  size_t n = 0;
  for (size_t k = 0; k < count; ++k) {
    index[n] = static_cast<uint32_t>(k);
    n += walks[k].active ? 1 : 0;
  }
  for (;;) {
    if (n == 0) return;
    for (size_t j = 0; j < n; ++j) rays[j] = walks[index[j]].ray;
    // Incoherent rays, one query for the wavefront's bounce: on a small tree as packets, on a
    // large one interleaved (BvhAccel::intersect_incoherent); the hits are those of one ray at a
    // time, bit for bit.
    accel_.intersect_incoherent(std::span<const Ray>(rays.data(), n),
                                std::span<Hit>(hits.data(), n));
    traced_ += n;
    size_t m = 0;
    for (size_t j = 0; j < n; ++j) {
      if (will_draw(walks[index[j]], hits[j])) drawing[m++] = &samplers[index[j]];
    }
    draw_groups<2>(drawing.data(), m, u);
    step_bounce(paths, walks, index.data(), hits.data(), n, u.data(), escaped);
    size_t still = 0;
    for (size_t j = 0; j < n; ++j) {
      const uint32_t k = index[j];
      index[still] = k;
      still += walks[k].active ? 1 : 0;
    }
    n = still;
  }
}

void BdptTracer::step_bounce(std::vector<Vertex>* const* paths, WalkState* walks,
                             const uint32_t* index, const Hit* hits, size_t n,
                             const std::array<glm::vec2, 2>* u, bool* escaped) const {
  std::array<uint32_t, 8> lane_index;
  std::array<const Vertex*, 8> lane_vertex;
  std::array<const std::array<glm::vec2, 2>*, 8> lane_u;
  size_t lanes_used = 0;
  size_t m = 0;
  for (size_t j = 0; j < n; ++j) {
    const uint32_t k = index[j];
    const std::array<glm::vec2, 2>& uj = u[will_draw(walks[k], hits[j]) ? m++ : 0];
    // (walk_hit goes on exactly where will_draw held.)
    if (!walk_hit(*paths[k], walks[k], hits[j], escaped[k])) continue;
#if defined(TRITRACE_LANES)
    const Vertex& x = (*paths[k])[static_cast<size_t>(walks[k].count - 1)];
    if (it_.settings_.lanes && !walks[k].light && x.lambert && !x.smooth) {
      lane_index[lanes_used] = k;
      lane_vertex[lanes_used] = &x;
      lane_u[lanes_used++] = &uj;
      // Eight at a time, while their vertices are still in the first-level cache.
      if (lanes_used == lanes::kWidth) {
        walk_scatter_lanes(paths, walks, lane_index.data(), lane_vertex.data(), lane_u.data(),
                           lanes_used);
        lanes_used = 0;
      }
      continue;
    }
#endif
    walk_scatter(*paths[k], walks[k], uj);
  }
  if (lanes_used > 0) {
    walk_scatter_lanes(paths, walks, lane_index.data(), lane_vertex.data(), lane_u.data(),
                       lanes_used);
  }
}

#if defined(TRITRACE_LANES)
void BdptTracer::walk_scatter_lanes(std::vector<Vertex>* const* paths, WalkState* walks,
                                    const uint32_t* index, const Vertex* const* vertices,
                                    const std::array<glm::vec2, 2>* const* u, size_t n) const {
  using lanes::F;
  using lanes::I;
  using lanes::V3;
  constexpr size_t W = lanes::kWidth;
  // Per lane (lanes past n repeat lane 0 and are not written back) its vertex and walk: the runs
  // of floats they keep together transposed into registers, the rest gathered lane by lane (never
  // stored per lane and reloaded as vectors: store forwarding fails on such loads).
  std::array<const Vertex*, W> xs;
  std::array<const WalkState*, W> ws;
  for (size_t l = 0; l < W; ++l) {
    const size_t i = l < n ? l : 0;
    xs[l] = vertices[i];
    ws[l] = &walks[index[i]];
  }
  const auto lane = [](auto get) {
    return F{get(0), get(1), get(2), get(3), get(4), get(5), get(6), get(7)};
  };
  const auto lane_mask = [](auto get) {
    return I{get(0), get(1), get(2), get(3), get(4), get(5), get(6), get(7)};
  };
  const I edge_mask = lane_mask([&](size_t l) { return xs[l]->edge ? -1 : 0; });
  // The vertices' runs of floats (Vertex's layout notes), transposed eight lanes at a time.
  const void* const* rows = reinterpret_cast<const void* const*>(xs.data());
  F p_run[W], wo_run[W], pdf_run[W], frame_run[W], tri_run[W];
  lanes::transpose8(rows, offsetof(Vertex, p), p_run);             // p, ng, ns.x, ns.y
  lanes::transpose8(rows, offsetof(Vertex, wo), wo_run);           // wo, beta, albedo.x, .y
  lanes::transpose8(rows, offsetof(Vertex, albedo) + 8, pdf_run);  // albedo.z, pdf_fwd, ...
  lanes::transpose8(rows, offsetof(Vertex, frame), frame_run);     // frame.x, .y, .z.x, .z.y
  lanes::transpose8(rows, offsetof(Vertex, frame) + 32, tri_run);  // frame.z.z, v0, e1, e2.x
  const V3 fx = lanes::v3(frame_run), fy = lanes::v3(frame_run + 3);
  const V3 fz{frame_run[6], frame_run[7], tri_run[0]};
  // Frame::to_local(x.wo).
  const V3 w_prev = lanes::v3(wo_run);
  const V3 wo_local{lanes::dot(w_prev, fx), lanes::dot(w_prev, fy), lanes::dot(w_prev, fz)};
  // bsdf_sample's Lambert branch: wo turned up, sample_cosine_hemisphere (its concentric disk
  // with sincosf lane by lane), the density and the weight, then wi turned back.
  const I below = wo_local.z < 0.0f;
  const F wo_z = below ? -wo_local.z : wo_local.z;
  const I up = ~(wo_z <= 0.0f);
  const lanes::CosineSample cs = lanes::cosine_hemisphere(
      2.0f * lane([&](size_t l) { return (*u[l < n ? l : 0])[1].x; }) - 1.0f,
      2.0f * lane([&](size_t l) { return (*u[l < n ? l : 0])[1].y; }) - 1.0f);
  const F dx = cs.x, dy = cs.y, z = cs.z, pdf = cs.pdf;
  const I has_pdf = pdf > 0.0f;
  const V3 weight = lanes::select(
      has_pdf, V3{wo_run[6], wo_run[7], pdf_run[0]} * lanes::splat(kInvPi) * (z / pdf), V3{});
  const I valid = up & has_pdf & ((weight.x > 0.0f) | (weight.y > 0.0f) | (weight.z > 0.0f));
  const V3 wi{dx, dy, below ? -z : z};
  const V3 w_next = fx * wi.x + fy * wi.y + fz * wi.z;  // Frame::to_world
  // bsdf_pdf(x, wi, wo_local) (lambert_pdf), then to_area_prev towards the previous vertex.
  const I flip = wi.z < 0.0f;
  const F rev_o = flip ? -wi.z : wi.z, rev_i = flip ? -wo_local.z : wo_local.z;
  const F pdf_rev_dir = rev_o <= 0.0f ? F{} : (rev_i > 0.0f ? rev_i * kInvPi : F{});
  const F prev_pdf_rev = edge_mask ? pdf_rev_dir / pdf_run[4] * pdf_run[5] : F{};
  // The throughput, Russian roulette, and the walk's test of what is left.
  F beta_run[W];  // the walks' beta, rr_beta, pdf_dir and flags
  lanes::transpose8(reinterpret_cast<const void* const*>(ws.data()), offsetof(WalkState, beta),
                    beta_run);
  V3 beta_next = lanes::v3(beta_run) * weight;
  V3 rr_next = lanes::v3(beta_run + 3) * weight;
  const I rr = lane_mask(
      [&](size_t l) { return ws[l]->count - 1 >= it_.settings_.roulette_depth ? -1 : 0; });
  const F survive = lanes::min(lanes::splat(1.0f), lanes::sqrt(lanes::max_component(rr_next)));
  I alive = valid & (~rr | (lane([&](size_t l) { return (*u[l < n ? l : 0])[0].y; }) < survive));
  const F inverse = 1.0f / survive;
  beta_next = lanes::select(rr, beta_next * inverse, beta_next);
  rr_next = lanes::select(rr, rr_next * inverse, rr_next);
  const F largest = lanes::max_component(beta_next);
  alive &= (largest > 0.0f) & (lanes::abs(largest) <= std::numeric_limits<float>::max());
  // ray_start: leave_surface on the side w_next leaves to.
  const V3 n_lab = lanes::v3(p_run + 3);
  const I front = lanes::dot(n_lab, w_next) >= 0.0f;
  const V3 side = lanes::select(front, n_lab, -n_lab);
  const V3 e1v = lanes::v3(tri_run + 4),
           e2v{tri_run[7], lane([&](size_t l) { return xs[l]->tri.e2.y; }),
               lane([&](size_t l) { return xs[l]->tri.e2.z; })};
  const V3 start =
      lanes::leave_surface(lanes::v3(tri_run + 1), e1v, e2v, lanes::triangle_extent(e1v, e2v),
                           lanes::v3(p_run), side, it_.offset_);
  for (size_t l = 0; l < n; ++l) {
    if (!valid[l]) continue;
    WalkState& w = walks[index[l]];
    std::vector<Vertex>& path = *paths[index[l]];
    Vertex& x = path[static_cast<size_t>(w.count - 1)];
    x.delta = false;
    x.aov_tint = glm::vec3(weight.x[l], weight.y[l], weight.z[l]);
    path[static_cast<size_t>(w.count - 2)].pdf_rev = prev_pdf_rev[l];
    if (!alive[l]) continue;
    w.beta = glm::vec3(beta_next.x[l], beta_next.y[l], beta_next.z[l]);
    w.rr_beta = glm::vec3(rr_next.x[l], rr_next.y[l], rr_next.z[l]);
    w.pdf_dir = pdf[l];
    const glm::vec3 origin(start.x[l], start.y[l], start.z[l]);
    const bool f = front[l] != 0;
    x.start[f ? 0 : 1] = origin;
    x.start_known |= f ? 1 : 2;
    w.ray.origin = origin;
    w.ray.dir = glm::vec3(w_next.x[l], w_next.y[l], w_next.z[l]);
    w.ray.tmin = 0.0f;
    w.ray.tmax = kRayTMax;
    walk_begin(path, w);
  }
}
#else
void BdptTracer::walk_scatter_lanes(std::vector<Vertex>* const*, WalkState*, const uint32_t*,
                                    const Vertex* const*, const std::array<glm::vec2, 2>* const*,
                                    size_t) const {}
#endif

void BdptTracer::light_subpath(std::vector<Vertex>& path, int max_vertices,
                               const std::array<glm::vec2, 3>& u, bool walk, WalkState& w) const {
  const glm::vec2 u_choice = u[0], u_point = u[1], u_dir = u[2];
  w = WalkState{};
  w.light = true;
  w.max_vertices = max_vertices;
  if (it_.table_.empty() || max_vertices < 1) return;
  w.count = 1;
  const AliasTable::Sample pick = it_.table_.sample(u_choice.x);
  const BdptIntegrator::Emitter& e = it_.emitters_[pick.index];
  Vertex& x = path[0];
  x.type = VertexType::kLight;
  x.start_known = 0;
  x.connectible = true;
  x.wo = glm::vec3(0.0f);
  x.pdf_rev = 0.0f;
  x.directional = false;
  x.spot = nullptr;
  Ray& ray = w.ray;
  glm::vec3& beta = w.beta;
  float& pdf_dir = w.pdf_dir;
  if (e.directional) return directional_light_subpath(path, max_vertices, e, u_point, walk, w);
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
    if (!(x.pdf_fwd > 0.0f) || !(max_component(x.le) > 0.0f)) return;
    x.beta = glm::vec3(1.0f / x.pdf_fwd);
    if (!walk) return;
    const Frame frame = Frame::from_normal(x.w_env);
    const glm::vec2 d = sample_uniform_disk_concentric(u_point);
    const float r = it_.environment_radius_;
    ray.origin = it_.environment_centre_ + r * (x.w_env + d.x * frame.x + d.y * frame.y);
    ray.dir = -x.w_env;
    ray.tmin = 0.0f;
    ray.tmax = kRayTMax;
    beta = x.le * (1.0f / (x.pdf_fwd * x.env_pdf_pos));
    pdf_dir = x.env_pdf_pos;
    return walk_begin(path, w);
  }
  if (e.point || e.spot) {
    // Not delta in the MIS sense: a point (or spot) light can be connected to (its position is a
    // delta, which no camera subpath can hit: the weights test delta_light for that).
    x.point_light = true;
    x.delta = false;
    x.smooth = false;
    x.p = e.position;
    x.ng = x.ns = glm::vec3(0.0f);
    x.le = e.intensity;
    x.pdf_fwd = pick.pmf;
    x.beta = glm::vec3(1.0f / pick.pmf);
    if (e.spot) x.spot = &scene_.spot_lights[e.prim];
    if (!walk) return;
    glm::vec3 w;
    if (e.spot) {
      // A direction in the cone in proportion to its intensity (the vertex's le is the axis's).
      w = sample_spot_direction(*x.spot, u_point.x, u_dir);
      pdf_dir = spot_direction_pdf(*x.spot, w);
      if (!(pdf_dir > 0.0f)) return;
      beta = emission(scene_, x, w) * (1.0f / (pick.pmf * pdf_dir));
    } else {
      w = sample_uniform_sphere(u_dir);
      pdf_dir = uniform_sphere_pdf();
      beta = e.intensity * (1.0f / (pick.pmf * pdf_dir));
    }
    ray.origin = x.p;
    ray.dir = w;
  } else {
    x.point_light = false;
    x.delta = false;
    x.prim = e.prim;
    const glm::vec3 b = sample_uniform_triangle(u_point);
    set_triangle(x, e.prim, b.y, b.z);
    x.material = &scene_.materials[x.tri.material];
    x.two_sided = x.material->two_sided;
    x.emits = true;
    // Emission is taken flat (the lab normal), as the path tracer's light sampling does.
    x.smooth = false;
    x.u = b.y;
    x.v = b.z;
    x.ns = x.ng;
    x.pdf_fwd = pick.pmf / e.area;
    x.beta = glm::vec3(1.0f / x.pdf_fwd);
    // (x.le, the emission along the sampled direction, is read by nothing but this walk's start.)
    if (!walk) return;
    const bool back = x.two_sided && u_choice.y >= 0.5f;
    const glm::vec3 n = back ? -x.ng : x.ng;
    const glm::vec3 local = sample_cosine_hemisphere(u_dir);
    const glm::vec3 w = Frame::from_normal(n).to_world(local);
    pdf_dir = emission_pdf(x, w);
    const glm::vec3 le = emission(scene_, x, w);
    x.le = le;
    if (!(pdf_dir > 0.0f) || !(max_component(le) > 0.0f)) return;
    beta = le * (std::abs(glm::dot(x.ng, w)) / (x.pdf_fwd * pdf_dir));
    ray.origin = offset_ray_origin(x.p, n, triangle_extent(x.tri.e1, x.tri.e2), it_.offset_);
    ray.dir = w;
  }
  ray.tmin = 0.0f;
  ray.tmax = kRayTMax;
  walk_begin(path, w);
}

void BdptTracer::directional_light_subpath(std::vector<Vertex>& path, int max_vertices,
                                           const BdptIntegrator::Emitter& e, glm::vec2 u_point,
                                           bool walk, WalkState& w) const {
  // Parallel light from direction -l.direction: a ray along it from a point of the disk across it
  // that covers the scene's bounding sphere (density 1 / (pi R^2) by area, pbrt-v4's
  // DistantLight::SampleLe). The vertex is infinite, as the environment's, with the light's
  // irradiance as its le: a connection to it (s = 1) adds E |cos| f / pmf, the path tracer's
  // next-event estimate. Its direction is a delta (the pick's probability is its pdf_fwd), so no
  // camera subpath reaches it (delta_light).
  const DirectionalLight& l = scene_.directional_lights[e.prim];
  Vertex& x = path[0];
  x.type = VertexType::kEnvironment;
  x.directional = true;
  x.point_light = x.delta = x.smooth = false;
  x.emits = true;
  x.w_env = -l.direction;
  x.le = l.irradiance;
  x.env_pdf_pos = it_.environment_pdf_pos_;
  x.pdf_fwd = e.pmf;
  if (!(x.pdf_fwd > 0.0f) || !(max_component(x.le) > 0.0f)) return;
  x.beta = glm::vec3(1.0f / x.pdf_fwd);
  if (!walk) return;
  const Frame frame = Frame::from_normal(x.w_env);
  const glm::vec2 d = sample_uniform_disk_concentric(u_point);
  const float r = it_.environment_radius_;
  Ray& ray = w.ray;
  ray.origin = it_.environment_centre_ + r * (x.w_env + d.x * frame.x + d.y * frame.y);
  ray.dir = -x.w_env;
  ray.tmin = 0.0f;
  ray.tmax = kRayTMax;
  w.beta = x.le * (1.0f / (x.pdf_fwd * x.env_pdf_pos));
  w.pdf_dir = x.env_pdf_pos;
  (void)max_vertices;
  walk_begin(path, w);
}

bool BdptTracer::shadow_ray(const Vertex& c, const Vertex& l, glm::vec3 w, Ray& r) const {
  const glm::vec3 from = ray_start(c, w, it_.offset_);
  r.origin = from;
  r.tmin = 0.0f;
  if (infinite(l)) {
    r.dir = w;
    r.tmax = kRayTMax;
    return true;
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
  if (!(length > 0.0f && glm::dot(segment, w) > 0.0f)) return false;
  r.dir = segment * (1.0f / length);
  r.tmax = length;
  return true;
}

bool BdptTracer::camera_shadow_ray(const Vertex& l, glm::vec3 eye, glm::vec3 w, Ray& r) const {
  const glm::vec3 from = ray_start(l, w, it_.offset_);
  const glm::vec3 segment = eye - from;
  const float length = std::sqrt(glm::dot(segment, segment));
  if (!(length > 0.0f)) return false;
  r.origin = from;
  r.dir = segment * (1.0f / length);
  r.tmin = 0.0f;
  r.tmax = length;
  return true;
}

void BdptTracer::queue(int s, int t, glm::vec3 contribution, bool has_ray, const Ray& ray, int px,
                       int py, float count_ratio, glm::vec3 dir) {
  if (pending_count_ == kMaxPending) {
    // flush selects the samples it weighs: the caller's is selected again after it.
    const size_t caller = selected_;
    flush();
    select(caller);
  }
  Pending& p = pending_[static_cast<size_t>(pending_count_++)];
  p.contribution = contribution;
  p.s = s;
  p.t = t;
  p.px = px;
  p.py = py;
  p.count_ratio = count_ratio;
  p.dir = dir;
  p.sample = static_cast<uint32_t>(current_ - state_.data());
  p.weighted = false;
  p.caustic_q = 0.0f;
  p.skip = false;
  p.ray = -1;
  if (has_ray) {
    p.ray = ray_count_;
    rays_[static_cast<size_t>(ray_count_++)] = ray;
  }
}

void BdptTracer::flush() {
  run_lane_jobs();
  const auto n = static_cast<size_t>(ray_count_);
  if (n > 0) {
    accel_.occluded_incoherent(std::span<const Ray>(rays_.data(), n),
                               std::span<uint8_t>(blocked_.data(), n));
    traced_ += n;
  }
  const bool unweighted = it_.settings_.unweighted;
  for (int k = 0; k < pending_count_; ++k) {
    const Pending& p = pending_[static_cast<size_t>(k)];
    if (tally_ != nullptr) {
      pilot_record(p);  // the pilot connects every sample with the general code
      continue;
    }
    if (p.skip || (p.ray >= 0 && blocked_[static_cast<size_t>(p.ray)])) continue;
    if (p.weighted) {
      // connect_camera_only's term (t >= 2), weighted already: only its sample's total.
      const glm::vec3 term = p.contribution;
      if (std::isfinite(term.x + term.y + term.z)) state_[p.sample].total += term;
      continue;
    }
    select(p.sample);
    const glm::vec3 term = p.contribution * (unweighted ? 1.0f : weight_of(p));
    // Density ratios of vertices a few ULPs apart can overflow; such a term (measure zero) is
    // dropped rather than let a NaN or infinity into the pixel.
    if (!std::isfinite(term.x + term.y + term.z)) continue;
    if (p.t == 1) {
      float& u_round = current_->u_round;
      splats_->add(p.px, p.py, splat_value(term, p.count_ratio), u_round);
      // Each further splat shifts the rounding's number by the golden ratio: each stays uniform.
      u_round += 0.618034f;
      if (u_round >= 1.0f) u_round -= 1.0f;
    } else {
      current_->total += term;
    }
  }
  pending_count_ = ray_count_ = 0;
}

void BdptTracer::pilot_record(const Pending& p) {
  LightPathsTally::Sample& rec = tally_->samples[first_ + p.sample];
  const bool light = p.s >= 2;  // light tracing's t = 1 has s >= 2 too
  if (p.ray >= 0) ++(light ? rec.light_rays : rec.always_rays);
  if (p.ray >= 0 && blocked_[static_cast<size_t>(p.ray)]) return;
  const double v = luminance(p.contribution);
  if (!(v > 0.0) || p.s + p.t == 2) return;
  select(p.sample);
  // As connection_weight: light tracing to an orthographic lens joins this connection's lens point.
  Vertex& eye = camera_[0];
  const glm::vec3 saved = eye.p;
  if (p.t == 1 && scene_.camera.is_orthographic()) eye.p = ortho_lens_point(light_[p.s - 1].p);
  pilot_strategies_.clear();
  pilot_strategies_.emplace_back(1.0f, light);
  const float ratio = p.t == 1 ? p.count_ratio * it_.settings_.mis_count_scale : pixel_ratio_;
  (void)mis_weight_walk(light_, camera_, p.s, p.t, ratio, &pilot_strategies_, p.caustic_q);
  eye.p = saved;
  add_pilot_contribution(rec, v, p.t == 1, pilot_strategies_);
}

// The power heuristic over the strategies with t >= 2 that can sample the path of light vertices
// [0, s) and camera vertices [0, t), by the ratio walk of Veach 1997, section 10.2: moving the
// connection one vertex multiplies the strategy's density by pdf_rev / pdf_fwd of the vertex that
// changes sides. The connection's four neighbouring pdf_rev values are set for this path and
// restored afterwards.
float BdptTracer::mis_weight_walk(Vertex* light, Vertex* camera, int s, int t, float ratio,
                                  std::vector<std::pair<float, bool>>* strategies,
                                  float caustic_q) const {
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
    qs->pdf_rev = camera_area_pdf(pt, *qs);
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

  // Each strategy's number of samples per camera sample (Veach 1997, sec. 9.2: the heuristics
  // weigh n_i p_i): light tracing takes `ratio` light subpaths per camera sample of the pixel
  // (adaptive sampling; 1 otherwise), and the strategies with s >= 2 have light_paths' share of
  // the samples. Applied here as factors of whole strategies; the stored densities that carry
  // them for the recursion (camera vertex 1's pdf_fwd divided by the ratio, light vertex 1's
  // multiplied by light_paths) are undone below.
  const float light_paths = it_.settings_.light_paths;
  const auto count = [&](int ss, int tt) {
    return (ss >= 2 ? light_paths : 1.0f) * (tt == 1 ? ratio : 1.0f);
  };
  const float own = remap(count(s, t));
  float sum = 0.0f;
  float r = 1.0f;
  // Moving the connection to camera vertex i - 1 gives strategy (s + t - i, i). i = 1 is light
  // tracing, a strategy only with it on and with at least two light vertices ((1, 1), an emitter
  // seen by the camera, is left to (0, 2)).
  const int last_i = it_.settings_.light_tracing && s + t >= 3 ? 1 : 2;
  for (int i = t - 1; i >= last_i; --i) {
    const float fwd = i == 1 ? camera[1].pdf_fwd * ratio : camera[i].pdf_fwd;
    r *= remap(camera[i].pdf_rev) / remap(fwd);
    if (!camera[i].delta && !camera[i - 1].delta) {
      sum += r * remap(count(s + t - i, i)) / own;
      if (strategies) strategies->emplace_back(r, s + t - i >= 2);
    }
  }
  // Strategy s = 0's ratio to this one, and its term (with counts); this one's where s = 0.
  float s0_ratio = s == 0 ? 1.0f : 0.0f, s0_term = s0_ratio;
  r = 1.0f;
  for (int i = s - 1; i >= 0; --i) {
    const float fwd = i == 1 ? light[1].pdf_fwd / light_paths : light[i].pdf_fwd;
    r *= remap(light[i].pdf_rev) / remap(fwd);
    const bool delta_light_side = i > 0 ? light[i - 1].delta : delta_light(light[0]);
    if (!light[i].delta && !delta_light_side) {
      const float term = r * remap(count(i, s + t - i)) / own;
      sum += term;
      if (strategies) strategies->emplace_back(r, i >= 2);
      if (i == 0) s0_ratio = r, s0_term = term;
    }
  }

  pt.pdf_rev = saved_pt;
  pt_minus.pdf_rev = saved_pt_minus;
  pt.delta = saved_pt_delta;
  if (qs != nullptr) {
    qs->pdf_rev = saved_qs;
    qs->delta = saved_qs_delta;
  }
  if (qs_minus != nullptr) qs_minus->pdf_rev = saved_qs_minus;
  if (caustic_q > 0.0f && s0_term > 0.0f) {
    // The caustic strategy, sampled once per camera sample as s = 0 is.
    sum += s0_term * caustic_q;
    if (strategies) strategies->emplace_back(s0_ratio * caustic_q, false);
  }
  return 1.0f / (1.0f + sum);
}

// The walk's sums in O(1) per connection (the recursion of D. van Antwerpen, "Recursive MIS
// computation for streaming BDPT on the GPU", TU Delft 2011, and I. Georgiev, "Implementing
// Vertex Connection and Merging", 2012, with merging left out), written with the walk's
// completed ratios so that it keeps the walk's conventions term by term. On the camera side the
// walk sums, over the strategies (s + t - i, i) with m <= i <= t - 1 (m: first_camera_strategy),
//   S = sum_i c_i prod_{j=i..t-1} r_j,   r_j = density_ratio(pdf_rev_j, pdf_fwd_j),
// c_i = 1 where neither camera vertex i nor i - 1 scattered by a delta lobe. With the partial sums
//   A_k = sum_{i=m..k} c_i prod_{j=i..k} r_j = r_k (A_{k-1} + c_k),   A_{m-1} = 0,
// and since only r_{t-1}, r_{t-2} and c_{t-1} depend on the connection (the pdf_rev of its two
// nearest vertices; pt counts as not delta),
//   S = r'_{t-1} (c'_{t-1} + r'_{t-2} (c_{t-2} + A_{t-3})).
// The light side is the same with B_k over i >= 0, where vertex 0's "predecessor" is delta for a
// point, spot or directional light (no camera subpath hits one). prepare_weights stores A_k and B_k
// at vertex k.
void BdptTracer::prepare_weights(Vertex* light, int nl, Vertex* camera, int nc) const {
  const int m = first_camera_strategy();
  float a = 0.0f;
  for (int k = 0; k < nc; ++k) {
    Vertex& x = camera[k];
    if (k < m) {
      x.mis_sum = 0.0f;
      continue;
    }
    a = carry_camera_sum(a, x, camera[k - 1]);
  }
  float b = 0.0f;
  for (int k = 0; k < nl; ++k) {
    Vertex& x = light[k];
    const bool delta_before = k > 0 ? light[k - 1].delta : delta_light(light[0]);
    const float d = !x.delta && !delta_before ? 1.0f : 0.0f;
    b = b + d > 0.0f ? density_ratio(x.pdf_rev, x.pdf_fwd) * (b + d) : 0.0f;
    x.mis_sum = b;
  }
}

float BdptTracer::mis_weight_recursive(const Vertex* light, const Vertex* camera, int s, int t,
                                       float ratio, const glm::vec3* dir) const {
  if (s + t == 2) return 1.0f;  // an emitter seen by the camera: (1, 1) is not a strategy here
  const Vertex& pt = camera[t - 1];
  const Vertex* qs = s > 0 ? &light[s - 1] : nullptr;
  const Vertex* qs_minus = s > 1 ? &light[s - 2] : nullptr;
  // The four densities that depend on the connection, as the walk sets them.
  float pt_rev = 0.0f, pt_minus_rev = 0.0f, qs_rev = 0.0f, qs_minus_rev = 0.0f;
  if (t == 1) {
    qs_rev = light_tracing_camera_pdf(camera_area_pdf(pt, *qs), ratio);
    if (qs_minus != nullptr) qs_minus_rev = pdf_area(*qs, &pt, *qs_minus);
  } else {
    const Vertex& pt_minus = camera[t - 2];
    // The strategies with s >= 2 count light_paths (F) times: with s = 1 each strategy on the
    // camera side has s >= 2, so pt (light vertex 1 there) carries F; with s = 0 those past
    // (1, t - 1) do, through pt_minus. From s >= 2 the light side's (1, .) and (0, .) lose F
    // through light vertex 1's stored pdf_fwd (walk_hit).
    const float f = it_.settings_.light_paths;
    if (s > 0) {
      // pt is a surface vertex (connectible); qs a surface, light or environment vertex.
      // pdf_area_given's densities, with the edges towards pt_minus and qs_minus as the walks
      // measured them and the connection's distance measured once for both of its ends.
      const glm::vec3 w = dir != nullptr ? *dir : direction(pt, *qs);
      const glm::vec3 w_pt_minus = direction_prev(pt, pt_minus);
      const glm::vec3 w_qs_minus =
          qs_minus != nullptr ? direction_prev(*qs, *qs_minus) : glm::vec3(0.0f);
      const float qs_dir = infinite(*qs)                    ? qs->env_pdf_pos
                           : qs->type == VertexType::kLight ? emission_pdf(*qs, -w)
                                                            : surface_pdf(*qs, w_qs_minus, -w);
      const float pt_dir = surface_pdf(pt, w_pt_minus, w);
      if (infinite(*qs)) {
        pt_rev = to_area(qs_dir, *qs, pt);
        qs_rev = pt_dir;
      } else {
        // to_area both ways: d and -d give the same square and cosines' magnitudes.
        const glm::vec3 d = pt.p - qs->p;
        const float dist2 = glm::dot(d, d);
        if (dist2 > 0.0f) {
          const float length = std::sqrt(dist2);
          pt_rev = qs_dir / dist2 * (std::abs(glm::dot(pt.ng, d)) / length);
          qs_rev = pt_dir / dist2;
          if (!qs->point_light) qs_rev *= std::abs(glm::dot(qs->ng, d)) / length;
        }
      }
      if (s == 1) pt_rev *= f;
      pt_minus_rev = to_area_prev(surface_pdf(pt, w, w_pt_minus), pt, pt_minus);
      if (qs_minus != nullptr) {
        qs_minus_rev = to_area_prev(surface_pdf(*qs, -w, w_qs_minus), *qs, *qs_minus);
      }
    } else if (infinite(pt)) {
      pt_rev = it_.environment_pmf_ * it_.environment_dir_pdf(pt.w_env);
      pt_minus_rev = pdf_area(pt, nullptr, pt_minus) * f;
    } else {
      pt_rev = it_.origin_pdf(pt.prim);
      pt_minus_rev = to_area(emission_pdf(pt, direction(pt, pt_minus)), pt, pt_minus) * f;
    }
  }
  // ratio * (terms), with no ratio at all where the terms are 0 (an overflowed ratio times 0 is
  // not a NaN here, as the walk never multiplies it in).
  const auto scaled = [](float ratio, float terms) { return terms > 0.0f ? ratio * terms : 0.0f; };
  float sum = 0.0f;
  const int m = first_camera_strategy();
  if (t - 1 >= m) {
    const Vertex& pt_minus = camera[t - 2];
    float inner = 0.0f;
    if (t - 2 >= m) {
      const float before = t - 3 >= m ? camera[t - 3].mis_sum : 0.0f;
      const float c = !pt_minus.delta && !camera[t - 3].delta ? 1.0f : 0.0f;
      inner = scaled(density_ratio(pt_minus_rev, pt_minus.pdf_fwd), before + c);
    }
    sum += scaled(density_ratio(pt_rev, pt.pdf_fwd), inner + (pt_minus.delta ? 0.0f : 1.0f));
  }
  if (qs != nullptr) {
    float inner = 0.0f;
    if (qs_minus != nullptr) {
      const float before = s >= 3 ? light[s - 3].mis_sum : 0.0f;
      const bool delta_before = s >= 3 ? light[s - 3].delta : delta_light(light[0]);
      const float d = !qs_minus->delta && !delta_before ? 1.0f : 0.0f;
      inner = scaled(density_ratio(qs_minus_rev, qs_minus->pdf_fwd), before + d);
    }
    const bool delta_before = qs_minus != nullptr ? qs_minus->delta : delta_light(light[0]);
    sum += scaled(density_ratio(qs_rev, qs->pdf_fwd), inner + (delta_before ? 0.0f : 1.0f));
  }
  return 1.0f / (1.0f + sum);
}

float BdptTracer::mis_weight(Vertex* light, Vertex* camera, int s, int t, float ratio,
                             const glm::vec3* dir) const {
  const float w = mis_weight_recursive(light, camera, s, t, ratio, dir);
  if (BdptSettings::WeightCheck* check = it_.settings_.weight_check) {
    const float walked = mis_weight_walk(light, camera, s, t, ratio);
    // A NaN from either, but not both, is a difference that no tolerance passes.
    const double difference =
        std::isnan(w) && std::isnan(walked) ? 0.0 : std::abs(static_cast<double>(w) - walked);
    const std::lock_guard<std::mutex> lock(check->mutex);
    if (!(difference <= check->max_difference)) check->max_difference = difference;
    ++check->count;
  }
  return w;
}

float BdptTracer::mis_count_ratio(int x, int y) const {
  return (pass_ ? pass_->count_ratio(x, y) : 1.0f) * it_.settings_.mis_count_scale;
}

void BdptTracer::set_pass(size_t k, const SplatPass* pass, uint32_t pixel) {
  pass_ = pass;
  SampleState& st = state_[k];
  st.pixel = pixel;
  const auto [x, y] = pixel_xy(pixel, pass ? pass->width : 1);
  st.pixel_ratio = mis_count_ratio(x, y);
}

void BdptTracer::select(size_t k) {
  if (k == selected_) return;
  selected_ = k;
  Subpaths& sub = thread_subpaths()[k];
  camera_ = sub.camera.data();
  light_ = sub.light.data();
  current_ = &state_[k];
  lens_offset_ = current_->lens_offset;
  pixel_ = current_->pixel;
  pixel_ratio_ = current_->pixel_ratio;
}

float BdptTracer::connection_weight(int s, int t, float ratio, const glm::vec3* dir,
                                    float caustic_q) {
  const auto weigh = [&](const glm::vec3* d) {
    return caustic_q > 0.0f ? mis_weight_walk(light_, camera_, s, t, ratio, nullptr, caustic_q)
                            : mis_weight(light_, camera_, s, t, ratio, d);
  };
  if (t != 1 || !scene_.camera.is_orthographic()) return weigh(dir);
  Vertex& eye = camera_[0];
  const glm::vec3 saved = eye.p;
  eye.p = ortho_lens_point(light_[s - 1].p);
  const float w = weigh(nullptr);
  eye.p = saved;
  return w;
}

void BdptTracer::splat_light_subpath(int nl) {
  const BdptSettings& settings = it_.settings_;
  const bool only = settings.only_s >= 0 && settings.only_t >= 0;
  const Camera& cam = scene_.camera;
  const bool ortho = cam.is_orthographic();
  const Vertex* light = light_;
  for (int s = 2; s <= nl && s + 1 <= settings.max_depth + 2; ++s) {
    if (only && s != settings.only_s) continue;
    const Vertex& qs = light[s - 1];
    if (!qs.connectible || infinite(qs)) continue;
    // The camera's point: the pinhole, the camera subpath's lens point, or an orthographic lens's
    // point for qs.
    const glm::vec3 eye = ortho ? ortho_lens_point(qs.p) : camera_[0].p;
    const glm::vec3 d = eye - qs.p;
    const float dist2 = glm::dot(d, d);
    if (!(dist2 > 0.0f)) continue;
    const glm::vec3 w = d * (1.0f / std::sqrt(dist2));  // from qs towards the camera
    int px = 0, py = 0;
    if (!project(cam, eye, -w, px, py)) continue;
    // Adaptive sampling: not onto a pixel finished before this pass, nor in the pilot onto a
    // neighbour whose budget this sample's pixel helps set (SplatPass::keeps).
    if (pass_ && !pass_->keeps(pixel_, px, py)) continue;
    const glm::vec3 f_light = surface_f(qs, w, qs.wo);
    if (!(max_component(f_light) > 0.0f)) continue;
    const float g = std::abs(glm::dot(qs.ng, w)) / dist2;
    // Over light_paths' share of the samples (s >= 2 here).
    const glm::vec3 contribution =
        qs.beta * f_light * (g * camera_dir_pdf(cam, -w, dist2)) * it_.inverse_light_paths_;
    if (!(max_component(contribution) > 0.0f)) continue;
    Ray ray;
    // (w is glm::normalize(d), bit for bit.)
    const bool has_ray = camera_shadow_ray(qs, eye, w, ray);
    // The splat's sums, fetched for the atomic adds that flush makes: at a pixel anywhere in the
    // image, they are rarely in the cache.
    if (splats_ != nullptr) {
      const uint64_t* sums = splats_->raw(px, py);
      __builtin_prefetch(sums, 1);
      __builtin_prefetch(sums + 2, 1);
    }
    queue(s, 1, contribution, has_ray, ray, px, py, pass_ ? pass_->count_ratio(px, py) : 1.0f);
    pending_[static_cast<size_t>(pending_count_ - 1)].caustic_q = caustic_q(s, 1, eye);
  }
}

void BdptTracer::wavefront(const SampleBatch& batch, const SampleOutput& out, const Hit* first_hits,
                           size_t first, size_t count) {
  const BdptSettings& settings = it_.settings_;
  const int max_camera = settings.max_depth + 2;
  const int max_light = settings.max_depth + 1;
  std::array<Subpaths, kWavefront>& subs = thread_subpaths();
  std::array<WalkState, kWavefront> walks;
  std::array<std::vector<Vertex>*, kWavefront> paths{};
  std::array<bool, kWavefront> escaped{};
  Sampler* samplers = batch.samplers.data() + first;
  selected_ = kWavefront;
  first_ = first;
  splats_ = out.splats;
  // The camera subpaths: their first vertices at the given hits, then bounce by bounce.
  for (size_t k = 0; k < count; ++k) {
    Subpaths& sub = subs[k];
    if (sub.camera.empty()) {
      sub.camera.resize(kInitialSubpathVertices);
      sub.light.resize(kInitialSubpathVertices);
    }
    set_pass(k, out.pass, out.pass ? batch.pixels[first + k] : 0);
    SampleState& st = state_[k];
    st.camera_escaped = false;
    st.total = glm::vec3(0.0f);
    st.views = false;
    if (mask_ != nullptr && !batch.pixels.empty()) {
      const uint32_t pixel = batch.pixels[first + k];
      st.views = pixel < mask_->pixels.size() && mask_->pixels[pixel] != 0;
    }
    const Ray& camera_ray = batch.rays[first + k];
    Vertex& c0 = sub.camera[0];
    c0.type = VertexType::kCamera;
    c0.p = camera_ray.origin;
    c0.delta = false;
    c0.point_light = c0.directional = false;
    c0.spot = nullptr;
    c0.beta = glm::vec3(1.0f);
    c0.pdf_fwd = c0.pdf_rev = 0.0f;
    // The camera's density of the ray: the first camera vertex's pdf_fwd, read by the weights of
    // light tracing (1 stands for it without).
    WalkState& w = walks[k];
    w = WalkState{};
    w.count = 1;
    w.max_vertices = max_camera;
    w.ray = camera_ray;
    w.beta = glm::vec3(1.0f);
    w.pdf_dir = settings.light_tracing
                    ? light_tracing_camera_pdf(
                          camera_pdf(scene_.camera, glm::normalize(camera_ray.dir)), st.pixel_ratio)
                    : 1.0f;
    paths[k] = &sub.camera;
    escaped[k] = false;
    walk_begin(sub.camera, w);
  }
  // The light subpaths' first three groups (the emitter and side, the point, the emission
  // direction), drawn by every sample before its camera walk, so that they are the same dimensions
  // in every sample of a pixel (the camera walk's length varies): the Sobol sampler stratifies
  // the light vertex that next-event estimation (s = 1) connects to across the pixel's samples,
  // as the path tracer's light sample at each vertex is.
  std::array<Sampler*, kWavefront> all{};
  for (size_t k = 0; k < count; ++k) all[k] = &samplers[k];
  std::array<std::array<glm::vec2, 3>, kWavefront> u_light;
  draw_groups<3>(all.data(), count, u_light);
  {
    std::array<Sampler*, kWavefront> drawing{};
    std::array<std::array<glm::vec2, 2>, kWavefront> u{};
    size_t m = 0;
    for (size_t k = 0; k < count; ++k) {
      if (walks[k].active && will_draw(walks[k], first_hits[first + k])) {
        drawing[m++] = &samplers[k];
      }
    }
    draw_groups<2>(drawing.data(), m, u);
    std::array<uint32_t, kWavefront> index;
    std::array<Hit, kWavefront> hits;
    size_t n = 0;
    for (size_t k = 0; k < count; ++k) {
      if (!walks[k].active) continue;
      index[n] = static_cast<uint32_t>(k);
      hits[n++] = first_hits[first + k];
    }
    step_bounce(paths.data(), walks.data(), index.data(), hits.data(), n, u.data(), escaped.data());
  }
  walk_all(paths.data(), walks.data(), samplers, escaped.data(), count);
  for (size_t k = 0; k < count; ++k) {
    Subpaths& sub = subs[k];
    SampleState& st = state_[k];
    st.nc = walks[k].count;
    st.camera_escaped = escaped[k];
    if (settings.light_tracing && scene_.camera.is_orthographic() && st.nc >= 2 &&
        !infinite(sub.camera[1])) {
      // An orthographic lens's density depends on the distance to the first hit (ortho_lens_pdf).
      sub.camera[1].pdf_fwd =
          light_tracing_camera_pdf(camera_area_pdf(sub.camera[0], sub.camera[1]), st.pixel_ratio);
    }
    // A sample outside light_paths' share keeps only the light subpath's first vertex (for s = 1).
    light_subpath(sub.light, max_light, u_light[k],
                  traces_light_subpath(samplers[k], settings.light_paths), walks[k]);
    paths[k] = &sub.light;
  }
  walk_all(paths.data(), walks.data(), samplers, escaped.data(), count);
  // The connections, sample by sample; their shadow rays queued across samples.
  pending_count_ = ray_count_ = 0;
  for (size_t k = 0; k < count; ++k) {
    state_[k].nl = walks[k].count;
    if (LightPathsTally* tally = tally_) {
      LightPathsTally::Sample& rec = tally->samples[first + k];
      rec.camera_vertices = static_cast<uint32_t>(state_[k].nc);
      rec.light_vertices = static_cast<uint32_t>(std::max(0, state_[k].nl - 1));
    }
    connect(k, samplers[k]);
  }
  flush();
  if (mask_ != nullptr) specular_views(batch, first, count);
  for (size_t k = 0; k < count; ++k) {
    if (!out.albedo.empty() || !out.normal.empty()) {
      glm::vec3 albedo, normal;
      surface_aovs(k, albedo, normal);
      if (!out.albedo.empty()) out.albedo[first + k] = albedo;
      if (!out.normal.empty()) out.normal[first + k] = normal;
    }
    // (After the AOVs: it writes over the camera subpath.)
    if (guide_ != nullptr) caustic_strategy(k, samplers[k], batch.pixels[first + k]);
    out.radiance[first + k] = state_[k].total;
  }
}

void BdptTracer::connect_camera_only(size_t k) {
  const BdptSettings& settings = it_.settings_;
  select(k);
  const int nc = current_->nc, nl = current_->nl;
  Vertex* camera = camera_;
  Vertex* light = light_;
  const bool weighted = !settings.unweighted;
  const int m = first_camera_strategy();
  // prepare_weights' camera side (the light side's one vertex has no partial sum that s = 1
  // reads), a vertex at a time just before the connections that read it.
  float a = 0.0f;
  const auto partial_sum = [&](int i) {
    Vertex& x = camera[i];
    if (i < m) {
      x.mis_sum = 0.0f;
      return;
    }
    a = carry_camera_sum(a, x, camera[i - 1]);
  };
  if (weighted && nc > 0) partial_sum(0);
#if defined(TRITRACE_LANES)
  // Whether the connections s = 1 can go to the lanes (run_lane_jobs): the light vertex is a point
  // of an emissive triangle without an emission texture.
  const bool lane_ready = settings.lanes && settings.weight_check == nullptr && nl >= 1 &&
                          light[0].type == VertexType::kLight && !light[0].point_light &&
                          !light[0].material->emission_texture.present();
#endif
  // Queues the weighted term of connection (s, t).
  const auto add = [&](int s, int t, glm::vec3 contribution, bool has_ray, const Ray& ray,
                       const glm::vec3* dir) {
    const float weight = weighted ? mis_weight(light, camera, s, t, pixel_ratio_, dir) : 1.0f;
    queue(s, t, contribution * weight, has_ray, ray);
    pending_[static_cast<size_t>(pending_count_ - 1)].weighted = true;
  };
  for (int t = 2; t <= nc; ++t) {
    if (weighted) partial_sum(t - 1);
    const Vertex& pt = camera[t - 1];
    // s = 0 (t <= nc <= max_depth + 2).
    if (pt.emits) {
      glm::vec3 contribution = pt.beta * emission(scene_, pt, pt.wo);
      if (current_->views && seen_through_specular(t)) contribution *= view_share();
      if (max_component(contribution) > 0.0f) {
        const float q = caustic_q(0, t, camera[0].p);
        if (q > 0.0f) {
          queue_caustic_s0(t, contribution, q);
        } else {
          add(0, t, contribution, false, Ray{}, nullptr);
        }
      }
    }
    // s = 1: next-event estimation to the light subpath's first vertex (connect's arithmetic).
    if (nl < 1 || 1 + t > settings.max_depth + 2) continue;
    const Vertex& qs = light[0];
#if defined(TRITRACE_LANES)
    if (lane_ready && pt.lambert && !pt.smooth && pt.edge) {
      queue(1, t, glm::vec3(0.0f), false, Ray{});  // run_lane_jobs adds its ray
      pending_[static_cast<size_t>(pending_count_ - 1)].weighted = true;
      LaneJob& job = lane_jobs_[lane_job_count_++];
      job.pt = &pt;
      job.light = &qs;
      job.pending = pending_count_ - 1;
      const Vertex& pt_minus = camera[t - 2];
      job.has_outer = t - 1 >= m;
      job.has_inner = t - 2 >= m;
      job.inner_terms = 0.0f;
      if (t - 2 >= m) {
        const float before = t - 3 >= m ? camera[t - 3].mis_sum : 0.0f;
        const float c = !pt_minus.delta && !camera[t - 3].delta ? 1.0f : 0.0f;
        job.inner_terms = before + c;
      }
      job.outer_add = pt_minus.delta ? 0.0f : 1.0f;
      if (lane_job_count_ == lane_jobs_.size()) run_lane_jobs();
      continue;
    }
#endif
    if (!pt.connectible || !qs.connectible) continue;
    const glm::vec3 d = infinite(qs) ? qs.w_env : qs.p - pt.p;
    const float dist2 = infinite(qs) ? 1.0f : glm::dot(d, d);
    if (!(dist2 > 0.0f)) continue;
    const glm::vec3 w = d * (1.0f / std::sqrt(dist2));
    const glm::vec3 f_camera = surface_f(pt, pt.wo, w);
    if (!(max_component(f_camera) > 0.0f)) continue;
    const glm::vec3 f_light = emission(scene_, qs, -w);
    if (!(max_component(f_light) > 0.0f)) continue;
    const float cos_light = qs.point_light || infinite(qs) ? 1.0f : std::abs(glm::dot(qs.ng, w));
    const float g = std::abs(glm::dot(pt.ng, w)) * cos_light / dist2;
    const glm::vec3 contribution = pt.beta * f_camera * (g * f_light) * qs.beta;
    if (!(max_component(contribution) > 0.0f)) continue;
    Ray ray;
    const bool has_ray = shadow_ray(pt, qs, w, ray);
    add(1, t, contribution, has_ray, ray, &w);
  }
}

#if defined(TRITRACE_LANES)
void BdptTracer::run_lane_jobs() {
  const size_t n = lane_job_count_;
  if (n == 0) return;
  lane_job_count_ = 0;
  using lanes::F;
  using lanes::I;
  using lanes::V3;
  constexpr size_t W = lanes::kWidth;
  const BdptSettings& settings = it_.settings_;
  // Per lane (lanes past n repeat lane 0 and are not written back) its vertices: the runs of
  // floats they keep together transposed into registers, the rest gathered lane by lane (never
  // stored per lane and reloaded as vectors: store forwarding fails on such loads).
  std::array<const LaneJob*, W> jobs;
  std::array<const Vertex*, W> pts, minus, lights;
  for (size_t l = 0; l < W; ++l) {
    jobs[l] = &lane_jobs_[l < n ? l : 0];
    pts[l] = jobs[l]->pt;
    minus[l] = jobs[l]->pt - 1;
    lights[l] = jobs[l]->light;
  }
  const auto lane = [](auto get) {
    return F{get(0), get(1), get(2), get(3), get(4), get(5), get(6), get(7)};
  };
  const auto lane_mask = [](auto get) {
    return I{get(0), get(1), get(2), get(3), get(4), get(5), get(6), get(7)};
  };
  // The vertices' runs of floats (Vertex's layout notes), transposed eight lanes at a time.
  const auto runs = [](const std::array<const Vertex*, W>& v, size_t offset, F* out) {
    lanes::transpose8(reinterpret_cast<const void* const*>(v.data()), offset, out);
  };
  // The camera vertex's frame.z is its ns (Frame::from_normal(ns)'s z): read from the first
  // cache lines, its frame's (the third) is not touched.
  F pt_p_run[W], pt_wo_run[W], pt_pdf_run[W], pt_tri_run[W];
  runs(pts, offsetof(Vertex, p), pt_p_run);             // p, ng, ns.x, ns.y
  runs(pts, offsetof(Vertex, ns) + 8, pt_wo_run);       // ns.z, wo, beta, albedo.x
  runs(pts, offsetof(Vertex, albedo) + 4, pt_pdf_run);  // albedo.y, .z, pdf_fwd, ..., to_prev.x
  runs(pts, offsetof(Vertex, tri), pt_tri_run);         // v0, e1, e2.x, e2.y
  F qs_p_run[W], qs_wo_run[W], qs_pdf_run[W], qs_tri_run[W];
  runs(lights, offsetof(Vertex, p), qs_p_run);             // p, ng, ns.x, ns.y
  runs(lights, offsetof(Vertex, wo), qs_wo_run);           // wo, beta, albedo.x, .y
  runs(lights, offsetof(Vertex, albedo) + 8, qs_pdf_run);  // albedo.z, pdf_fwd, ...
  runs(lights, offsetof(Vertex, tri) + 12, qs_tri_run);    // e1, e2, normal.x, normal.y
  const I has_outer = lane_mask([&](size_t l) { return jobs[l]->has_outer ? -1 : 0; });
  const I has_inner = lane_mask([&](size_t l) { return jobs[l]->has_inner ? -1 : 0; });
  const F inner_terms = lane([&](size_t l) { return jobs[l]->inner_terms; });
  const F outer_add = lane([&](size_t l) { return jobs[l]->outer_add; });
  const V3 pt_p = lanes::v3(pt_p_run), pt_ng = lanes::v3(pt_p_run + 3);
  const V3 frame_z{pt_p_run[6], pt_p_run[7], pt_wo_run[0]};
  const V3 qs_p = lanes::v3(qs_p_run), qs_ng = lanes::v3(qs_p_run + 3);
  const V3 pt_wo = lanes::v3(pt_wo_run + 1), pt_albedo{pt_wo_run[7], pt_pdf_run[0], pt_pdf_run[1]},
           pt_beta = lanes::v3(pt_wo_run + 4),
           pt_to_prev{pt_pdf_run[7], lane([&](size_t l) { return pts[l]->to_prev.y; }),
                      lane([&](size_t l) { return pts[l]->to_prev.z; })};
  const V3 pt_v0 = lanes::v3(pt_tri_run), pt_e1 = lanes::v3(pt_tri_run + 3),
           pt_e2{pt_tri_run[6], pt_tri_run[7], lane([&](size_t l) { return pts[l]->tri.e2.z; })};
  const V3 qs_e1 = lanes::v3(qs_tri_run), qs_e2 = lanes::v3(qs_tri_run + 3),
           qs_beta = lanes::v3(qs_wo_run + 3);
  const V3 qs_le{lane([&](size_t l) { return lights[l]->material->emission.x; }),
                 lane([&](size_t l) { return lights[l]->material->emission.y; }),
                 lane([&](size_t l) { return lights[l]->material->emission.z; })};
  const F pt_fwd = pt_pdf_run[2], edge_dist2 = pt_pdf_run[5], prev_factor = pt_pdf_run[6],
          minus_fwd = lane([&](size_t l) { return minus[l]->pdf_fwd; }), q_fwd = qs_pdf_run[1];
  const I sided = lane_mask([&](size_t l) { return lights[l]->two_sided ? -1 : 0; });
  // connect_camera_only's scalar s = 1, term by term.
  const V3 d = qs_p - pt_p;
  const F dist2 = lanes::dot(d, d);
  I keep = dist2 > 0.0f;
  const V3 w = d * (1.0f / lanes::sqrt(dist2));
  const V3 minus_w = -w;
  // surface_f (flat: no shading factor) with lambert_eval.
  const F cos_g = lanes::abs(lanes::dot(pt_ng, w));
  F wo_z = lanes::dot(pt_wo, frame_z), wi_z = lanes::dot(w, frame_z);
  {
    const I flip = wo_z < 0.0f;
    wo_z = flip ? -wo_z : wo_z;
    wi_z = flip ? -wi_z : wi_z;
  }
  const I f_nonzero = (cos_g > 0.0f) & ~((wo_z <= 0.0f) | (wi_z <= 0.0f));
  const V3 f_camera = lanes::select(f_nonzero, pt_albedo * lanes::splat(kInvPi), V3{});
  keep &= lanes::max_component(f_camera) > 0.0f;
  // emission: emitted_radiance of the light's material towards -w.
  const F c_light = lanes::dot(qs_ng, minus_w);
  const V3 f_light = lanes::select(sided | (c_light > 0.0f), qs_le, V3{});
  keep &= lanes::max_component(f_light) > 0.0f;
  const F cos_light = lanes::abs(lanes::dot(qs_ng, w));
  const F g = cos_g * cos_light / dist2;
  const V3 contribution = pt_beta * f_camera * (g * f_light) * qs_beta;
  keep &= lanes::max_component(contribution) > 0.0f;
  // shadow_ray: ray_start at pt (leave_surface on w's side), the light's end
  // moved off its surface towards pt and stopped short.
  const I front = lanes::dot(pt_ng, w) >= 0.0f;
  const V3 side = lanes::select(front, pt_ng, -pt_ng);
  const V3 from = lanes::leave_surface(pt_v0, pt_e1, pt_e2, lanes::triangle_extent(pt_e1, pt_e2),
                                       pt_p, side, it_.offset_);
  const V3 side_l = lanes::select(lanes::dot(qs_ng, w) <= 0.0f, qs_ng, -qs_ng);
  const V3 end =
      lanes::offset_ray_origin(qs_p, side_l, lanes::triangle_extent(qs_e1, qs_e2), it_.offset_);
  const V3 end_segment = end - from;
  const V3 to = end + side_l * (kRayEndScale * lanes::sqrt(lanes::dot(end_segment, end_segment)));
  const V3 segment = to - from;
  const F length = lanes::sqrt(lanes::dot(segment, segment));
  const I has_ray = (length > 0.0f) & (lanes::dot(segment, w) > 0.0f);
  const V3 ray_dir = segment * (1.0f / length);
  // mis_weight_recursive for s = 1.
  F weight = lanes::splat(1.0f);
  if (!settings.unweighted) {
    const bool balance = settings.balance;
    const auto remap = [balance](F f) { return f != 0.0f ? (balance ? f : f * f) : 1.0f; };
    const auto ratio = [&](F rev, F fwd) { return remap(rev) / remap(fwd); };
    const auto scaled = [](F r, F terms) { return terms > 0.0f ? r * terms : F{}; };
    const auto lambert_pdf = [](F given_z, F sampled_z) {
      const I flip = given_z < 0.0f;
      const F o = flip ? -given_z : given_z, i = flip ? -sampled_z : sampled_z;
      return o <= 0.0f ? F{} : (i > 0.0f ? i * kInvPi : F{});
    };
    const V3 w_pt_minus = pt_to_prev;
    const F qs_dir =
        sided ? 0.5f * lanes::abs(c_light) * kInvPi : (c_light > 0.0f ? c_light * kInvPi : F{});
    const F minus_z = lanes::dot(w_pt_minus, frame_z), w_z = lanes::dot(w, frame_z);
    const F pt_dir = lambert_pdf(minus_z, w_z);
    const V3 d2 = pt_p - qs_p;
    const F dist2b = lanes::dot(d2, d2);
    const I apart = dist2b > 0.0f;
    const F len2 = lanes::sqrt(dist2b);
    F pt_rev = apart ? qs_dir / dist2b * (lanes::abs(lanes::dot(pt_ng, d2)) / len2) : F{};
    F qs_rev = apart ? pt_dir / dist2b : F{};
    qs_rev = apart ? qs_rev * (lanes::abs(lanes::dot(qs_ng, d2)) / len2) : qs_rev;
    pt_rev *= settings.light_paths;
    const F pt_minus_rev = lambert_pdf(w_z, minus_z) / edge_dist2 * prev_factor;
    const F inner = has_inner ? scaled(ratio(pt_minus_rev, minus_fwd), inner_terms) : F{};
    const F outer = has_outer ? scaled(ratio(pt_rev, pt_fwd), inner + outer_add) : F{};
    F sum = F{} + outer;
    sum = sum + scaled(ratio(qs_rev, q_fwd), F{} + 1.0f);
    weight = 1.0f / (1.0f + sum);
  }
  const V3 term = contribution * weight;
  for (size_t l = 0; l < n; ++l) {
    Pending& pending = pending_[static_cast<size_t>(lane_jobs_[l].pending)];
    if (!keep[l]) {
      pending.skip = true;
      continue;
    }
    pending.contribution = glm::vec3(term.x[l], term.y[l], term.z[l]);
    if (has_ray[l]) {
      // (At most one ray per queued connection: rays_ has room.)
      pending.ray = ray_count_++;
      Ray& r = rays_[static_cast<size_t>(pending.ray)];
      r.origin = glm::vec3(from.x[l], from.y[l], from.z[l]);
      r.dir = glm::vec3(ray_dir.x[l], ray_dir.y[l], ray_dir.z[l]);
      r.tmin = 0.0f;
      r.tmax = length[l];
    }
  }
}
#else
void BdptTracer::run_lane_jobs() {}
#endif

void BdptTracer::connect(size_t k, Sampler& sampler) {
  const BdptSettings& settings = it_.settings_;
  // (The pilot's tally reads each connection's vertices, which only the general code queues.)
  if (settings.camera_only_connect && tally_ == nullptr && state_[k].nl <= 1 &&
      !(settings.only_s >= 0 && settings.only_t >= 0)) {
    connect_camera_only(k);
    return;
  }
  select(k);
  const int nc = current_->nc, nl = current_->nl;
  Vertex* camera = camera_;
  Vertex* light = light_;
  if (!settings.unweighted) prepare_weights(light, nl, camera, nc);

  const bool only = settings.only_s >= 0 && settings.only_t >= 0;
  for (int t = 2; t <= nc; ++t) {
    for (int s = 0; s <= nl && s + t <= settings.max_depth + 2; ++s) {
      if (only && (s != settings.only_s || t != settings.only_t)) continue;
      const Vertex& pt = camera[t - 1];
      glm::vec3 contribution(0.0f);
      glm::vec3 dir(0.0f);
      Ray ray;
      bool has_ray = false;
      float s0_caustic_q = 0.0f;
      if (s == 0) {
        if (!pt.emits) continue;
        contribution = pt.beta * emission(scene_, pt, pt.wo);
        if (current_->views && seen_through_specular(t)) contribution *= view_share();
        const float q = caustic_q(0, t, camera[0].p);
        if (q > 0.0f && tally_ == nullptr) {
          if (max_component(contribution) > 0.0f) queue_caustic_s0(t, contribution, q);
          continue;
        }
        // (The pilot weighs it by the walk with the caustic strategy, in pilot_record.)
        s0_caustic_q = q;
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
        // w is direction(pt, qs), bit for bit (glm::normalize is d / sqrt(d . d) written the same
        // way; the environment's w_env times 1), for the shadow ray and the weight.
        has_ray = shadow_ray(pt, qs, w, ray);
        dir = w;
      }
      if (!(max_component(contribution) > 0.0f)) continue;
      // Strategies past the light subpath's first vertex have light_paths' share of the samples.
      if (s >= 2) contribution *= it_.inverse_light_paths_;
      queue(s, t, contribution, has_ray, ray, 0, 0, 1.0f, dir);
      pending_[static_cast<size_t>(pending_count_ - 1)].caustic_q =
          s >= 1 ? caustic_q(s, t, camera[0].p) : s0_caustic_q;
    }
  }
  // The renderer always gives an integrator that splats its film's light image
  // (SampleOutput::splats); without one the light image is missing, never written out of bounds.
  assert(!settings.light_tracing || splats_ != nullptr);
  // A light subpath of one vertex makes no splat (s >= 2): its sample draws no numbers for them
  // (the last a sample draws; each sample's numbers start afresh, so nothing else moves).
  if (settings.light_tracing && splats_ != nullptr && !(only && settings.only_t != 1) && nl >= 2) {
    // One number per sample for the splats' stochastic rounding (SplatBuffer::add), drawn after
    // every dimension the subpaths use.
    current_->u_round = sampler.get_1d();
    if (scene_.camera.is_orthographic()) {
      // Light tracing's lens offset for an orthographic camera (ortho_lens_point), one per sample.
      current_->lens_offset =
          scene_.camera.lens_radius() * sample_uniform_disk_concentric(sampler.get_2d());
      lens_offset_ = current_->lens_offset;
    }
    splat_light_subpath(nl);
  }
}

float BdptTracer::caustic_q(int s, int t, glm::vec3 eye) const {
  if (guide_ == nullptr) return 0.0f;
  // The path's vertices from the light's end: light[0, s), then camera[t - 1] down to camera[0].
  const int n = s + t;
  const auto at = [&](int k) -> const Vertex& { return k < s ? light_[k] : camera_[n - 1 - k]; };
  const Vertex& l = at(0);
  if (s >= 1 ? l.type != VertexType::kLight || l.point_light || l.directional
             : l.type != VertexType::kSurface) {
    return 0.0f;
  }
  int k = 1;
  while (k < n && at(k).type == VertexType::kSurface && at(k).specular) ++k;
  if (k == 1 || k >= n - 1) return 0.0f;  // no specular vertex, or none but the camera before
  const Vertex& d = at(k);
  if (d.type != VertexType::kSurface || !d.connectible) return 0.0f;
  // A connection's end scatters by a non-delta lobe; elsewhere the subpath's own choice: a light
  // vertex's towards the camera side, a camera vertex's towards the light side.
  if (k != s - 1 && k != s && d.delta) return 0.0f;
  const CausticGuide::Cell cell = guide_->cell(d.p);
  if (cell.count == 0) return 0.0f;
  const glm::vec3 w = glm::normalize(at(k - 1).p - d.p);
  const float pg = CausticGuide::pdf(cell, w);
  if (!(pg > 0.0f)) return 0.0f;
  const glm::vec3 towards_camera = k + 1 == n - 1 ? eye : at(k + 1).p;
  const float pb = surface_pdf(d, glm::normalize(towards_camera - d.p), w);
  return caustic_q_of(pg, pb);
}

void BdptTracer::queue_caustic_s0(int t, glm::vec3 contribution, float q) {
  const float w0 = mis_weight(light_, camera_, 0, t, pixel_ratio_);
  queue(0, t, contribution * (w0 / (1.0f + q * w0)), false, Ray{});
  pending_[static_cast<size_t>(pending_count_ - 1)].weighted = true;
}

void BdptTracer::caustic_strategy(size_t k, const Sampler& sampler, uint32_t pixel) {
  const auto [px, py] = pixel_xy(pixel, scene_.camera.width());
  const uint64_t guide_seed = hash_combine(sampler.seed(), 0x6361757374696373ull);
  select(k);
  std::vector<Vertex>& path = thread_subpaths()[k].camera;
  const int nc = current_->nc;
  const int max_vertices = it_.settings_.max_depth + 2;
  // D is camera vertex i; a caustic path needs at least two vertices after it. From the last D
  // down: each writes over the camera subpath past its D only.
  for (int i = std::min(nc - 1, max_vertices - 3); i >= 1; --i) {
    const Vertex& candidate = path[static_cast<size_t>(i)];
    if (candidate.type != VertexType::kSurface || !candidate.connectible) continue;
    const CausticGuide::Cell cell = guide_->cell(candidate.p);
    if (cell.count == 0) continue;
    // Direction j of sample s: point 8 s + j of the pixel's sequence for camera vertex i.
    Sampler numbers(hash_combine(guide_seed, static_cast<uint64_t>(i)), sampler.kind());
    for (int j = 0; j < kCausticDirections; ++j) {
      Vertex& d = path[static_cast<size_t>(i)];  // (again: the subpath may have moved)
      numbers.start_pixel_sample(
          px, py,
          sampler.sample_index() * static_cast<uint32_t>(kCausticDirections) +
              static_cast<uint32_t>(j));
      const float u_pick = numbers.get_1d();
      const glm::vec2 u_dir = numbers.get_2d();
      const glm::vec3 w = CausticGuide::sample(cell, u_pick, u_dir);
      const float pg = CausticGuide::pdf(cell, w);
      if (!(pg > 0.0f)) continue;
      const glm::vec3 f = surface_f(d, d.wo, w);
      if (!(max_component(f) > 0.0f)) continue;
      const float pb = surface_pdf(d, d.wo, w);
      const float q = caustic_q_of(pg, pb);
      glm::vec3 beta =
          d.beta * f *
          (std::abs(glm::dot(d.ng, w)) / (pg * static_cast<float>(kCausticDirections)));
      if (!(max_component(beta) > 0.0f) || !std::isfinite(max_component(beta))) continue;
      // D's scattering as the camera subpath would have made it towards w, for the ratio walk:
      // D's predecessor's reverse density, D's lobe, the next vertex's forward density (p_b).
      Vertex& before = path[static_cast<size_t>(i - 1)];
      before.pdf_rev = to_area_prev(surface_pdf(d, w, d.wo), d, before);
      d.delta = false;
      float pdf_dir = pb;
      Ray ray{ray_start(d, w, it_.offset_), w, 0.0f, kRayTMax};
      int count = i + 1;  // the path's vertices so far
      bool specular_met = false;
      while (count < max_vertices) {
        const Hit hit = trace_one(ray);
        ++traced_;
        if (LightPathsTally* tally = tally_) ++tally->samples[first_ + k].always_rays;
        if (!hit.found()) break;
        if (static_cast<size_t>(count) >= path.size()) {
          path.resize(std::min(2 * path.size(), static_cast<size_t>(max_vertices)));
          selected_ = kWavefront;
          select(k);  // the subpath moved
        }
        Vertex& prev = path[static_cast<size_t>(count - 1)];
        Vertex& x = path[static_cast<size_t>(count)];
        make_surface(x, ray, hit);
        x.beta = beta;
        x.pdf_fwd = measure_edge(pdf_dir, prev, x);
        x.pdf_rev = 0.0f;
        ++count;
        if (specular_met && x.emits) {
          const glm::vec3 le = emission(scene_, x, x.wo);
          if (LightPathsTally* tally = tally_; tally && max_component(le) > 0.0f) {
            // The pilot weighs the term at each share itself: the other strategies' densities
            // relative to this one's are the walk's relative to s = 0 over q.
            pilot_strategies_.assign(2, {1.0f, false});  // this strategy, then s = 0
            (void)mis_weight_walk(light_, camera_, 0, count, pixel_ratio_, &pilot_strategies_);
            for (size_t m = 1; m < pilot_strategies_.size(); ++m) pilot_strategies_[m].first /= q;
            const double v = luminance(beta * le);
            if (v > 0.0 && std::isfinite(v)) {
              add_pilot_contribution(tally->samples[first_ + k], v, false, pilot_strategies_);
            }
          } else if (max_component(le) > 0.0f) {
            // The weight q w_0 / (1 + q w_0), written so that q w_0 of 0 or infinity gives 0 or 1.
            const float w0 = mis_weight_walk(light_, camera_, 0, count, pixel_ratio_);
            const float weight = 1.0f / (1.0f + 1.0f / (q * w0));
            const glm::vec3 term = beta * le * weight;
            if (std::isfinite(term.x + term.y + term.z)) current_->total += term;
          }
        }
        if (!x.specular || count >= max_vertices) break;
        specular_met = true;
        // A specular vertex's scattering as the camera subpath's walk_scatter samples it (the
        // choice between its delta lobes by its probability; no Russian roulette). (Its numbers
        // drawn first: where it fails the chain ends, so nothing else reads the sequence.)
        const float u_lobe = numbers.get_1d();
        const glm::vec2 u = numbers.get_2d();
        const Scatter sc = scatter(x, u_lobe, u);
        if (!sc.bs.valid()) break;
        const BsdfSample& bs = sc.bs;
        const glm::vec3 w_next = sc.w_next;
        x.delta = bs.delta;
        prev.pdf_rev = to_area_prev(bs.delta ? 0.0f : bsdf_pdf(x, bs.wi, sc.wo_local), x, prev);
        beta *= bs.weight;
        if (!(max_component(beta) > 0.0f) || !std::isfinite(max_component(beta))) break;
        pdf_dir = bs.delta ? 0.0f : bs.pdf;
        ray = Ray{ray_start(x, w_next, it_.offset_), w_next, 0.0f, kRayTMax};
      }
    }
  }
}

void BdptTracer::specular_views(const SampleBatch& batch, size_t first, size_t count) {
  const int n_rays = it_.settings_.specular_view_rays;
  const int max_vertices = it_.settings_.max_depth + 2;
  const float share = view_share();
  const Camera& camera = scene_.camera;
  const int width = camera.width();
  const bool lens = camera.has_lens();
  // A view ray between bounces: its sampler (the pixel's second sequence), its ray and
  // throughput, its sample and the path's vertices so far (the camera's included).
  struct View {
    Sampler sampler;
    Ray ray;
    glm::vec3 beta{1.0f};
    uint32_t k = 0;
    int count = 1;
  };
  thread_local std::vector<View> views;
  thread_local std::vector<Ray> rays;
  thread_local std::vector<Hit> hits;
  views.clear();
  for (size_t k = 0; k < count; ++k) {
    if (!state_[k].views) continue;
    const Sampler& own = batch.samplers[first + k];
    const auto [x, y] = pixel_xy(batch.pixels[first + k], width);
    for (int j = 0; j < n_rays; ++j) {
      View& v = views.emplace_back();
      // The second sequence: the pixel's samples' view rays are the first n_rays x spp points of
      // a Sobol sequence of their own (stratified together), as the pixel's own samples are of
      // theirs; the box filter (bdpt's only one with light tracing) puts a sample at (x, y) + u.
      v.sampler = Sampler(hash_combine(own.seed(), 0x73706563756c6172ull), own.kind());
      v.sampler.start_pixel_sample(
          x, y, own.sample_index() * static_cast<uint32_t>(n_rays) + static_cast<uint32_t>(j));
      const glm::vec2 u = v.sampler.get_2d();
      const float px = static_cast<float>(x) + u.x, py = static_cast<float>(y) + u.y;
      v.ray = lens ? camera.lens_ray(px, py, v.sampler.get_2d()) : camera.ray_through(px, py);
      v.k = static_cast<uint32_t>(k);
    }
  }
  Vertex& x = view_vertex_;
  size_t n = views.size();
  while (n > 0) {
    rays.resize(n);
    hits.resize(n);
    for (size_t j = 0; j < n; ++j) rays[j] = views[j].ray;
    accel_.intersect_incoherent(std::span<const Ray>(rays.data(), n),
                                std::span<Hit>(hits.data(), n));
    traced_ += n;
    size_t still = 0;
    for (size_t j = 0; j < n; ++j) {
      View& v = views[j];
      const size_t k = v.k;
      if (LightPathsTally* tally = tally_) ++tally->samples[first_ + k].always_rays;
      const bool after_specular = v.count >= 2;
      glm::vec3 le(0.0f);
      bool goes_on = false;
      if (!hits[j].found()) {
        if (after_specular && it_.has_environment_) {
          le = it_.environment_radiance(glm::normalize(v.ray.dir));
        }
      } else if (const uint8_t kind = it_.view_materials_[scene_.material_of(hits[j].prim)];
                 kind &
                 (after_specular ? BdptIntegrator::kMayBeSpecular | BdptIntegrator::kViewEmitter
                                 : BdptIntegrator::kMayBeSpecular)) {
        // (Only a surface that may be specular, or an emitter after a specular one, needs its
        // vertex: the others end the ray with nothing.)
        make_surface(x, v.ray, hits[j]);
        ++v.count;
        if (after_specular && x.emits) le = emission(scene_, x, x.wo);
        if (x.specular && v.count < max_vertices) {
          // The scattering as the camera walk's walk_scatter samples it (the delta lobe chosen by
          // its probability), without Russian roulette. (Where it fails the ray ends, so nothing
          // else reads its sampler.)
          const glm::vec2 u_choice = v.sampler.get_2d();
          const glm::vec2 u_dir = v.sampler.get_2d();
          const Scatter sc = scatter(x, u_choice.x, u_dir);
          if (sc.bs.valid()) {
            const glm::vec3 w_next = sc.w_next;
            const glm::vec3 beta_next = v.beta * sc.bs.weight;
            goes_on = max_component(beta_next) > 0.0f && std::isfinite(max_component(beta_next));
            if (goes_on) {
              // (le is this vertex's, with the throughput that reached it.)
              if (max_component(le) > 0.0f) add_view_term(k, v.beta * le * share);
              le = glm::vec3(0.0f);
              v.beta = beta_next;
              v.ray = Ray{ray_start(x, w_next, it_.offset_), w_next, 0.0f, kRayTMax};
            }
          }
        }
      }
      if (max_component(le) > 0.0f) add_view_term(k, v.beta * le * share);
      if (goes_on) views[still++] = v;
    }
    n = still;
    views.resize(n);
  }
}

void BdptTracer::add_view_term(size_t k, glm::vec3 term) {
  if (!std::isfinite(term.x + term.y + term.z)) return;
  if (LightPathsTally* tally = tally_) {
    const double v = luminance(term);
    pilot_strategies_.assign(1, {1.0f, false});  // the only strategy of an E S+ L path
    if (v > 0.0) add_pilot_contribution(tally->samples[first_ + k], v, false, pilot_strategies_);
    return;
  }
  state_[k].total += term;
}

std::vector<CausticPhoton> BdptTracer::caustic_photons(uint32_t chunk, uint32_t n) {
  std::vector<CausticPhoton> photons;
  std::vector<Vertex> path(kInitialSubpathVertices);
  const int max_vertices = it_.settings_.max_depth + 1;
  // The chunk's stream: a PCG32 sequence (stream selector and start both keyed by the chunk), so
  // no chunk's numbers depend on another's having been drawn.
  // (Pairs drawn in braces: in the same order by any compiler.)
  Pcg32 rng(hash_words(0x70686f746f6e73ull, chunk), chunk);
  const uint64_t first = static_cast<uint64_t>(chunk) * kGuideChunk;
  const uint64_t end = std::min<uint64_t>(n, first + kGuideChunk);
  for (uint64_t i = first; i < end; ++i) {
    std::array<glm::vec2, 3> u;
    for (glm::vec2& v : u) v = glm::vec2{rng.next_float(), rng.next_float()};
    WalkState w;
    light_subpath(path, max_vertices, u, true, w);
    if (w.count == 0) continue;
    const Vertex& l0 = path[0];
    if (l0.type != VertexType::kLight || l0.point_light || l0.directional) continue;
    bool specular_met = false, escaped = false;
    while (w.active) {
      const Hit hit = trace_one(w.ray);
      if (!hit.found()) break;
      const bool more = walk_hit(path, w, hit, escaped);
      const Vertex& x = path[static_cast<size_t>(w.count - 1)];
      if (!x.specular) {
        if (specular_met && x.connectible && x.edge) {
          photons.push_back({x.p, x.to_prev, std::sqrt(x.edge_dist2)});
        }
        break;
      }
      specular_met = true;
      if (!more) break;
      std::array<glm::vec2, 2> us;
      for (glm::vec2& v : us) v = glm::vec2{rng.next_float(), rng.next_float()};
      walk_scatter(path, w, us);
    }
  }
  return photons;
}

const CausticGuide* BdptIntegrator::caustic_guide(const Scene& scene, const Accel& accel) const {
  if (!wants_guide_) return nullptr;
  std::call_once(guide_->once, [&] {
    // Fixed chunks of paths, each with its own stream, traced in parallel and their photons
    // joined in chunk order: the photons (and so the guide) are the same for any thread count.
    const auto n = static_cast<uint32_t>(settings_.caustic_paths);
    const uint32_t chunks = (n + kGuideChunk - 1) / kGuideChunk;
    std::vector<std::vector<CausticPhoton>> parts(chunks);
    // Isolated: while this thread waits for the chunks it runs only them, never another task of
    // the arena (such as a render tile, whose first radiance call would wait for this guide).
    tbb::this_task_arena::isolate([&] {
      parallel::for_range(tbb::blocked_range<uint32_t>(0, chunks, 1),
                          [&](const tbb::blocked_range<uint32_t>& range) {
                            BdptTracer tracer(*this, scene, accel);
                            for (uint32_t c = range.begin(); c != range.end(); ++c) {
                              parts[c] = tracer.caustic_photons(c, n);
                            }
                          });
    });
    size_t total = 0;
    for (const std::vector<CausticPhoton>& part : parts) total += part.size();
    std::vector<CausticPhoton> photons;
    photons.reserve(total);
    for (const std::vector<CausticPhoton>& part : parts) {
      photons.insert(photons.end(), part.begin(), part.end());
    }
    guide_->guide = CausticGuide(photons, guide_->cell);
  });
  return guide_->guide.empty() ? nullptr : &guide_->guide;
}

bool BdptIntegrator::use_caustic_guide(const std::shared_ptr<GuideSlot>& slot) {
  if (!slot || !wants_guide_ || slot->paths != guide_->paths ||
      slot->max_depth != guide_->max_depth || slot->cell != guide_->cell ||
      slot->offset.int_scale != guide_->offset.int_scale ||
      slot->offset.float_scale != guide_->offset.float_scale) {
    return false;
  }
  guide_ = slot;
  return true;
}

bool camera_light_tracing(const Camera& camera) {
  // An orthographic camera without a lens sees along forward only: a light vertex joins it with
  // probability zero (its direction is a delta), so light tracing's strategies (s, 1) do not
  // exist, and the weights of t >= 2, light tracing off, are exactly the weights over the
  // strategies that do. With a lens its rays spread (ortho_lens_pdf).
  return !camera.is_orthographic() || camera.has_lens();
}

std::string check_light_paths(double light_paths) {
  if (light_paths >= kMinLightPaths && light_paths <= 1.0) return "";
  return "must be the share of samples that trace a light subpath, greater than 0 (at least 1e-6) "
         "and at most 1, got " +
         std::to_string(light_paths);
}

std::string bdpt_unsupported(const Scene& scene) {
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
  if (const std::string why = check_light_paths(settings_.light_paths); !why.empty()) {
    throw Error("light_paths", why);
  }
  inverse_light_paths_ = 1.0f / settings_.light_paths;
  settings_.light_tracing = settings_.light_tracing && camera_light_tracing(scene.camera);
  std::vector<float> power;
  for (uint32_t i = 0; i < scene.lights.size(); ++i) {
    const PointLight& l = scene.lights[i];
    const float p = channel_mean(l.power);
    if (!(p > 0.0f)) continue;
    Emitter e;
    e.point = true;
    e.prim = i;
    e.position = l.position;
    e.intensity = l.power / (4.0f * kPi);
    emitters_.push_back(e);
    power.push_back(p);
  }
  add_delta_lights(scene, power);
  // Emissive triangles in the scene's numbering, each chosen in proportion to its flux
  // (Le area pi per emitting side), as the path tracer's light sampler weighs them.
  std::vector<std::pair<uint32_t, uint32_t>> prims;  // (prim, emitter index)
  const auto add_triangle = [&](uint32_t prim, const SurfaceTriangle& t) {
    const Material& m = scene.materials[t.material];
    if (!m.emits()) return;
    const float area = 0.5f * glm::length(glm::cross(t.e1, t.e2));
    const float p = channel_mean(m.emission) * area * kPi * (m.two_sided ? 2.0f : 1.0f);
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
  }
  if (has_environment_ || !scene.directional_lights.empty()) {
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
  // The caustic guide: where light from emissive triangles can meet a surface whose material is
  // not diffuse (only those can be specular), and the tests of single strategies are not running.
  const bool any_not_diffuse = std::any_of(scene.materials.begin(), scene.materials.end(),
                                           [](const Material& m) { return !m.is_diffuse(); });
  wants_guide_ = settings_.caustic_paths > 0 && !settings_.unweighted &&
                 !(settings_.only_s >= 0 && settings_.only_t >= 0) && !prims.empty() &&
                 any_not_diffuse;
  mask_ = std::make_shared<MaskSlot>();
  if (settings_.specular_view_rays > 0 && settings_.light_tracing && !settings_.unweighted &&
      !(settings_.only_s >= 0 && settings_.only_t >= 0)) {
    view_materials_.assign(scene.materials.size(), 0);
    for (size_t m = 0; m < scene.materials.size(); ++m) {
      const Material& mat = scene.materials[m];
      const bool specular = !mat.is_diffuse() && (mat.has_parameter_textures() ||
                                                  Bsdf(mat, glm::vec3(1.0f)).all_delta());
      view_materials_[m] =
          static_cast<uint8_t>((specular ? kMayBeSpecular : 0) | (mat.emits() ? kViewEmitter : 0));
    }
    const auto may_be_specular = [&](uint32_t m) { return view_materials_[m] & kMayBeSpecular; };
    for (uint32_t prim = 0; prim < scene.mesh.size(); ++prim) {
      if (may_be_specular(scene.mesh.material()[prim])) specular_prims_.push_back(prim);
    }
    for (const Instance& inst : scene.instances) {
      const TriangleMesh& proto = scene.prototypes[inst.prototype];
      for (uint32_t k = 0; k < proto.size(); ++k) {
        if (may_be_specular(proto.material()[k])) specular_prims_.push_back(inst.first_prim + k);
      }
    }
  }
  guide_ = std::make_shared<GuideSlot>();
  if (wants_guide_) {
    const Bounds3 b = scene_bounds(scene);
    const float diagonal = glm::length(b.hi - b.lo);
    wants_guide_ = std::isfinite(diagonal) && diagonal > 0.0f;
    guide_->paths = settings_.caustic_paths;
    guide_->max_depth = settings_.max_depth;
    guide_->cell = diagonal / 128.0f;
    guide_->offset = offset_;
  }
}

void BdptIntegrator::add_delta_lights(const Scene& scene, std::vector<float>& power) {
  // Spot and directional lights after the point lights, weighed by power as the path tracer's
  // light sampler weighs them (spot_light_power; directional_light_power through the scene's
  // bounding sphere, falling back to E for a scene of no extent), so that the environment's share
  // (half, against the others' sum) is the same too.
  for (uint32_t i = 0; i < scene.spot_lights.size(); ++i) {
    const SpotLight& l = scene.spot_lights[i];
    const float p = channel_mean(spot_light_power(l));
    if (!(p > 0.0f) || !std::isfinite(p)) continue;
    Emitter e;
    e.spot = true;
    e.prim = i;
    e.position = l.position;
    e.intensity = l.intensity;
    emitters_.push_back(e);
    power.push_back(p);
  }
  if (scene.directional_lights.empty()) return;
  const Bounds3 b = scene_bounds(scene);
  const float radius = 0.5f * glm::length(b.hi - b.lo);
  for (uint32_t i = 0; i < scene.directional_lights.size(); ++i) {
    const DirectionalLight& l = scene.directional_lights[i];
    const float p = directional_light_weight(l, radius);
    if (p == 0.0f) continue;
    Emitter e;
    e.directional = true;
    e.prim = i;
    emitters_.push_back(e);
    power.push_back(p);
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

namespace {

bool same_view(const Camera& a, const Camera& b) {
  return a.width() == b.width() && a.height() == b.height() && a.position() == b.position() &&
         a.right() == b.right() && a.down() == b.down() && a.forward() == b.forward() &&
         a.focal_px() == b.focal_px() && a.lens_radius() == b.lens_radius() &&
         a.focus_distance() == b.focus_distance() && a.ortho_scale() == b.ortho_scale();
}

}  // namespace

std::shared_ptr<const BdptIntegrator::SpecularMask> BdptIntegrator::specular_mask(
    const Scene& scene) const {
  if (specular_prims_.empty()) return nullptr;
  const Camera& camera = scene.camera;
  std::lock_guard<std::mutex> lock(mask_->mutex);
  if (mask_->mask && same_view(mask_->mask->camera, camera)) return mask_->mask;
  auto mask = std::make_shared<SpecularMask>(SpecularMask{camera, {}});
  const int width = camera.width(), height = camera.height();
  mask->pixels.assign(static_cast<size_t>(width) * static_cast<size_t>(height), 0);
  // Each triangle's projected bounds, a pixel wider, and with a lens the circle of confusion of
  // its corners wider still (f R |1/z - 1/focus| pixels for a thin lens at depth z). A triangle
  // reaching behind the camera covers every pixel. The mask only decides where the extra rays
  // are spent: a pixel left out keeps the sample's own estimate, unbiased either way.
  const glm::vec3 eye = camera.position();
  const float half_w = static_cast<float>(width / 2), half_h = static_cast<float>(height / 2);
  const bool ortho = camera.is_orthographic();
  for (const uint32_t prim : specular_prims_) {
    const SurfaceTriangle tri = scene.triangle(prim);
    const std::array<glm::vec3, 3> corners = {tri.v0, tri.v0 + tri.e1, tri.v0 + tri.e2};
    float x0 = std::numeric_limits<float>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
    bool everywhere = false;
    for (const glm::vec3& c : corners) {
      const glm::vec3 d = c - eye;
      const float z = glm::dot(d, camera.forward());
      float px, py, margin = 1.0f;
      if (ortho) {
        px = glm::dot(d, camera.right()) / camera.ortho_scale();
        py = glm::dot(d, camera.down()) / camera.ortho_scale();
        if (camera.has_lens()) everywhere = true;
      } else {
        if (!(z > 1e-6f)) {
          everywhere = true;
          break;
        }
        px = camera.focal_px() * glm::dot(d, camera.right()) / z;
        py = camera.focal_px() * glm::dot(d, camera.down()) / z;
        if (camera.has_lens()) {
          margin += camera.focal_px() * camera.lens_radius() *
                    std::abs(1.0f / z - 1.0f / camera.focus_distance());
        }
      }
      x0 = std::min(x0, half_w + px - margin);
      x1 = std::max(x1, half_w + px + margin);
      y0 = std::min(y0, half_h + py - margin);
      y1 = std::max(y1, half_h + py + margin);
    }
    if (everywhere || !std::isfinite(x0 + x1 + y0 + y1)) {
      std::fill(mask->pixels.begin(), mask->pixels.end(), uint8_t{1});
      break;
    }
    // (Clamped as floats first: a far corner's coordinate may not fit an int.)
    const auto pixel = [](float v, int size) {
      return static_cast<int>(std::clamp(std::floor(v), -1.0f, static_cast<float>(size)));
    };
    const int ix0 = std::max(0, pixel(x0, width)), ix1 = std::min(width - 1, pixel(x1, width));
    const int iy0 = std::max(0, pixel(y0, height)), iy1 = std::min(height - 1, pixel(y1, height));
    if (ix0 > ix1) continue;
    for (int y = iy0; y <= iy1; ++y) {
      std::fill_n(mask->pixels.begin() + static_cast<ptrdiff_t>(y) * width + ix0, ix1 - ix0 + 1,
                  uint8_t{1});
    }
  }
  mask_->mask = mask;
  return mask;
}

uint64_t BdptIntegrator::radiance(const SampleBatch& batch, const SampleOutput& out,
                                  const Scene& scene, const Accel& accel) const {
  return trace_batch(batch, out, scene, accel, nullptr);
}

uint64_t BdptIntegrator::pilot_radiance(const SampleBatch& batch, const SampleOutput& out,
                                        const Scene& scene, const Accel& accel,
                                        LightPathsTally& tally) const {
  assert(settings_.light_paths == 1.0f && tally.samples.size() == batch.rays.size());
  return trace_batch(batch, out, scene, accel, &tally);
}

uint64_t BdptIntegrator::trace_batch(const SampleBatch& batch, const SampleOutput& out,
                                     const Scene& scene, const Accel& accel,
                                     LightPathsTally* tally) const {
  const size_t n = batch.rays.size();
  assert(n <= kMaxBatch && batch.samplers.size() == n && out.radiance.size() == n);
  BdptTracer tracer(*this, scene, accel, caustic_guide(scene, accel), tally);
  const std::shared_ptr<const SpecularMask> mask = specular_mask(scene);
  tracer.set_specular_mask(mask.get());
  // The camera rays together, as the path tracer traces them (packets where the accel has them;
  // the same hits as one at a time, bit for bit).
  std::array<Hit, kMaxBatch> first_hits;
  accel.intersect(batch.rays, std::span<Hit>(first_hits.data(), n));
  for (size_t first = 0; first < n; first += kWavefront) {
    tracer.wavefront(batch, out, first_hits.data(), first, std::min(kWavefront, n - first));
  }
  // Depth is the first hit's, whatever it is.
  write_first_hit_aovs(scene, batch.rays, std::span<const Hit>(first_hits.data(), n),
                       SampleOutput{.depth = out.depth});
  return n + tracer.traced();
}

}  // namespace tritrace
