// The BSDFs against independent answers: chi-square of every rough lobe's sampling against its
// pdf (integrated over cells of the sphere) for several incident directions and roughness values,
// sampled weights against eval cos / pdf, reciprocity, Fresnel's closed forms, Snell's law and the
// Fresnel split of smooth glass, and energy that is never gained.
#include "tritrace/render/material/bsdf.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "../math/chi_square.h"
#include "tritrace/math/random.h"

namespace tritrace {
namespace {

constexpr double kPiD = std::numbers::pi;
constexpr int kThetaBins = 32, kPhiBins = 64;
constexpr int kSamples = 1000000;

glm::vec3 direction(double theta, double phi) {
  return glm::vec3(static_cast<float>(std::sin(theta) * std::cos(phi)),
                   static_cast<float>(std::sin(theta) * std::sin(phi)),
                   static_cast<float>(std::cos(theta)));
}

glm::vec3 incident(float cos_theta, float phi = 0.3f) {
  const float s = std::sqrt(std::max(0.0f, 1.0f - cos_theta * cos_theta));
  return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

int cell_of(glm::vec3 w) {
  const double theta = std::acos(std::clamp(static_cast<double>(w.z), -1.0, 1.0));
  double phi = std::atan2(static_cast<double>(w.y), static_cast<double>(w.x));
  if (phi < 0.0) phi += 2.0 * kPiD;
  const int t = std::min(kThetaBins - 1, static_cast<int>(theta / kPiD * kThetaBins));
  const int p = std::min(kPhiBins - 1, static_cast<int>(phi / (2.0 * kPiD) * kPhiBins));
  return t * kPhiBins + p;
}

// Observed counts per cell plus a last cell for failed samples; expected counts from the pdf
// integrated over each cell (sin theta dtheta dphi, Simpson), the last cell holding the remaining
// probability, which the sampler must fail with.
struct Histograms {
  std::vector<double> observed, expected;
};

// The polar angles inside the sphere where a refracting lobe's pdf jumps: the circle where the
// generalised half vector of a refraction, -(wo + eta wi) (Walter et al. 2007, eq. 16), reaches the
// horizon, wi.z = -wo.z / eta (in the frame seen from wo's side). Microfacets below the horizon do
// not exist, so the pdf drops there from visible_d of a horizontal normal (large at roughness
// 0.6-0.9) to 0. Simpson's rule across such a jump errs by O(cell height): at roughness 0.9 and
// cos 0.3 the cells' integrals summed to 0.9763 (16 points per cell) or 0.9705 (64), against
// 0.97148 by sampling and by a fine integral, which failed the chi-square test; split at the
// jump, 16 and 64 points both give 0.97145.
std::vector<double> pdf_jumps(const Material& m, glm::vec3 wo) {
  const bool refracts = m.type == MaterialType::kDielectric ||
                        (m.type == MaterialType::kPrincipled && m.transmission > 0.0f);
  if (!refracts) return {};
  const double cos_o = static_cast<double>(wo.z), eta = static_cast<double>(m.ior);
  // Seen from inside, the relative index is 1 / eta and the frame is flipped.
  const double z = cos_o > 0.0 ? -cos_o / eta : -cos_o * eta;
  if (!(std::abs(z) < 1.0)) return {};
  return {std::acos(z)};
}

Histograms histograms(const Bsdf& bsdf, glm::vec3 wo, uint64_t seed,
                      const std::vector<double>& jumps = {}) {
  const int cells = kThetaBins * kPhiBins;
  Histograms h{std::vector<double>(cells + 1, 0.0), std::vector<double>(cells + 1, 0.0)};
  Pcg32 rng(seed, 11);
  for (int i = 0; i < kSamples; ++i) {
    const float u_lobe = rng.next_float();
    const glm::vec2 u(rng.next_float(), rng.next_float());
    const BsdfSample s = bsdf.sample(wo, u_lobe, u);
    h.observed[s.valid() ? cell_of(s.wi) : cells] += 1.0;
  }
  double total = 0.0;
  for (int t = 0; t < kThetaBins; ++t) {
    for (int p = 0; p < kPhiBins; ++p) {
      const double t0 = t * kPiD / kThetaBins, t1 = (t + 1) * kPiD / kThetaBins;
      const double p0 = p * 2.0 * kPiD / kPhiBins, p1 = (p + 1) * 2.0 * kPiD / kPhiBins;
      // The cell's edges pulled in by 1e-6: the pdf jumps at the horizon, which is a cell edge, and
      // there float(cos(pi / 2)) is 6e-17, above it. A cell with a jump inside (pdf_jumps) is
      // integrated in two pieces, each pulled in likewise.
      constexpr double kIn = 1e-6;
      std::vector<double> edges{t0};
      for (double j : jumps) {
        if (j > t0 + 2.0 * kIn && j < t1 - 2.0 * kIn) edges.push_back(j);
      }
      edges.push_back(t1);
      const auto f = [&](double theta, double phi) {
        return bsdf.pdf(wo, direction(theta, phi)) * std::sin(theta);
      };
      double integral = 0.0;
      for (size_t e = 0; e + 1 < edges.size(); ++e) {
        const double a = edges[e], b = edges[e + 1];
        integral += simpson_2d(f, a + kIn, b - kIn, p0, p1, 16) * (b - a) / (b - a - 2.0 * kIn);
      }
      h.expected[static_cast<size_t>(t * kPhiBins + p)] = integral * kSamples;
      total += integral;
    }
  }
  h.expected[cells] = std::max(0.0, 1.0 - total) * kSamples;
  return h;
}

struct LobeCase {
  std::string name;
  Material material;
  float cos_o;  // of wo; negative: from inside
};

Material make(MaterialType type, float roughness, glm::vec3 albedo = glm::vec3(0.8f, 0.6f, 0.3f),
              float metallic = 0.0f, float transmission = 0.0f) {
  Material m;
  m.type = type;
  m.roughness = roughness;
  m.albedo = albedo;
  m.metallic = metallic;
  m.transmission = transmission;
  return m;
}

std::vector<LobeCase> lobe_cases() {
  std::vector<LobeCase> cases;
  cases.push_back({"diffuse", make(MaterialType::kDiffuse, 0.0f), 0.7f});
  for (float r : {0.3f, 0.6f, 0.9f}) {
    const std::string rs = std::to_string(static_cast<int>(r * 10));
    for (float c : {0.95f, 0.35f}) {
      const std::string cs = std::to_string(static_cast<int>(c * 100));
      cases.push_back({"conductor_r" + rs + "_cos" + cs, make(MaterialType::kConductor, r), c});
    }
    for (float c : {0.9f, 0.3f, -0.8f, -0.4f}) {
      const std::string cs =
          (c < 0 ? "in" : "") + std::to_string(static_cast<int>(std::abs(c) * 100));
      cases.push_back({"glass_r" + rs + "_cos" + cs, make(MaterialType::kDielectric, r), c});
    }
  }
  cases.push_back({"principled_plastic", make(MaterialType::kPrincipled, 0.4f), 0.6f});
  cases.push_back({"principled_half_metal",
                   make(MaterialType::kPrincipled, 0.5f, glm::vec3(0.9f, 0.5f, 0.2f), 0.5f), 0.8f});
  cases.push_back({"principled_transmissive",
                   make(MaterialType::kPrincipled, 0.5f, glm::vec3(0.9f), 0.2f, 0.6f), 0.5f});
  return cases;
}

class BsdfLobes : public ::testing::TestWithParam<LobeCase> {};

TEST_P(BsdfLobes, SamplingFitsThePdf) {
  const LobeCase& c = GetParam();
  const Bsdf bsdf(c.material);
  const glm::vec3 wo = incident(c.cos_o);
  const Histograms h = histograms(bsdf, wo, 1234, pdf_jumps(c.material, wo));
  EXPECT_TRUE(chi_square_fits(h.observed, h.expected));
}

TEST_P(BsdfLobes, SampledWeightIsEvalCosOverPdf) {
  const LobeCase& c = GetParam();
  const Bsdf bsdf(c.material);
  const glm::vec3 wo = incident(c.cos_o);
  Pcg32 rng(99, 3);
  int valid = 0;
  for (int i = 0; i < 2000; ++i) {
    const BsdfSample s = bsdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()});
    if (!s.valid()) continue;
    ++valid;
    ASSERT_FALSE(s.delta);
    const float pdf = bsdf.pdf(wo, s.wi);
    EXPECT_NEAR(s.pdf, pdf, 1e-4f * pdf);
    const glm::vec3 expected = bsdf.eval(wo, s.wi) * (std::abs(s.wi.z) / pdf);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.weight[k], expected[k], 1e-4f * expected[k] + 1e-7f);
    EXPECT_NEAR(glm::length(s.wi), 1.0f, 1e-5f);
  }
  EXPECT_GT(valid, 1000);  // very rough lobes send up to 40% below the horizon
}

// f(wo, wi) = f(wi, wo) for reflection (to float precision: 1 - F near total reflection loses
// digits, hence the absolute floor); for refraction in radiance transport
// f(wo, wi) / n(wo's side)^2 = f(wi, wo) / n(wi's side)^2 (Veach 1997, eq. 5.15).
TEST_P(BsdfLobes, EvalIsReciprocal) {
  const LobeCase& c = GetParam();
  const Bsdf bsdf(c.material);
  Pcg32 rng(5, 8);
  int checked = 0;
  for (int i = 0; i < 4000; ++i) {
    const glm::vec3 a = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    const glm::vec3 b = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    const glm::vec3 fab = bsdf.eval(a, b), fba = bsdf.eval(b, a);
    const float ior = c.material.type == MaterialType::kDiffuse ? 1.0f : c.material.ior;
    const float na = a.z < 0.0f ? ior : 1.0f, nb = b.z < 0.0f ? ior : 1.0f;
    for (int k = 0; k < 3; ++k) {
      const float x = fab[k] / (na * na), y = fba[k] / (nb * nb);
      EXPECT_NEAR(x, y, 2e-3f * std::max(x, y) + 1e-6f)
          << "x " << x << " y " << y << " a " << a.z << " b " << b.z << " f(a, b) " << fab[k]
          << " f(b, a) " << fba[k];
    }
    if (fab.x > 0.0f) ++checked;
  }
  EXPECT_GT(checked, 200);
}

INSTANTIATE_TEST_SUITE_P(Rough, BsdfLobes, ::testing::ValuesIn(lobe_cases()),
                         [](const auto& info) { return info.param.name; });

// How many chi-square tests this file adds to the family (kChiSquareTests).
TEST(BsdfLobes, FamilyCountIsInChiSquareTests) {
  EXPECT_EQ(lobe_cases().size(), 22u);
}

TEST(ChiSquarePower, RejectsAGgxPdfOfTheWrongWidth) {
  // The histogram of roughness 0.6 judged against the pdf of roughness 0.63.
  const Bsdf sampled(make(MaterialType::kConductor, 0.6f));
  const Bsdf judged(make(MaterialType::kConductor, 0.63f));
  const glm::vec3 wo = incident(0.7f);
  const Histograms h = histograms(sampled, wo, 77);
  const Histograms j = histograms(judged, wo, 77);
  EXPECT_FALSE(chi_square_fits(h.observed, j.expected));
}

TEST(Fresnel, DielectricMatchesClosedForms) {
  // Normal incidence: ((n - 1) / (n + 1))^2.
  EXPECT_NEAR(fresnel_dielectric(1.0f, 1.5f), 0.04f, 1e-6f);
  EXPECT_NEAR(fresnel_dielectric(-1.0f, 1.5f), 0.04f, 1e-6f);
  EXPECT_NEAR(fresnel_dielectric(1.0f, 1.33f), std::pow(0.33 / 2.33, 2.0), 1e-6);
  // Brewster's angle tan(theta) = n: the p reflectance vanishes and theta_i + theta_t = 90
  // degrees, so F = r_s^2 / 2 = sin^2(theta_i - theta_t) / 2.
  const double tb = std::atan(1.5), tt = kPiD / 2.0 - tb;
  EXPECT_NEAR(fresnel_dielectric(static_cast<float>(std::cos(tb)), 1.5f),
              0.5 * std::pow(std::sin(tb - tt), 2.0), 1e-6);
  // From inside, beyond the critical angle asin(1/n): total internal reflection.
  const double critical = std::asin(1.0 / 1.5);
  EXPECT_EQ(fresnel_dielectric(-static_cast<float>(std::cos(critical + 0.01)), 1.5f), 1.0f);
  EXPECT_LT(fresnel_dielectric(-static_cast<float>(std::cos(critical - 0.01)), 1.5f), 1.0f);
  // Grazing incidence reflects everything; an index-matched interface nothing.
  EXPECT_NEAR(fresnel_dielectric(1e-6f, 1.5f), 1.0f, 1e-4f);
  EXPECT_NEAR(fresnel_dielectric(0.5f, 1.0f), 0.0f, 1e-7f);
  // Stokes: the transmittance is the same both ways, 1 - F(theta_i) = 1 - F(theta_t from inside).
  const float ci = 0.6f;
  const float ct = std::sqrt(1.0f - (1.0f - ci * ci) / (1.5f * 1.5f));
  EXPECT_NEAR(fresnel_dielectric(ci, 1.5f), fresnel_dielectric(-ct, 1.5f), 1e-6f);
}

TEST(Fresnel, SchlickIsF0AtNormalIncidenceAndOneAtGrazing) {
  const glm::vec3 f0(0.9f, 0.6f, 0.1f);
  EXPECT_EQ(fresnel_schlick(f0, 1.0f), f0);
  EXPECT_EQ(fresnel_schlick(f0, 0.0f), glm::vec3(1.0f));
  // At cos = 0.5: F0 + (1 - F0) / 32.
  EXPECT_NEAR(fresnel_schlick(f0, 0.5f).z, 0.1f + 0.9f / 32.0f, 1e-6f);
}

// The conductor's exact Fresnel against forms derived apart from the complex arithmetic it uses:
// normal incidence ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2); k = 0 giving the dielectric's; and at
// oblique angles the real-valued form of Born and Wolf (as in Pharr, Jakob and Humphreys,
// "Physically Based Rendering", 3rd ed., section 8.2.1): with a^2 + b^2 =
// sqrt((n^2 - k^2 - sin^2)^2 + 4 n^2 k^2) and a = sqrt((a^2 + b^2 + n^2 - k^2 - sin^2) / 2),
// R_s = (a^2 + b^2 - 2 a cos + cos^2) / (a^2 + b^2 + 2 a cos + cos^2) and
// R_p = R_s (cos^2 (a^2 + b^2) - 2 a cos sin^2 + sin^4) / (cos^2 (a^2 + b^2) + 2 a cos sin^2 +
// sin^4).
double conductor_reflectance_real_form(double cos_i, double n, double k) {
  const double c2 = cos_i * cos_i, s2 = 1.0 - c2;
  const double t0 = n * n - k * k - s2;
  const double a2b2 = std::sqrt(t0 * t0 + 4.0 * n * n * k * k);
  const double a = std::sqrt(0.5 * (a2b2 + t0));
  const double rs = (a2b2 - 2.0 * a * cos_i + c2) / (a2b2 + 2.0 * a * cos_i + c2);
  const double t1 = c2 * a2b2 + s2 * s2, t2 = 2.0 * a * cos_i * s2;
  const double rp = rs * (t1 - t2) / (t1 + t2);
  return 0.5 * (rs + rp);
}

TEST(Fresnel, ConductorMatchesClosedForms) {
  // Gold, copper, aluminium and silver at about 650, 550 and 450 nm, and a made-up index.
  const double indices[][2] = {{0.18, 3.4}, {0.42, 2.35}, {1.37, 1.85}, {0.27, 3.61},
                               {1.5, 7.6},  {0.05, 4.2},  {2.0, 0.5}};
  for (const auto& [n, k] : indices) {
    const double normal = ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
    EXPECT_NEAR(fresnel_complex(1.0f, float(n), float(k)), normal, 1e-6) << n << " " << k;
    for (double c : {0.95, 0.7, 0.4, 0.15, 0.02}) {
      EXPECT_NEAR(fresnel_complex(float(c), float(n), float(k)),
                  conductor_reflectance_real_form(c, n, k), 2e-6)
          << "n " << n << " k " << k << " cos " << c;
    }
    EXPECT_NEAR(fresnel_complex(0.0f, float(n), float(k)), 1.0, 1e-6);  // grazing
  }
  for (float eta : {1.5f, 1.33f, 2.4f, 0.7f}) {
    for (float c : {1.0f, 0.8f, 0.5f, 0.2f, 0.05f}) {
      EXPECT_NEAR(fresnel_complex(c, eta, 0.0f), fresnel_dielectric(c, eta), 2e-6)
          << "eta " << eta << " cos " << c;
    }
  }
  const glm::vec3 f = fresnel_conductor(0.6f, {0.18f, 0.42f, 1.37f}, {3.4f, 2.35f, 1.85f});
  EXPECT_NEAR(f.x, conductor_reflectance_real_form(0.6, 0.18, 3.4), 2e-6);
  EXPECT_NEAR(f.z, conductor_reflectance_real_form(0.6, 1.37, 1.85), 2e-6);
}

// A smooth conductor given by its complex index reflects its exact Fresnel reflectance; a rough one
// samples consistently with its pdf (the lobe's sampling does not depend on the Fresnel factor)
// and its weight is eval cos / pdf.
TEST(ComplexIorConductor, MirrorWeightIsTheExactFresnel) {
  Material m = make(MaterialType::kConductor, 0.0f);
  m.conductor_eta = glm::vec3(0.18f, 0.42f, 1.37f);
  m.conductor_k = glm::vec3(3.4f, 2.35f, 1.85f);
  const glm::vec3 wo = incident(0.4f, 0.5f);
  const BsdfSample s = Bsdf(m).sample(wo, 0.5f, {0.3f, 0.3f});
  ASSERT_TRUE(s.delta);
  EXPECT_NEAR(s.weight.x, conductor_reflectance_real_form(0.4, 0.18, 3.4), 1e-5);
  EXPECT_NEAR(s.weight.y, conductor_reflectance_real_form(0.4, 0.42, 2.35), 1e-5);
  EXPECT_NEAR(s.weight.z, conductor_reflectance_real_form(0.4, 1.37, 1.85), 1e-5);
  m.roughness = 0.5f;
  const Bsdf rough(m);
  Pcg32 rng(31, 4);
  int checked = 0;
  for (int i = 0; i < 2000; ++i) {
    const BsdfSample r = rough.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()});
    if (!r.valid()) continue;
    const glm::vec3 expected = rough.eval(wo, r.wi) * (std::abs(r.wi.z) / rough.pdf(wo, r.wi));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.weight[c], expected[c], 1e-4f * expected[c] + 1e-6f);
    ++checked;
  }
  EXPECT_GT(checked, 1500);
}

TEST(SmoothConductor, IsAMirrorWithSchlickWeight) {
  const Bsdf bsdf(make(MaterialType::kConductor, 0.0f));
  const glm::vec3 wo = incident(0.5f, 1.0f);
  const BsdfSample s = bsdf.sample(wo, 0.3f, {0.2f, 0.7f});
  ASSERT_TRUE(s.delta);
  EXPECT_NEAR(s.wi.x, -wo.x, 1e-7f);
  EXPECT_NEAR(s.wi.y, -wo.y, 1e-7f);
  EXPECT_NEAR(s.wi.z, wo.z, 1e-7f);
  EXPECT_NEAR(s.weight.x, 0.8f + 0.2f / 32.0f, 1e-6f);
  EXPECT_EQ(bsdf.eval(wo, s.wi), glm::vec3(0.0f));
  EXPECT_EQ(bsdf.pdf(wo, s.wi), 0.0f);
  EXPECT_TRUE(bsdf.all_delta());
}

// Smooth glass reflects with probability F and refracts by Snell's law otherwise, the refracted
// radiance scaled by 1 / eta^2 (n^2 L is invariant along a refracted ray).
TEST(SmoothDielectric, SplitsByFresnelAndRefractsBySnell) {
  Material m = make(MaterialType::kDielectric, 0.0f, glm::vec3(1.0f));
  const Bsdf bsdf(m);
  for (const float cos_o : {0.8f, 0.2f, -0.9f, -0.5f}) {
    const glm::vec3 wo = incident(cos_o, 0.4f);
    const float n_o = cos_o > 0.0f ? 1.0f : 1.5f, n_t = cos_o > 0.0f ? 1.5f : 1.0f;
    const double sin_o = std::sqrt(1.0 - cos_o * cos_o);
    const double sin_t = n_o * sin_o / n_t;
    // F from the angles (Fresnel's equations written with both angles, independent of the code's
    // form), or 1 beyond the critical angle.
    double expected_f = 1.0;
    if (sin_t < 1.0) {
      const double ti = std::asin(sin_o), tt = std::asin(sin_t);
      const double rs = std::sin(ti - tt) / std::sin(ti + tt);
      const double rp = std::tan(ti - tt) / std::tan(ti + tt);
      expected_f = 0.5 * (rs * rs + rp * rp);
    }
    Pcg32 rng(3, 4);
    int reflected = 0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
      const BsdfSample s = bsdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()});
      ASSERT_TRUE(s.valid());
      ASSERT_TRUE(s.delta);
      if (s.wi.z * wo.z > 0.0f) {
        ++reflected;
        EXPECT_NEAR(s.wi.z, wo.z, 1e-6f);
        EXPECT_NEAR(s.weight.x, 1.0f, 1e-6f);
      } else {
        const double sin_i = std::sqrt(1.0 - static_cast<double>(s.wi.z) * s.wi.z);
        EXPECT_NEAR(sin_i, sin_t, 1e-5);
        // Opposite azimuth: the refracted ray continues wo's reverse.
        EXPECT_LT(s.wi.x * wo.x, 0.0f);
        EXPECT_NEAR(s.weight.x, (n_o * n_o) / (n_t * n_t), 1e-5f);
      }
    }
    // Binomial z-test of the reflected fraction, 4 standard errors.
    const double se = std::sqrt(expected_f * (1.0 - expected_f) / n);
    EXPECT_NEAR(static_cast<double>(reflected) / n, expected_f, 4.0 * se + 1e-9) << cos_o;
  }
}

// The directional albedo, the mean sampled weight (unbiased for the integral of f cos), never
// above 1 for the rough lobes (radiance transport scales refraction into the denser side by
// 1/eta^2: the test measures energy, so it undoes that); and close to 1 for a white metal at low
// roughness, where single scattering loses little.
TEST(RoughLobes, NeverGainEnergy) {
  for (const float r : {0.2f, 0.5f, 1.0f}) {
    for (const float cos_o : {0.9f, 0.5f, 0.1f, -0.7f, -0.2f}) {
      for (const Material& m : {make(MaterialType::kConductor, r, glm::vec3(1.0f)),
                                make(MaterialType::kDielectric, r, glm::vec3(1.0f)),
                                make(MaterialType::kPrincipled, r, glm::vec3(1.0f)),
                                make(MaterialType::kPrincipled, r, glm::vec3(1.0f), 0.0f, 0.5f)}) {
        const Bsdf bsdf(m);
        if (cos_o < 0.0f && !bsdf.transmits()) continue;
        const glm::vec3 wo = incident(cos_o);
        Pcg32 rng(17, 2);
        double sum = 0.0, sum2 = 0.0;
        const int n = 200000;
        for (int i = 0; i < n; ++i) {
          const BsdfSample s =
              bsdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()});
          double w = s.weight.x;
          if (s.wi.z * wo.z < 0.0f) {
            const double eta = cos_o > 0.0f ? 1.5 : 1.0 / 1.5;
            w *= eta * eta;
          }
          sum += w;
          sum2 += w * w;
        }
        const double mean = sum / n;
        const double se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
        EXPECT_LT(mean, 1.0 + 4.0 * se)
            << "type " << static_cast<int>(m.type) << " r " << r << " cos " << cos_o;
        if (m.type == MaterialType::kConductor && r <= 0.2f && cos_o > 0.3f) {
          EXPECT_GT(mean, 0.97);
        }
      }
    }
  }
}

}  // namespace
}  // namespace tritrace
