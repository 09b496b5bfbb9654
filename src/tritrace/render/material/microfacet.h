// The GGX (Trowbridge-Reitz) microfacet distribution with Smith's masking, its visible-normal
// sampling, and Fresnel's reflectances: the building blocks of the BSDFs in bsdf.h.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "tritrace/math/sampling.h"

namespace tritrace {

// Below this GGX width a lobe is treated as a perfect mirror or refractor (a delta lobe): the
// microfacet terms lose float precision there (D peaks at 1 / (pi alpha^2)).
inline constexpr float kSmoothAlpha = 1e-3f;

// Unpolarised Fresnel reflectance of a smooth interface between dielectrics (the average of the s
// and p reflectances, Born and Wolf), for light arriving at cos_i (signed: negative when it arrives
// from the inside) on a surface whose inside has relative index eta. 1 under total internal
// reflection.
inline float fresnel_dielectric(float cos_i, float eta) {
  if (cos_i < 0.0f) {
    eta = 1.0f / eta;
    cos_i = -cos_i;
  }
  cos_i = std::min(cos_i, 1.0f);
  const float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0f) return 1.0f;
  const float cos_t = std::sqrt(1.0f - sin2_t);
  const float r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const float r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5f * (r_parallel * r_parallel + r_perpendicular * r_perpendicular);
}

// Unpolarised Fresnel reflectance of a conductor of complex relative index eta + i k, for light
// arriving from outside at cos_i: Fresnel's equations with a complex index (Born and Wolf,
// "Principles of Optics", section 14.2), r_s = (cos_i - n cos_t) / (cos_i + n cos_t) and
// r_p = (n cos_i - cos_t) / (n cos_i + cos_t) with n cos_t = sqrt(n^2 - sin^2_i) (the root with a
// non-negative imaginary part, so that the wave decays inside). With k = 0 it is
// fresnel_dielectric; at normal incidence ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2).
inline float fresnel_complex(float cos_i, float eta, float k) {
  using C = std::complex<double>;
  const double c = std::clamp(static_cast<double>(cos_i), 0.0, 1.0);
  const double sin2 = 1.0 - c * c;
  const C n(eta, k);
  C n_cos_t = std::sqrt(n * n - sin2);
  if (n_cos_t.imag() < 0.0) n_cos_t = -n_cos_t;
  const C rs = (c - n_cos_t) / (c + n_cos_t);
  // r_p with n cos_t written as n^2 cos_t / n, so that no division by n is needed: multiply the
  // numerator and denominator of (n c - cos_t) / (n c + cos_t) by n.
  const C rp = (n * n * c - n_cos_t) / (n * n * c + n_cos_t);
  const double r = 0.5 * (std::norm(rs) + std::norm(rp));
  return static_cast<float>(std::isfinite(r) ? std::min(r, 1.0) : 1.0);
}

inline glm::vec3 fresnel_conductor(float cos_i, glm::vec3 eta, glm::vec3 k) {
  return {fresnel_complex(cos_i, eta.x, k.x), fresnel_complex(cos_i, eta.y, k.y),
          fresnel_complex(cos_i, eta.z, k.z)};
}

// Schlick's approximation ("An Inexpensive BRDF Model for Physically-based Rendering", 1994) from
// the reflectance at normal incidence F0, the usual way to give a metal its colour.
inline glm::vec3 fresnel_schlick(glm::vec3 f0, float cos_i) {
  const float m = std::clamp(1.0f - cos_i, 0.0f, 1.0f);
  const float m2 = m * m;
  return f0 + (glm::vec3(1.0f) - f0) * (m2 * m2 * m);
}

// The isotropic GGX distribution of width alpha in the local frame (z = the macro normal):
// Walter, Marschner, Li and Torrance, "Microfacet Models for Refraction through Rough Surfaces"
// (EGSR 2007), with Smith's height-correlated masking-shadowing (Heitz, "Understanding the
// Masking-Shadowing Function in Microfacet-Based BRDFs", JCGT 2014).
struct Ggx {
  float alpha = 0.0f;

  // D(m): the density of microfacet normals per projected area; 0 below the horizon.
  float d(glm::vec3 m) const {
    if (m.z <= 0.0f) return 0.0f;
    const float a2 = alpha * alpha;
    const float c2 = m.z * m.z;
    const float t = c2 * (a2 - 1.0f) + 1.0f;
    return a2 / (kPi * t * t);
  }
  // Smith's Lambda for direction w (either side: it depends on |cos theta| only).
  float lambda(glm::vec3 w) const {
    const float c2 = w.z * w.z;
    if (c2 <= 0.0f) return INFINITY;
    const float tan2 = std::max(0.0f, 1.0f - c2) / c2;
    return 0.5f * (std::sqrt(1.0f + alpha * alpha * tan2) - 1.0f);
  }
  float g1(glm::vec3 w) const { return 1.0f / (1.0f + lambda(w)); }
  float g2(glm::vec3 wo, glm::vec3 wi) const { return 1.0f / (1.0f + lambda(wo) + lambda(wi)); }
  // The distribution of normals visible from wo (wo.z > 0): G1(wo) max(0, wo.m) D(m) / wo.z.
  float visible_d(glm::vec3 wo, glm::vec3 m) const {
    const float c = glm::dot(wo, m);
    if (c <= 0.0f || wo.z <= 0.0f) return 0.0f;
    return g1(wo) * c * d(m) / wo.z;
  }

  // A normal drawn from visible_d(wo, .) for wo.z > 0: Heitz, "Sampling the GGX Distribution of
  // Visible Normals" (JCGT 2018): stretch wo to the hemisphere configuration (alpha = 1), sample
  // the projected half disk there (a disk whose far half is squeezed by (1 + cos) / 2), lift the
  // point onto the hemisphere and unstretch the normal.
  glm::vec3 sample_visible(glm::vec3 wo, glm::vec2 u) const {
    const glm::vec3 vh = glm::normalize(glm::vec3(alpha * wo.x, alpha * wo.y, wo.z));
    const float len2 = vh.x * vh.x + vh.y * vh.y;
    const glm::vec3 t1 = len2 > 0.0f ? glm::vec3(-vh.y, vh.x, 0.0f) * (1.0f / std::sqrt(len2))
                                     : glm::vec3(1.0f, 0.0f, 0.0f);
    const glm::vec3 t2 = glm::cross(vh, t1);
    const float r = std::sqrt(u.x);
    const float phi = 2.0f * kPi * u.y;
    const float p1 = r * std::cos(phi);
    const float s = 0.5f * (1.0f + vh.z);
    const float p2 = (1.0f - s) * std::sqrt(std::max(0.0f, 1.0f - p1 * p1)) + s * r * std::sin(phi);
    const glm::vec3 nh =
        p1 * t1 + p2 * t2 + std::sqrt(std::max(0.0f, 1.0f - p1 * p1 - p2 * p2)) * vh;
    return glm::normalize(glm::vec3(alpha * nh.x, alpha * nh.y, std::max(1e-6f, nh.z)));
  }
};

}  // namespace tritrace
