// Rough materials against their directional albedo: an open plane of one material in a uniform
// environment of radiance 1 returns, at every pixel, the integral of f(wo, wi) |cos theta_i| over
// the sphere of directions wi (one scattering: nothing else to hit). That integral is computed here
// by a deterministic product-grid quadrature in double, from the GGX and Fresnel formulas restated
// from the papers (not from bsdf.cpp's code or its sampling routines), and the render must agree
// within 1% or 3 standard errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"

namespace tritrace {
namespace {

constexpr double kPiD = std::numbers::pi;

struct V3 {
  double x, y, z;
};
V3 operator+(V3 a, V3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
V3 operator*(double s, V3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
double dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
V3 unit(V3 a) {
  return (1.0 / std::sqrt(dot(a, a))) * a;
}

// Trowbridge-Reitz (GGX) normal distribution and Smith's height-correlated masking-shadowing
// (Walter, Marschner, Li and Torrance, EGSR 2007, eqs. 33-34; Heitz, JCGT 2014, eq. 99).
double ggx_d(double alpha, V3 m) {
  if (m.z <= 0.0) return 0.0;
  const double a2 = alpha * alpha, c2 = m.z * m.z;
  const double t = 1.0 + c2 * (a2 - 1.0);
  return a2 / (kPiD * t * t);
}
double smith_lambda(double alpha, V3 w) {
  const double c2 = w.z * w.z;
  const double tan2 = (1.0 - c2) / c2;
  return 0.5 * (std::sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}
double smith_g2(double alpha, V3 wo, V3 wi) {
  return 1.0 / (1.0 + smith_lambda(alpha, wo) + smith_lambda(alpha, wi));
}

// Unpolarised Fresnel reflectance of a dielectric interface, light arriving from the side of index
// 1 at cos_i > 0 onto index eta (Born and Wolf).
double fresnel(double cos_i, double eta) {
  const double sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0) return 1.0;
  const double cos_t = std::sqrt(1.0 - sin2_t);
  const double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}
double schlick(double f0, double cos_i) {
  return f0 + (1.0 - f0) * std::pow(1.0 - cos_i, 5.0);
}

// Microfacet reflection with Fresnel `f_of` (Walter et al. 2007, eq. 20), wo and wi above.
double reflection(double alpha, V3 wo, V3 wi, const std::function<double(double)>& f_of) {
  if (wi.z <= 0.0) return 0.0;
  const V3 h = unit(wo + wi);
  return f_of(dot(wo, h)) * ggx_d(alpha, h) * smith_g2(alpha, wo, wi) / (4.0 * wo.z * wi.z);
}

// Microfacet refraction from wo (outside, index 1) to wi (inside, index eta) for radiance
// (Walter et al. 2007, eq. 21, with eta_o = 1 on wo's side and eta_i = eta on wi's).
double refraction(double alpha, double eta, V3 wo, V3 wi) {
  if (wi.z >= 0.0) return 0.0;
  V3 h = unit(wo + eta * wi);  // eq. 16
  if (h.z < 0.0) h = -1.0 * h;
  const double oh = dot(wo, h), ih = dot(wi, h);
  if (oh <= 0.0 || ih >= 0.0) return 0.0;
  const double denom = eta * ih + oh;
  return std::abs(ih) * oh / (std::abs(wi.z) * wo.z) * (1.0 - fresnel(oh, eta)) *
         smith_g2(alpha, wo, wi) * ggx_d(alpha, h) / (denom * denom);
}

// The materials' BSDFs for wo above the surface (grey, so one channel).
struct Reference {
  std::string name;
  Material material;
  std::function<double(V3, V3)> f;
};

std::vector<Reference> references() {
  std::vector<Reference> out;
  {
    // A grey metal of F0 = 0.9 (Schlick's Fresnel), roughness 0.5.
    const double alpha = 0.25, f0 = 0.9;
    out.push_back(
        {"rough_conductor",
         Material{.albedo = glm::vec3(0.9f), .type = MaterialType::kConductor, .roughness = 0.5f},
         [=](V3 wo, V3 wi) {
           return reflection(alpha, wo, wi, [=](double c) { return schlick(f0, c); });
         }});
  }
  {
    // Clear glass of index 1.5, roughness 0.5: reflection and refraction.
    const double alpha = 0.25, eta = 1.5;
    out.push_back({"rough_dielectric",
                   Material{.albedo = glm::vec3(1.0f),
                            .type = MaterialType::kDielectric,
                            .roughness = 0.5f,
                            .ior = 1.5f},
                   [=](V3 wo, V3 wi) {
                     return reflection(alpha, wo, wi, [=](double c) { return fresnel(c, eta); }) +
                            refraction(alpha, eta, wo, wi);
                   }});
  }
  {
    // glTF's metallic-roughness model as bsdf.h documents it: metallic times a Schlick metal of
    // F0 = base colour, plus (1 - metallic) times [transmission times tinted glass, plus
    // (1 - transmission) times (a varnish of index ior over Lambert of the base colour, the
    // Lambert term scaled by the light's transmission through the varnish in and out)].
    const double alpha = 0.36, eta = 1.5, base = 0.8, metallic = 0.3, transmission = 0.4;
    const double opaque = (1.0 - metallic) * (1.0 - transmission);
    out.push_back(
        {"principled",
         Material{.albedo = glm::vec3(0.8f),
                  .type = MaterialType::kPrincipled,
                  .roughness = 0.6f,
                  .ior = 1.5f,
                  .metallic = 0.3f,
                  .transmission = 0.4f},
         [=](V3 wo, V3 wi) {
           const auto dielectric = [=](double c) { return fresnel(c, eta); };
           double f =
               metallic * reflection(alpha, wo, wi, [=](double c) { return schlick(base, c); });
           f += (1.0 - metallic) * transmission *
                (reflection(alpha, wo, wi, dielectric) + base * refraction(alpha, eta, wo, wi));
           f += opaque * reflection(alpha, wo, wi, dielectric);
           if (wi.z > 0.0) {
             f += opaque * base / kPiD * (1.0 - fresnel(wo.z, eta)) * (1.0 - fresnel(wi.z, eta));
           }
           return f;
         }});
  }
  return out;
}

// The integral of g(w) over the sphere, w = (sin theta cos phi, sin theta sin phi, cos theta): the
// midpoint rule in theta and phi with d omega = sin theta d theta d phi. Steps in theta keep the
// same angular resolution at the poles, where the lobes at normal incidence peak (the refracted
// lobe of roughness 0.5 at index 1.5 is about 0.08 radians wide).
double sphere_integral(const std::function<double(V3)>& g, int n_theta, int n_phi) {
  double sum = 0.0;
  const double d_theta = kPiD / n_theta, d_phi = 2.0 * kPiD / n_phi;
  for (int i = 0; i < n_theta; ++i) {
    const double theta = (i + 0.5) * d_theta;
    const double s = std::sin(theta), c = std::cos(theta);
    double ring = 0.0;
    for (int j = 0; j < n_phi; ++j) {
      const double phi = (j + 0.5) * d_phi;
      ring += g({s * std::cos(phi), s * std::sin(phi), c});
    }
    sum += ring * s;
  }
  return sum * d_theta * d_phi;
}

constexpr int kTheta = 2048, kPhi = 1024;

double directional_albedo(const Reference& r, V3 wo) {
  return sphere_integral([&](V3 wi) { return r.f(wo, wi) * std::abs(wi.z); }, kTheta, kPhi);
}

// The quadrature itself, on integrals known in closed form: the projected area of the GGX normals
// (1 for every alpha: Walter et al. 2007, eq. 4), the cosine (pi) and a Lambert albedo.
TEST(PlaneFurnaceQuadrature, IntegratesKnownIntegralsToAPartIn10000) {
  for (double alpha : {0.25, 0.36}) {
    const double projected =
        sphere_integral([&](V3 m) { return ggx_d(alpha, m) * std::max(m.z, 0.0); }, kTheta, kPhi);
    EXPECT_NEAR(projected, 1.0, 1e-4) << "alpha " << alpha;
  }
  EXPECT_NEAR(sphere_integral([](V3 w) { return std::max(w.z, 0.0); }, kTheta, kPhi), kPiD, 1e-4);
}

struct PlaneCase {
  int reference;  // into references()
  double theta_degrees;
};

class PlaneFurnace : public ::testing::TestWithParam<PlaneCase> {};

// A square of side 40 in the plane z = 0 facing -z (its lab normal), a camera 200 away at angle
// theta from the normal with a 0.5 degree view (every pixel sees the plane within 0.25 degrees of
// theta), the environment radiance 1 on both sides.
TEST_P(PlaneFurnace, EveryPixelIsTheDirectionalAlbedo) {
  const Reference ref = references()[static_cast<size_t>(GetParam().reference)];
  const double theta = GetParam().theta_degrees * kPiD / 180.0;
  Scene scene;
  scene.materials.push_back(ref.material);
  // Wound so that normalize(cross(e2, e1)) = (0, 0, -1).
  scene.mesh.add({-20, -20, 0}, {20, -20, 0}, {20, 20, 0}, 0);
  scene.mesh.add({-20, -20, 0}, {20, 20, 0}, {-20, 20, 0}, 0);
  ASSERT_NEAR(scene.mesh.normal()[0].z, -1.0f, 1e-6f);
  scene.environment = glm::vec3(1.0f);
  const glm::vec3 eye(static_cast<float>(200.0 * std::sin(theta)), 0.0f,
                      static_cast<float>(-200.0 * std::cos(theta)));
  constexpr int kSide = 16;
  scene.camera = Camera::look_at(kSide, kSide, eye, {0, 0, 0}, {0, -1, 0},
                                 Camera::focal_for_vertical_fov(kSide, 0.5));
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const Image image = render(scene, accel, integrator, {.spp = 256, .seed = 11});
  double sum = 0.0, sum2 = 0.0;
  for (const glm::vec3& p : image.pixels()) {
    const double v = (p.x + p.y + p.z) / 3.0;
    sum += v;
    sum2 += v * v;
  }
  const double n = static_cast<double>(image.pixels().size());
  const double mean = sum / n;
  const double se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / (n - 1.0));
  // wo in the plane's local frame (z = its normal, -z in the world).
  const V3 wo{std::sin(theta), 0.0, std::cos(theta)};
  const double want = directional_albedo(ref, wo);
  ::testing::Test::RecordProperty("albedo", std::to_string(want));
  ::testing::Test::RecordProperty("image_mean", std::to_string(mean));
  EXPECT_LT(std::abs(mean - want), std::max(0.01 * want, 3.0 * se))
      << ref.name << " at " << GetParam().theta_degrees << " degrees: image " << mean << " (se "
      << se << "), quadrature " << want;
  // The test has the power to see a lobe lost or counted twice: its standard error is far below
  // the 1% it allows.
  EXPECT_LT(3.0 * se, 0.01 * want);
}

INSTANTIATE_TEST_SUITE_P(Materials, PlaneFurnace,
                         ::testing::Values(PlaneCase{0, 0.0}, PlaneCase{0, 45.0},
                                           PlaneCase{0, 75.0}, PlaneCase{1, 0.0},
                                           PlaneCase{1, 45.0}, PlaneCase{1, 75.0},
                                           PlaneCase{2, 0.0}, PlaneCase{2, 45.0},
                                           PlaneCase{2, 75.0}),
                         [](const auto& info) {
                           return references()[static_cast<size_t>(info.param.reference)].name +
                                  "_" + std::to_string(static_cast<int>(info.param.theta_degrees)) +
                                  "deg";
                         });

}  // namespace
}  // namespace tritrace
