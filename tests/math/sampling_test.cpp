// The sampling routines against their densities: chi-square fits of sampled histograms to counts
// integrated from the density, every density integrating to one, the frame, the power heuristic
// and the alias table, with expected values from closed forms.
#include "tritrace/math/sampling.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "chi_square.h"
#include "tritrace/math/random.h"

namespace tritrace {
namespace {

constexpr int kSamples = 1'000'000;
constexpr double kPiD = std::numbers::pi;

glm::vec2 next_2d(Pcg32& rng) {
  const float u = rng.next_float();
  return {u, rng.next_float()};
}

// Directions are binned on a grid over (z, phi) in [-1, 1] x [-pi, pi]: the solid angle element is
// dz dphi (Archimedes), so a bin's expected count is N times the integral of the density over it in
// these coordinates, with no Jacobian. The whole sphere is binned, so a warp that puts samples
// below the horizon lands in bins of expected count zero and fails.
constexpr int kZBins = 20;  // even: z = 0, where the cosine density has a kink, is a bin boundary
constexpr int kPhiBins = 40;

size_t direction_cell(glm::vec3 w) {
  const double z = std::clamp(static_cast<double>(w.z), -1.0, 1.0);
  const double phi = std::atan2(static_cast<double>(w.y), static_cast<double>(w.x));
  const int iz = std::min(static_cast<int>((z + 1.0) * 0.5 * kZBins), kZBins - 1);
  const int iphi = std::min(static_cast<int>((phi + kPiD) / (2.0 * kPiD) * kPhiBins), kPhiBins - 1);
  return static_cast<size_t>(iz * kPhiBins + iphi);
}

template <typename Warp>
std::vector<double> direction_histogram(Warp warp, uint64_t seed) {
  std::vector<double> counts(kZBins * kPhiBins, 0.0);
  Pcg32 rng(seed, 1);
  for (int i = 0; i < kSamples; ++i) counts[direction_cell(warp(next_2d(rng)))] += 1.0;
  return counts;
}

// The integral of pdf(direction) over each bin, by Simpson's rule in (z, phi). The outermost nodes
// sit 1e-12 inside the bin, so a density that jumps on a bin boundary (the horizon) is integrated
// with its one-sided values, exactly.
template <typename Pdf>
std::vector<double> direction_integrals(Pdf pdf) {
  std::vector<double> integrals(kZBins * kPhiBins, 0.0);
  for (int iz = 0; iz < kZBins; ++iz) {
    for (int iphi = 0; iphi < kPhiBins; ++iphi) {
      const double z0 = -1.0 + 2.0 * iz / kZBins;
      const double phi0 = -kPiD + 2.0 * kPiD * iphi / kPhiBins;
      integrals[iz * kPhiBins + iphi] = simpson_2d(
          [&](double z, double phi) {
            const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
            return static_cast<double>(pdf(glm::vec3(r * std::cos(phi), r * std::sin(phi), z)));
          },
          z0 + 1e-12, z0 + 2.0 / kZBins - 1e-12, phi0, phi0 + 2.0 * kPiD / kPhiBins);
    }
  }
  return integrals;
}

std::vector<double> times(std::vector<double> v, double n) {
  for (double& x : v) x *= n;
  return v;
}

double sum(const std::vector<double>& v) {
  double s = 0.0;
  for (const double x : v) s += x;
  return s;
}

// Densities as the closed forms say, independently of the code under test.
double cosine_pdf_formula(glm::vec3 w) {
  return std::max(0.0, static_cast<double>(w.z)) / kPiD;
}
double uniform_hemisphere_pdf_formula(glm::vec3 w) {
  return w.z >= 0.0f ? 0.5 / kPiD : 0.0;
}

TEST(SamplingPdfs, EqualTheirClosedForms) {
  for (const float c : {0.0f, 1e-6f, 0.25f, 0.5f, 0.9f, 1.0f}) {
    EXPECT_FLOAT_EQ(cosine_hemisphere_pdf(c), static_cast<float>(c / kPiD)) << c;
  }
  EXPECT_EQ(cosine_hemisphere_pdf(-0.3f), 0.0f);
  EXPECT_EQ(cosine_hemisphere_pdf(-0.0f), 0.0f);
  EXPECT_FLOAT_EQ(uniform_hemisphere_pdf(), static_cast<float>(1.0 / (2.0 * kPiD)));
  EXPECT_FLOAT_EQ(uniform_sphere_pdf(), static_cast<float>(1.0 / (4.0 * kPiD)));
}

TEST(SamplingPdfs, IntegrateToOne) {
  EXPECT_NEAR(sum(direction_integrals([](glm::vec3 w) { return cosine_hemisphere_pdf(w.z); })), 1.0,
              1e-3);
  EXPECT_NEAR(sum(direction_integrals(
                  [](glm::vec3 w) { return w.z >= 0.0f ? uniform_hemisphere_pdf() : 0.0f; })),
              1.0, 1e-3);
  EXPECT_NEAR(sum(direction_integrals([](glm::vec3) { return uniform_sphere_pdf(); })), 1.0, 1e-3);
  // The disk's 1/pi over the unit disk in polar coordinates, r dr dphi.
  EXPECT_NEAR(simpson_2d([](double r, double) { return r / kPiD; }, 0.0, 1.0, 0.0, 2.0 * kPiD), 1.0,
              1e-3);
}

TEST(SampleCosineHemisphere, FitsItsPdf) {
  const std::vector<double> observed = direction_histogram(sample_cosine_hemisphere, 1);
  const std::vector<double> expected =
      times(direction_integrals([](glm::vec3 w) { return cosine_hemisphere_pdf(w.z); }), kSamples);
  EXPECT_TRUE(chi_square_fits(observed, expected));
}

TEST(SampleUniformHemisphere, FitsItsPdf) {
  const std::vector<double> observed = direction_histogram(sample_uniform_hemisphere, 2);
  const std::vector<double> expected = times(direction_integrals([](glm::vec3 w) {
                                               return w.z >= 0.0f ? uniform_hemisphere_pdf() : 0.0f;
                                             }),
                                             kSamples);
  EXPECT_TRUE(chi_square_fits(observed, expected));
}

TEST(SampleUniformSphere, FitsItsPdf) {
  const std::vector<double> observed = direction_histogram(sample_uniform_sphere, 3);
  const std::vector<double> expected =
      times(direction_integrals([](glm::vec3) { return uniform_sphere_pdf(); }), kSamples);
  EXPECT_TRUE(chi_square_fits(observed, expected));
}

TEST(ChiSquarePower, RejectsCosineSamplesAgainstTheUniformPdf) {
  // The test must be able to fail: cosine-weighted directions judged against the uniform density,
  // and uniform ones against the cosine density, are rejected far beyond the significance.
  const std::vector<double> cosine = direction_histogram(sample_cosine_hemisphere, 4);
  const std::vector<double> uniform_expected =
      times(direction_integrals(uniform_hemisphere_pdf_formula), kSamples);
  EXPECT_FALSE(chi_square_fits(cosine, uniform_expected));
  EXPECT_LT(chi_square(cosine, uniform_expected).p_value, 1e-12);
  const std::vector<double> uniform = direction_histogram(sample_uniform_hemisphere, 5);
  const std::vector<double> cosine_expected =
      times(direction_integrals(cosine_pdf_formula), kSamples);
  EXPECT_FALSE(chi_square_fits(uniform, cosine_expected));
}

TEST(ChiSquarePower, RejectsASlightlyWrongDensity) {
  // (1 + 0.1 (cos - 2/3)) cos / pi is normalised (the mean cosine under cos/pi is 2/3) and differs
  // from cos/pi by -7% to +3%; its non-centrality N 0.1^2 Var(cos) = 1e6 / 1800 is far beyond the
  // statistic's spread over these cells, so a million cosine samples reject it.
  const std::vector<double> cosine = direction_histogram(sample_cosine_hemisphere, 6);
  const std::vector<double> skewed = times(direction_integrals([](glm::vec3 w) {
                                             const double c = std::max(0.0f, w.z);
                                             return (1.0 + 0.1 * (c - 2.0 / 3.0)) * c / kPiD;
                                           }),
                                           kSamples);
  EXPECT_NEAR(sum(skewed), kSamples, 1e-6 * kSamples);
  EXPECT_FALSE(chi_square_fits(cosine, skewed));
}

TEST(SampleCosineHemisphere, UnitDirectionsAboveTheHorizonEvenAtTheSquaresEdges) {
  for (const float a : {0.0f, 1e-7f, 0.25f, 0.5f, 0.75f, kOneMinusEpsilon}) {
    for (const float b : {0.0f, 1e-7f, 0.25f, 0.5f, 0.75f, kOneMinusEpsilon}) {
      const glm::vec3 w = sample_cosine_hemisphere({a, b});
      EXPECT_NEAR(glm::length(w), 1.0f, 1e-6f) << a << " " << b;
      EXPECT_GE(w.z, 0.0f);
      const glm::vec3 s = sample_uniform_sphere({a, b});
      EXPECT_NEAR(glm::length(s), 1.0f, 1e-6f);
      const glm::vec3 h = sample_uniform_hemisphere({a, b});
      EXPECT_NEAR(glm::length(h), 1.0f, 1e-6f);
      EXPECT_GE(h.z, 0.0f);
    }
  }
  // The centre of the square is the zenith.
  EXPECT_EQ(sample_cosine_hemisphere({0.5f, 0.5f}), glm::vec3(0.0f, 0.0f, 1.0f));
}

TEST(SampleUniformDiskConcentric, MapsTheSquaresCentreAndEdgesAsShirleyAndChiuDraw) {
  // Concentric squares go to concentric circles: the centre to the origin, the midpoints of the
  // square's sides to the circle's axis points, the corner (0, 0) (half-width 1, on the diagonal)
  // to radius 1 at 225 degrees.
  EXPECT_EQ(sample_uniform_disk_concentric({0.5f, 0.5f}), glm::vec2(0.0f));
  const glm::vec2 right = sample_uniform_disk_concentric({1.0f, 0.5f});
  EXPECT_NEAR(right.x, 1.0f, 1e-6f);
  EXPECT_NEAR(right.y, 0.0f, 1e-6f);
  const glm::vec2 top = sample_uniform_disk_concentric({0.5f, 1.0f});
  EXPECT_NEAR(top.x, 0.0f, 1e-6f);
  EXPECT_NEAR(top.y, 1.0f, 1e-6f);
  const glm::vec2 corner = sample_uniform_disk_concentric({0.0f, 0.0f});
  EXPECT_NEAR(corner.x, -std::numbers::sqrt2_v<float> / 2.0f, 1e-6f);
  EXPECT_NEAR(corner.y, -std::numbers::sqrt2_v<float> / 2.0f, 1e-6f);
  // A point at half-width 0.5 stays at radius 0.5.
  EXPECT_NEAR(glm::length(sample_uniform_disk_concentric({0.75f, 0.6f})), 0.5f, 1e-6f);
}

TEST(SampleUniformDiskConcentric, FitsTheUniformDensity) {
  // Bins over (s, phi) = (r^2, phi) in [0, 1] x [-pi, pi]: the area element r dr dphi is
  // ds dphi / 2, so the density 1/pi becomes 1/(2 pi) there.
  constexpr int kSBins = 20;
  std::vector<double> observed(kSBins * kPhiBins, 0.0);
  Pcg32 rng(7, 1);
  for (int i = 0; i < kSamples; ++i) {
    const glm::vec2 p = sample_uniform_disk_concentric(next_2d(rng));
    const double s = static_cast<double>(p.x) * p.x + static_cast<double>(p.y) * p.y;
    ASSERT_LE(s, 1.0 + 1e-6);
    const double phi = std::atan2(static_cast<double>(p.y), static_cast<double>(p.x));
    const int is = std::min(static_cast<int>(s * kSBins), kSBins - 1);
    const int iphi =
        std::min(static_cast<int>((phi + kPiD) / (2.0 * kPiD) * kPhiBins), kPhiBins - 1);
    observed[is * kPhiBins + iphi] += 1.0;
  }
  std::vector<double> expected(observed.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    expected[i] = kSamples * simpson_2d([](double, double) { return 0.5 / kPiD; }, 0.0,
                                        1.0 / kSBins, 0.0, 2.0 * kPiD / kPhiBins);
  }
  EXPECT_TRUE(chi_square_fits(observed, expected));
}

// The triangle test works in barycentric space: (b1, b2) uniform over the triangle b1, b2 >= 0,
// b1 + b2 <= 1 (area 1/2, density 2; any triangle is its affine image, which keeps uniformity).
// Bins are the cells of a grid over [0, 1]^2; a cell's expected count is 2 N times the area of its
// part below the line b1 + b2 = 1, integrated exactly by the trapezoidal rule between the kinks of
// the (piecewise linear) height of that part.
constexpr int kTriangleBins = 32;

double area_below_diagonal(double x0, double x1, double y0, double y1) {
  const auto height = [&](double x) { return std::clamp(1.0 - x - y0, 0.0, y1 - y0); };
  std::vector<double> xs{x0, x1};
  for (const double kink : {1.0 - y1, 1.0 - y0}) {
    if (kink > x0 && kink < x1) xs.push_back(kink);
  }
  std::sort(xs.begin(), xs.end());
  double area = 0.0;
  for (size_t i = 0; i + 1 < xs.size(); ++i) {
    area += 0.5 * (height(xs[i]) + height(xs[i + 1])) * (xs[i + 1] - xs[i]);
  }
  return area;
}

std::vector<double> triangle_expected() {
  std::vector<double> expected(kTriangleBins * kTriangleBins);
  const double h = 1.0 / kTriangleBins;
  for (int i = 0; i < kTriangleBins; ++i) {
    for (int j = 0; j < kTriangleBins; ++j) {
      expected[i * kTriangleBins + j] =
          kSamples * 2.0 * area_below_diagonal(i * h, (i + 1) * h, j * h, (j + 1) * h);
    }
  }
  return expected;
}

template <typename Warp>
std::vector<double> triangle_histogram(Warp warp, uint64_t seed) {
  std::vector<double> observed(kTriangleBins * kTriangleBins, 0.0);
  Pcg32 rng(seed, 1);
  for (int n = 0; n < kSamples; ++n) {
    const glm::vec3 b = warp(next_2d(rng));
    const int i = std::min(static_cast<int>(b.y * kTriangleBins), kTriangleBins - 1);
    const int j = std::min(static_cast<int>(b.z * kTriangleBins), kTriangleBins - 1);
    observed[i * kTriangleBins + j] += 1.0;
  }
  return observed;
}

TEST(SampleUniformTriangle, TheExpectedCountsIntegrateTheDensityToOne) {
  EXPECT_NEAR(sum(triangle_expected()) / kSamples, 1.0, 1e-12);
  // A cell cut by the diagonal through its corners holds half its area.
  EXPECT_DOUBLE_EQ(area_below_diagonal(0.5, 0.75, 0.25, 0.5), 0.5 * 0.25 * 0.25);
  EXPECT_DOUBLE_EQ(area_below_diagonal(0.0, 0.25, 0.0, 0.25), 0.25 * 0.25);
  EXPECT_DOUBLE_EQ(area_below_diagonal(0.75, 1.0, 0.5, 0.75), 0.0);
}

TEST(SampleUniformTriangle, FitsTheUniformDensity) {
  const std::vector<double> observed = triangle_histogram(sample_uniform_triangle, 8);
  EXPECT_TRUE(chi_square_fits(observed, triangle_expected()));
}

TEST(SampleUniformTriangle, BarycentricsAreValid) {
  Pcg32 rng(9, 1);
  for (int n = 0; n < 100000; ++n) {
    const glm::vec3 b = sample_uniform_triangle(next_2d(rng));
    ASSERT_GE(b.x, 0.0f);
    ASSERT_GE(b.y, 0.0f);
    ASSERT_GE(b.z, 0.0f);
    ASSERT_NEAR(b.x + b.y + b.z, 1.0f, 1e-6f);
  }
  for (const float a : {0.0f, 0.5f, kOneMinusEpsilon}) {
    for (const float c : {0.0f, 0.5f, kOneMinusEpsilon}) {
      const glm::vec3 b = sample_uniform_triangle({a, c});
      EXPECT_GE(b.z, 0.0f);
      EXPECT_NEAR(b.x + b.y + b.z, 1.0f, 1e-6f);
    }
  }
}

TEST(SampleUniformTriangle, PreservesAreaEverywhere) {
  // A uniform map has a constant Jacobian: area 1/2 (the barycentric triangle) over area 1 (the
  // square). Central differences on each side of the diagonal where the map is smooth.
  Pcg32 rng(10, 1);
  constexpr float kH = 1.0f / 1024.0f;
  for (int n = 0; n < 1000; ++n) {
    const glm::vec2 u = 0.01f + 0.98f * next_2d(rng);
    if (std::fabs(u.x - u.y) < 4.0f * kH) continue;
    const glm::vec3 dx = (sample_uniform_triangle(u + glm::vec2(kH, 0.0f)) -
                          sample_uniform_triangle(u - glm::vec2(kH, 0.0f))) /
                         (2.0f * kH);
    const glm::vec3 dy = (sample_uniform_triangle(u + glm::vec2(0.0f, kH)) -
                          sample_uniform_triangle(u - glm::vec2(0.0f, kH))) /
                         (2.0f * kH);
    EXPECT_NEAR(std::fabs(dx.y * dy.z - dx.z * dy.y), 0.5f, 1e-3f) << u.x << " " << u.y;
  }
}

TEST(ChiSquarePower, RejectsTheNaiveTriangleMap) {
  // b0 = u0, b1 = (1 - u0) u1 lands in the triangle but crowds the vertex b0 = 1: not uniform.
  const std::vector<double> observed = triangle_histogram(
      [](glm::vec2 u) {
        return glm::vec3(u.x, (1.0f - u.x) * u.y, 1.0f - u.x - (1.0f - u.x) * u.y);
      },
      11);
  EXPECT_FALSE(chi_square_fits(observed, triangle_expected()));
}

TEST(Frame, OrthonormalRightHandedForEveryNormal) {
  std::vector<glm::vec3> normals{{0, 0, 1},
                                 {0, 0, -1},
                                 {1, 0, 0},
                                 {0, -1, 0},
                                 {1.0f, 0.0f, -0.0f},
                                 glm::normalize(glm::vec3(1e-4f, 0.0f, -1.0f)),
                                 glm::normalize(glm::vec3(1e-7f, -1e-7f, -1.0f)),
                                 glm::normalize(glm::vec3(-3e-4f, 2e-4f, 1.0f)),
                                 glm::normalize(glm::vec3(1.0f, 1.0f, 1e-6f))};
  Pcg32 rng(12, 1);
  for (int n = 0; n < 100000; ++n) normals.push_back(sample_uniform_sphere(next_2d(rng)));
  for (const glm::vec3& n : normals) {
    const Frame f = Frame::from_normal(n);
    ASSERT_EQ(f.z, n);
    ASSERT_NEAR(glm::length(f.x), 1.0f, 1e-6f) << n.x << " " << n.y << " " << n.z;
    ASSERT_NEAR(glm::length(f.y), 1.0f, 1e-6f);
    ASSERT_NEAR(glm::dot(f.x, f.y), 0.0f, 1e-6f);
    ASSERT_NEAR(glm::dot(f.x, f.z), 0.0f, 1e-6f);
    ASSERT_NEAR(glm::dot(f.y, f.z), 0.0f, 1e-6f);
    ASSERT_LT(glm::length(glm::cross(f.x, f.y) - f.z), 1e-6f);
    const glm::vec3 local_n = f.to_local(n);
    ASSERT_NEAR(local_n.z, 1.0f, 1e-6f);
  }
}

TEST(Frame, ToWorldUndoesToLocal) {
  Pcg32 rng(13, 1);
  for (int n = 0; n < 100000; ++n) {
    const Frame f = Frame::from_normal(sample_uniform_sphere(next_2d(rng)));
    const glm::vec3 v = sample_uniform_sphere(next_2d(rng));
    const glm::vec3 back = f.to_world(f.to_local(v));
    ASSERT_LT(glm::length(back - v), 1e-6f);
    // A local direction's z is its cosine to the normal.
    const glm::vec3 w = sample_cosine_hemisphere(next_2d(rng));
    ASSERT_NEAR(glm::dot(f.to_world(w), f.z), w.z, 1e-6f);
  }
  const Frame down = Frame::from_normal({0.0f, 0.0f, -1.0f});
  EXPECT_EQ(down.to_world({0.0f, 0.0f, 1.0f}), glm::vec3(0.0f, 0.0f, -1.0f));
}

TEST(PowerHeuristic, ClosedFormValues) {
  // f^2 / (f^2 + g^2) with f = nf f_pdf, g = ng g_pdf.
  EXPECT_FLOAT_EQ(power_heuristic(1, 0.5f, 1, 0.5f), 0.5f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 2.0f, 1, 1.0f), 0.8f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 1.0f, 1, 2.0f), 0.2f);
  EXPECT_FLOAT_EQ(power_heuristic(2, 1.0f, 1, 1.0f), 0.8f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 3.0f, 4, 1.0f), 9.0f / 25.0f);
  Pcg32 rng(14, 1);
  for (int n = 0; n < 1000; ++n) {
    const float f = 10.0f * rng.next_float() + 1e-3f;
    const float g = 10.0f * rng.next_float() + 1e-3f;
    EXPECT_NEAR(power_heuristic(1, f, 1, g) + power_heuristic(1, g, 1, f), 1.0f, 1e-6f);
  }
}

TEST(PowerHeuristic, RobustAtTheLimits) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  EXPECT_EQ(power_heuristic(1, kInf, 1, 0.0f), 1.0f);  // a delta light or a mirror
  EXPECT_EQ(power_heuristic(1, kInf, 1, 5.0f), 1.0f);
  EXPECT_EQ(power_heuristic(1, kInf, 1, kInf), 1.0f);
  EXPECT_EQ(power_heuristic(1, 2.0f, 1, kInf), 0.0f);
  EXPECT_EQ(power_heuristic(1, 0.0f, 1, 0.0f), 0.0f);  // 0/0
  EXPECT_EQ(power_heuristic(1, 0.0f, 1, 3.0f), 0.0f);
  EXPECT_EQ(power_heuristic(1, 3.0f, 1, 0.0f), 1.0f);
  // Squares of 1e30 overflow float; the weight does not.
  EXPECT_FLOAT_EQ(power_heuristic(1, 1e30f, 1, 1e30f), 0.5f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 2e30f, 1, 1e30f), 0.8f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 1e-30f, 1, 2e-30f), 0.2f);
}

TEST(AliasTable, PmfIsWeightOverSum) {
  const std::vector<float> weights{1.0f, 2.0f, 3.0f, 0.0f, 4.0f};
  const AliasTable table(weights);
  ASSERT_EQ(table.size(), 5u);
  EXPECT_FALSE(table.empty());
  const float expected[] = {0.1f, 0.2f, 0.3f, 0.0f, 0.4f};
  for (uint32_t i = 0; i < 5; ++i) EXPECT_FLOAT_EQ(table.pmf(i), expected[i]) << i;
  EXPECT_EQ(table.pmf(5), 0.0f);
  Pcg32 rng(15, 1);
  for (int n = 0; n < 10000; ++n) {
    const AliasTable::Sample s = table.sample(rng.next_float());
    ASSERT_LT(s.index, 5u);
    ASSERT_NE(s.index, 3u);
    ASSERT_EQ(s.pmf, table.pmf(s.index));
  }
}

TEST(AliasTable, EveryUniformNumberRealisesThePmfToWithinItsResolution) {
  // All 2^24 floats the sampler can give, in order: each index's frequency is its pmf up to the
  // coin's resolution, 2^-24 per column (at most all 7 columns can hand out one index).
  const std::vector<float> weights{0.5f, 3.0f, 0.0f, 1e-3f, 2.0f, 7.0f, 0.25f};
  const AliasTable table(weights);
  std::vector<double> counts(weights.size(), 0.0);
  for (uint32_t k = 0; k < (1u << 24); ++k) counts[table.sample(k * 0x1p-24f).index] += 1.0;
  const double total = 0.5 + 3.0 + 0.0 + 1e-3 + 2.0 + 7.0 + 0.25;
  for (size_t i = 0; i < weights.size(); ++i) {
    EXPECT_NEAR(counts[i] * 0x1p-24, static_cast<double>(weights[i]) / total, 7 * 0x1p-24) << i;
  }
  EXPECT_EQ(counts[2], 0.0);
}

std::vector<float> alias_test_weights() {
  // 64 weights spread over six orders of magnitude, with zeros and one dominant entry.
  std::vector<float> w(64);
  for (size_t i = 0; i < w.size(); ++i) {
    w[i] = i % 9 == 4 ? 0.0f : std::pow(10.0f, static_cast<float>((i * 37) % 13) / 4.0f - 2.0f);
  }
  w[17] = 500.0f;
  return w;
}

std::vector<double> alias_histogram(const AliasTable& table, uint64_t seed) {
  std::vector<double> counts(table.size(), 0.0);
  Pcg32 rng(seed, 1);
  for (int n = 0; n < kSamples; ++n) counts[table.sample(rng.next_float()).index] += 1.0;
  return counts;
}

TEST(AliasTable, SamplingFrequenciesFitTheWeights) {
  const std::vector<float> weights = alias_test_weights();
  double total = 0.0;
  for (const float w : weights) total += w;
  std::vector<double> expected(weights.size());
  for (size_t i = 0; i < weights.size(); ++i) expected[i] = kSamples * weights[i] / total;
  EXPECT_TRUE(chi_square_fits(alias_histogram(AliasTable(weights), 16), expected));
}

TEST(AliasTable, UniformWeightsReturnTheirOwnColumn) {
  const std::vector<float> weights(10, 2.5f);
  const AliasTable table(weights);
  for (int k = 0; k < 1000; ++k) {
    const float u = k / 1000.0f;
    // floor(u n) of the exact product (in double; float's u * 10 can round up to the next column).
    EXPECT_EQ(table.sample(u).index, static_cast<uint32_t>(static_cast<double>(u) * 10.0)) << u;
    EXPECT_FLOAT_EQ(table.sample(u).pmf, 0.1f);
  }
  EXPECT_EQ(table.sample(1.0f).index, 9u);  // out of contract, still in range
}

TEST(ChiSquarePower, RejectsAliasFrequenciesAgainstAWeightFivePercentOff) {
  std::vector<float> weights(16, 1.0f);
  const AliasTable table(weights);
  std::vector<double> expected(16, kSamples / 16.0);
  expected[3] *= 1.05;
  expected[4] *= 0.95;
  EXPECT_FALSE(chi_square_fits(alias_histogram(table, 17), expected));
}

TEST(AliasTable, SingleNonZeroWeightIsAlwaysSampled) {
  const std::vector<float> weights{0.0f, 0.0f, 5.0f, 0.0f};
  const AliasTable table(weights);
  ASSERT_EQ(table.size(), 4u);
  EXPECT_EQ(table.pmf(2), 1.0f);
  for (const float u : {0.0f, 0.1f, 0.25f, 0.3f, 0.5f, 0.7f, 0.75f, 0.99f, kOneMinusEpsilon}) {
    const AliasTable::Sample s = table.sample(u);
    EXPECT_EQ(s.index, 2u) << u;
    EXPECT_EQ(s.pmf, 1.0f);
  }
  const std::vector<float> one{3.0f};
  EXPECT_EQ(AliasTable(one).sample(0.7f).index, 0u);
}

TEST(AliasTable, ZeroTotalOrNoWeightsIsEmpty) {
  const std::vector<float> zeros{0.0f, 0.0f, -0.0f};
  for (const AliasTable& table :
       {AliasTable(zeros), AliasTable(std::span<const float>()), AliasTable()}) {
    EXPECT_TRUE(table.empty());
    EXPECT_EQ(table.size(), 0u);
    EXPECT_EQ(table.pmf(0), 0.0f);
    const AliasTable::Sample s = table.sample(0.5f);
    EXPECT_EQ(s.index, 0u);
    EXPECT_EQ(s.pmf, 0.0f);
  }
}

TEST(AliasTable, BadWeightsThrow) {
  for (const float bad :
       {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
        -std::numeric_limits<float>::infinity(), -1.0f, -1e-30f}) {
    const std::vector<float> weights{1.0f, bad, 2.0f};
    EXPECT_THROW(AliasTable{weights}, std::invalid_argument) << bad;
  }
  // The largest floats sum without overflow (in double).
  const std::vector<float> huge(4, std::numeric_limits<float>::max());
  EXPECT_FLOAT_EQ(AliasTable(huge).pmf(1), 0.25f);
}

}  // namespace
}  // namespace tritrace
