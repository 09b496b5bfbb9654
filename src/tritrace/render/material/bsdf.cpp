// The lobes' formulas (Walter et al. 2007 for GGX reflection and refraction, Heitz 2018 for
// visible-normal sampling) and their mix: a lobe is chosen in proportion to an estimate of its
// reflectance from wo, and the mix's density is the sum of the lobes' densities so weighted.
#include "tritrace/render/material/bsdf.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tritrace {
namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();

glm::vec3 reflect_about(glm::vec3 wo, glm::vec3 m) {
  return 2.0f * glm::dot(wo, m) * m - wo;
}

// Half vector of a refraction from wo (outside, relative index 1) into the inside of index eta
// (Walter et al. 2007, eq. 16), turned to the outside; zero when degenerate.
glm::vec3 refraction_half_vector(glm::vec3 wo, glm::vec3 wi, float eta) {
  glm::vec3 h = wo + eta * wi;
  const float len2 = glm::dot(h, h);
  if (!(len2 > 0.0f)) return glm::vec3(0.0f);
  h *= 1.0f / std::sqrt(len2);
  return h.z < 0.0f ? -h : h;
}

// Reflection by microfacets without the Fresnel factor (Walter et al. 2007, eq. 20), for
// wo.z, wi.z > 0.
float microfacet_reflection(const Ggx& ggx, glm::vec3 wo, glm::vec3 wi, glm::vec3 h) {
  return ggx.d(h) * ggx.g2(wo, wi) / (4.0f * wo.z * wi.z);
}

glm::vec3 fresnel_of(const Lobe& lobe, float cos_i) {
  return lobe.kind == Lobe::Kind::kConductor ? lobe.conductor_fresnel(cos_i)
                                             : glm::vec3(fresnel_dielectric(cos_i, lobe.eta));
}

glm::vec3 lambert_eval(const Lobe& lobe, glm::vec3 wo, glm::vec3 wi) {
  if (wi.z <= 0.0f) return glm::vec3(0.0f);
  glm::vec3 f = lobe.colour * kInvPi;
  if (lobe.eta > 0.0f) {
    // The light passes the coat on the way in and on the way out (reciprocal, and with the coat's
    // reflection never more than 1 in all).
    f *= (1.0f - fresnel_dielectric(wo.z, lobe.eta)) * (1.0f - fresnel_dielectric(wi.z, lobe.eta));
  }
  return f;
}

}  // namespace

glm::vec3 lobe_eval(const Lobe& lobe, glm::vec3 wo, glm::vec3 wi) {
  if (wo.z <= 0.0f) return glm::vec3(0.0f);
  if (lobe.kind == Lobe::Kind::kLambert) return lambert_eval(lobe, wo, wi);
  if (lobe.delta()) return glm::vec3(0.0f);
  const Ggx ggx{lobe.alpha};
  if (wi.z > 0.0f) {
    const glm::vec3 h = glm::normalize(wo + wi);
    const float cos_oh = glm::dot(wo, h);
    if (cos_oh <= 0.0f) return glm::vec3(0.0f);
    return fresnel_of(lobe, cos_oh) * microfacet_reflection(ggx, wo, wi, h);
  }
  if (lobe.kind != Lobe::Kind::kDielectric || wi.z == 0.0f) return glm::vec3(0.0f);
  // Refraction (Walter et al. 2007, eq. 21, with the outside's index 1), in radiance transport:
  // f = (1 - F) D G |wi.h| |wo.h| / (|wi.z| |wo.z| (eta wi.h + wo.h)^2), which is the BTDF of
  // importance transport divided by eta^2.
  const glm::vec3 h = refraction_half_vector(wo, wi, lobe.eta);
  const float cos_oh = glm::dot(wo, h), cos_ih = glm::dot(wi, h);
  if (cos_oh <= 0.0f || cos_ih >= 0.0f) return glm::vec3(0.0f);
  const float denom = lobe.eta * cos_ih + cos_oh;
  const float f = (1.0f - fresnel_dielectric(cos_oh, lobe.eta)) * ggx.d(h) * ggx.g2(wo, wi) *
                  (-cos_ih * cos_oh) / (-wi.z * wo.z * denom * denom);
  return lobe.colour * f;
}

float lobe_pdf(const Lobe& lobe, glm::vec3 wo, glm::vec3 wi) {
  if (wo.z <= 0.0f) return 0.0f;
  if (lobe.kind == Lobe::Kind::kLambert) return cosine_hemisphere_pdf(wi.z);
  if (lobe.delta()) return 0.0f;
  const Ggx ggx{lobe.alpha};
  const bool chooses = lobe.kind == Lobe::Kind::kDielectric;
  if (wi.z > 0.0f) {
    const glm::vec3 h = glm::normalize(wo + wi);
    const float cos_oh = glm::dot(wo, h);
    if (cos_oh <= 0.0f) return 0.0f;
    const float reflect = chooses ? fresnel_dielectric(cos_oh, lobe.eta) : 1.0f;
    // dh/dwi = 1 / (4 wo.h) (Walter et al. 2007, eq. 14).
    return reflect * ggx.visible_d(wo, h) / (4.0f * cos_oh);
  }
  if (!chooses || wi.z == 0.0f) return 0.0f;
  const glm::vec3 h = refraction_half_vector(wo, wi, lobe.eta);
  const float cos_oh = glm::dot(wo, h), cos_ih = glm::dot(wi, h);
  if (cos_oh <= 0.0f || cos_ih >= 0.0f) return 0.0f;
  const float denom = lobe.eta * cos_ih + cos_oh;
  // dh/dwi = eta^2 |wi.h| / (eta wi.h + wo.h)^2 (Walter et al. 2007, eq. 17).
  return (1.0f - fresnel_dielectric(cos_oh, lobe.eta)) * ggx.visible_d(wo, h) * lobe.eta *
         lobe.eta * -cos_ih / (denom * denom);
}

BsdfSample lobe_sample(const Lobe& lobe, glm::vec3 wo, float u_lobe, glm::vec2 u) {
  BsdfSample s;
  if (wo.z <= 0.0f) return s;
  if (lobe.kind == Lobe::Kind::kLambert) {
    s.wi = sample_cosine_hemisphere(u);
    s.pdf = cosine_hemisphere_pdf(s.wi.z);
    if (s.pdf > 0.0f) s.weight = lambert_eval(lobe, wo, s.wi) * (s.wi.z / s.pdf);
    return s;
  }
  const bool dielectric = lobe.kind == Lobe::Kind::kDielectric;
  if (lobe.delta()) {
    s.delta = true;
    s.pdf = kInfinity;
    const glm::vec3 mirror(-wo.x, -wo.y, wo.z);
    if (!dielectric) {
      s.wi = mirror;
      s.weight = fresnel_of(lobe, wo.z);
      return s;
    }
    const float r = fresnel_dielectric(wo.z, lobe.eta);
    if (u_lobe < r) {
      s.wi = mirror;
      s.weight = glm::vec3(1.0f);  // F / F
      return s;
    }
    const float inv_eta = 1.0f / lobe.eta;
    const float sin2_t = (1.0f - wo.z * wo.z) * inv_eta * inv_eta;
    if (sin2_t >= 1.0f) return {};
    s.wi = glm::vec3(-wo.x * inv_eta, -wo.y * inv_eta, -std::sqrt(1.0f - sin2_t));
    s.radiance_scale = inv_eta * inv_eta;
    s.weight = lobe.colour * s.radiance_scale;  // (1 - F) / (1 - F), scaled for radiance
    return s;
  }
  const Ggx ggx{lobe.alpha};
  const glm::vec3 h = ggx.sample_visible(wo, u);
  const float cos_oh = glm::dot(wo, h);
  if (cos_oh <= 0.0f) return {};
  if (!dielectric || u_lobe < fresnel_dielectric(cos_oh, lobe.eta)) {
    s.wi = reflect_about(wo, h);
    if (s.wi.z <= 0.0f) return {};
  } else {
    const float inv_eta = 1.0f / lobe.eta;
    const float sin2_t = (1.0f - cos_oh * cos_oh) * inv_eta * inv_eta;
    if (sin2_t >= 1.0f) return {};
    s.wi = glm::normalize((cos_oh * inv_eta - std::sqrt(1.0f - sin2_t)) * h - wo * inv_eta);
    if (s.wi.z >= 0.0f) return {};
  }
  s.pdf = lobe_pdf(lobe, wo, s.wi);
  if (!(s.pdf > 0.0f)) return {};
  s.weight = lobe_eval(lobe, wo, s.wi) * (std::abs(s.wi.z) / s.pdf);
  return s;
}

Bsdf::Bsdf(const Material& m, glm::vec3 albedo) {
  const float alpha = m.roughness * m.roughness;
  auto add = [&](Lobe::Kind kind, glm::vec3 colour, float weight, float eta) {
    if (weight > 0.0f) lobes_[static_cast<size_t>(count_++)] = {kind, colour, weight, alpha, eta};
  };
  switch (m.type) {
    case MaterialType::kDiffuse:
      add(Lobe::Kind::kLambert, albedo, 1.0f, 0.0f);
      break;
    case MaterialType::kConductor:
      add(Lobe::Kind::kConductor, albedo, 1.0f, 0.0f);
      if (m.has_complex_ior()) {
        lobes_[0].eta_rgb = m.conductor_eta;
        lobes_[0].k_rgb = m.conductor_k;
      }
      break;
    case MaterialType::kDielectric:
      add(Lobe::Kind::kDielectric, albedo, 1.0f, m.ior);
      break;
    case MaterialType::kPrincipled: {
      // glTF 2.0's metallic-roughness model (Appendix B of the specification): a metal of F0 =
      // base colour, mixed by `metallic` with a dielectric, which is itself glass (transmission)
      // or a varnish of index ior over a diffuse base.
      const float opaque = (1.0f - m.metallic) * (1.0f - m.transmission);
      add(Lobe::Kind::kConductor, albedo, m.metallic, 0.0f);
      add(Lobe::Kind::kDielectric, albedo, (1.0f - m.metallic) * m.transmission, m.ior);
      add(Lobe::Kind::kCoat, glm::vec3(1.0f), opaque, m.ior);
      add(Lobe::Kind::kLambert, albedo, opaque, m.ior);
      break;
    }
  }
}

std::array<float, Bsdf::kMaxLobes> Bsdf::choice(glm::vec3 wo) const {
  // One lobe: the whole array as one constant (writing p[0] into a zeroed array and returning
  // it made a 16-byte load of a 4-byte store, a store-forwarding stall on every call).
  if (count_ == 1) return {1.0f, 0.0f, 0.0f, 0.0f};
  std::array<float, kMaxLobes> p{};
  float sum = 0.0f;
  for (int k = 0; k < count_; ++k) {
    const Lobe& l = lobes_[static_cast<size_t>(k)];
    float e = 0.0f;
    switch (l.kind) {
      case Lobe::Kind::kLambert:
        e = max_component(l.colour) *
            (l.eta > 0.0f ? 1.0f - fresnel_dielectric(wo.z, l.eta) : 1.0f);
        break;
      case Lobe::Kind::kConductor:
        e = max_component(l.conductor_fresnel(wo.z));
        break;
      case Lobe::Kind::kDielectric: {
        const float f = fresnel_dielectric(wo.z, l.eta);
        e = f + (1.0f - f) * max_component(l.colour);
        break;
      }
      case Lobe::Kind::kCoat:
        e = fresnel_dielectric(wo.z, l.eta);
        break;
    }
    p[static_cast<size_t>(k)] = l.weight * e;
    sum += p[static_cast<size_t>(k)];
  }
  if (!(sum > 0.0f)) return {};
  for (float& x : p) x /= sum;
  return p;
}

namespace {

// The lobe as seen from wo's side: from below, the inside is outside (index 1 / eta).
Lobe seen_from(const Lobe& lobe, bool below) {
  Lobe l = lobe;
  if (below && l.eta > 0.0f) l.eta = 1.0f / l.eta;
  return l;
}

glm::vec3 flip_z(glm::vec3 v) {
  return {v.x, v.y, -v.z};
}

}  // namespace

glm::vec3 Bsdf::eval(glm::vec3 wo, glm::vec3 wi) const {
  const bool below = wo.z < 0.0f;
  if (below) wo = flip_z(wo), wi = flip_z(wi);
  glm::vec3 f(0.0f);
  for (int k = 0; k < count_; ++k) {
    const Lobe& l = lobes_[static_cast<size_t>(k)];
    if (!l.delta()) f += l.weight * lobe_eval(seen_from(l, below), wo, wi);
  }
  return f;
}

float Bsdf::pdf(glm::vec3 wo, glm::vec3 wi) const {
  const bool below = wo.z < 0.0f;
  if (below) wo = flip_z(wo), wi = flip_z(wi);
  const std::array<float, kMaxLobes> p = choice(wo);
  float pdf = 0.0f;
  for (int k = 0; k < count_; ++k) {
    const Lobe& l = lobes_[static_cast<size_t>(k)];
    if (!l.delta() && p[static_cast<size_t>(k)] > 0.0f) {
      pdf += p[static_cast<size_t>(k)] * lobe_pdf(seen_from(l, below), wo, wi);
    }
  }
  return pdf;
}

BsdfSample Bsdf::sample(glm::vec3 wo, float u_lobe, glm::vec2 u) const {
  const bool below = wo.z < 0.0f;
  if (below) wo = flip_z(wo);
  const std::array<float, kMaxLobes> p = choice(wo);
  // Choose lobe k, then stretch u_lobe's part in [c_k, c_k + p_k) back to [0, 1) for the lobe's own
  // choice between reflection and refraction.
  int k = 0;
  float start = 0.0f;
  while (k < count_ - 1 && u_lobe >= start + p[static_cast<size_t>(k)]) {
    start += p[static_cast<size_t>(k)];
    ++k;
  }
  const float pk = p[static_cast<size_t>(k)];
  if (!(pk > 0.0f)) return {};
  const float u_rest = std::min((u_lobe - start) / pk, 0x1.fffffep-1f);
  const Lobe& chosen = lobes_[static_cast<size_t>(k)];
  BsdfSample s = lobe_sample(seen_from(chosen, below), wo, u_rest, u);
  if (!s.valid()) return {};
  if (s.delta) {
    s.weight *= chosen.weight / pk;
  } else if (count_ > 1) {
    // The direction could have come from any non-delta lobe: the mix's own density and value.
    glm::vec3 f(0.0f);
    float pdf = 0.0f;
    for (int j = 0; j < count_; ++j) {
      const Lobe& l = lobes_[static_cast<size_t>(j)];
      if (l.delta()) continue;
      const Lobe seen = seen_from(l, below);
      f += l.weight * lobe_eval(seen, wo, s.wi);
      pdf += p[static_cast<size_t>(j)] * lobe_pdf(seen, wo, s.wi);
    }
    if (!(pdf > 0.0f)) return {};
    s.pdf = pdf;
    s.weight = f * (std::abs(s.wi.z) / pdf);
    if (!s.valid()) return {};
  } else {
    s.weight *= chosen.weight;
  }
  if (below) s.wi = flip_z(s.wi);
  return s;
}

bool Bsdf::all_delta() const {
  for (int k = 0; k < count_; ++k) {
    if (!lobes_[static_cast<size_t>(k)].delta()) return false;
  }
  return true;
}

bool Bsdf::transmits() const {
  for (int k = 0; k < count_; ++k) {
    if (lobes_[static_cast<size_t>(k)].kind == Lobe::Kind::kDielectric) return true;
  }
  return false;
}

}  // namespace tritrace
