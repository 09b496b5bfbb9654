// CausticGuide (render/caustic_guide.h): the cells it bins photons into, its cones' angle, and its
// sampling against its density (a chi-square test; the cones' solid angles by hand).
#include "tritrace/render/caustic_guide.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "../math/chi_square.h"
#include "tritrace/math/random.h"
#include "tritrace/math/sampling.h"

namespace tritrace {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(CausticGuide, BinsPhotonsByCell) {
  const float cell = 0.5f;
  std::vector<CausticPhoton> photons;
  photons.push_back({glm::vec3(0.1f, 0.1f, 0.1f), glm::vec3(0, 0, 1), 1.0f});
  photons.push_back({glm::vec3(0.4f, 0.2f, 0.3f), glm::vec3(0, 1, 0), 1.0f});   // the same cell
  photons.push_back({glm::vec3(-0.1f, 0.1f, 0.1f), glm::vec3(1, 0, 0), 1.0f});  // x < 0: another
  photons.push_back({glm::vec3(NAN, 0.0f, 0.0f), glm::vec3(1, 0, 0), 1.0f});    // dropped
  const CausticGuide guide(photons, cell, 1);
  EXPECT_EQ(guide.cell_count(), 2u);
  EXPECT_EQ(guide.photon_count(), 3u);
  const CausticGuide::Cell a = guide.cell(glm::vec3(0.49f, 0.01f, 0.25f));
  ASSERT_EQ(a.count, 2u);
  EXPECT_EQ(a.axes[0], glm::vec3(0, 0, 1));  // in the photons' order
  EXPECT_EQ(a.axes[1], glm::vec3(0, 1, 0));
  EXPECT_EQ(guide.cell(glm::vec3(-0.3f, 0.2f, 0.2f)).count, 1u);
  EXPECT_EQ(guide.cell(glm::vec3(0.6f, 0.1f, 0.1f)).count, 0u);  // the next cell along x
  EXPECT_EQ(guide.cell(glm::vec3(0.1f, NAN, 0.1f)).count, 0u);
  EXPECT_TRUE(CausticGuide().empty());
  EXPECT_EQ(CausticGuide().cell(glm::vec3(0.0f)).count, 0u);
}

TEST(CausticGuide, KeepsTheFirstPhotonsOfACell) {
  std::vector<CausticPhoton> photons;
  for (uint32_t i = 0; i < CausticGuide::kMaxPerCell + 10; ++i) {
    const float a = 0.001f * static_cast<float>(i);
    photons.push_back({glm::vec3(0.5f), glm::normalize(glm::vec3(a, 0.0f, 1.0f)), 1.0f});
  }
  const CausticGuide guide(photons, 1.0f);
  const CausticGuide::Cell c = guide.cell(glm::vec3(0.5f));
  ASSERT_EQ(c.count, CausticGuide::kMaxPerCell);
  EXPECT_EQ(c.axes[CausticGuide::kMaxPerCell - 1], photons[CausticGuide::kMaxPerCell - 1].w);
}

TEST(CausticGuide, DropsCellsWithFewerPhotonsThanItsMinimum) {
  std::vector<CausticPhoton> photons;
  for (int i = 0; i < 7; ++i) photons.push_back({glm::vec3(0.5f), glm::vec3(0, 0, 1), 1.0f});
  for (int i = 0; i < 8; ++i) photons.push_back({glm::vec3(1.5f), glm::vec3(0, 1, 0), 1.0f});
  const CausticGuide guide(photons, 1.0f, 8);
  EXPECT_EQ(guide.cell_count(), 1u);
  EXPECT_EQ(guide.cell(glm::vec3(0.5f)).count, 0u);
  const CausticGuide::Cell kept = guide.cell(glm::vec3(1.5f));
  ASSERT_EQ(kept.count, 8u);
  EXPECT_EQ(kept.axes[0], glm::vec3(0, 1, 0));
  EXPECT_EQ(CausticGuide::kMinPerCell, 8u);  // the default the integrator builds with
}

// The half-angle: half the RMS angle about the mean direction, at least the cell's edge over the
// median distance, within [1e-3, 0.5] radians.
TEST(CausticGuide, ConeAngleFollowsTheSpreadAndTheParallax) {
  const auto theta = [](const CausticGuide::Cell& c) {
    return 2.0 * std::asin(std::sqrt(0.5 * static_cast<double>(c.one_minus_cos)));
  };
  // Two photons 0.2 rad either side of +z: RMS angle 0.2, so theta = 0.1 (parallax 0.01 / 10).
  const float s = std::sin(0.2f), co = std::cos(0.2f);
  std::vector<CausticPhoton> spread = {{glm::vec3(0.0f), glm::vec3(s, 0, co), 10.0f},
                                       {glm::vec3(0.0f), glm::vec3(-s, 0, co), 10.0f}};
  EXPECT_NEAR(theta(CausticGuide(spread, 0.01f, 1).cell(glm::vec3(0.0f))), 0.1, 1e-5);
  // One photon: no spread, so the parallax, cell 0.05 over distance 0.25.
  std::vector<CausticPhoton> one = {{glm::vec3(0.0f), glm::vec3(0, 0, 1), 0.25f}};
  EXPECT_NEAR(theta(CausticGuide(one, 0.05f, 1).cell(glm::vec3(0.0f))), 0.2, 1e-5);
  // Bounds.
  one[0].distance = 1e6f;
  EXPECT_NEAR(theta(CausticGuide(one, 0.05f, 1).cell(glm::vec3(0.0f))), 1e-3, 1e-7);
  one[0].distance = 0.01f;
  EXPECT_NEAR(theta(CausticGuide(one, 0.05f, 1).cell(glm::vec3(0.0f))), 0.5, 1e-5);
}

// The density by hand: inside k of the N cones, k / (N 2 pi (1 - cos theta)).
TEST(CausticGuide, DensityCountsTheConesHoldingADirection) {
  const glm::vec3 axes[3] = {glm::vec3(0, 0, 1), glm::normalize(glm::vec3(0.1f, 0, 1)),
                             glm::vec3(1, 0, 0)};
  const float theta = 0.3f;
  const float omc = 1.0f - std::cos(theta);
  const CausticGuide::Cell c{axes, 3, omc};
  const double one = 1.0 / (3.0 * 2.0 * kPi * static_cast<double>(omc));
  EXPECT_NEAR(CausticGuide::pdf(c, glm::vec3(0, 0, 1)), 2.0 * one, 1e-4 * one);  // in two
  EXPECT_NEAR(CausticGuide::pdf(c, glm::vec3(1, 0, 0)), one, 1e-4 * one);
  EXPECT_EQ(CausticGuide::pdf(c, glm::vec3(0, 1, 0)), 0.0f);
  EXPECT_EQ(CausticGuide::pdf(c, glm::vec3(0, 0, -1)), 0.0f);  // behind the axis: not inside
  // Just inside and just outside the first cone's rim, away from the others.
  const glm::vec3 in(std::sin(theta - 1e-3f) * -1.0f, 0.0f, std::cos(theta - 1e-3f));
  const glm::vec3 out(std::sin(theta + 1e-3f) * -1.0f, 0.0f, std::cos(theta + 1e-3f));
  EXPECT_NEAR(CausticGuide::pdf(c, in), one, 1e-4 * one);
  EXPECT_EQ(CausticGuide::pdf(c, out), 0.0f);
  EXPECT_EQ(CausticGuide::pdf(CausticGuide::Cell{}, glm::vec3(0, 0, 1)), 0.0f);
}

// Samples of a mixture of three disjoint cones (one narrow), each sample placed in the cone whose
// axis is nearest and binned there by (1 - cos of its angle) / (1 - cos theta) and its azimuth:
// the density is uniform in each cone, so every bin expects the same count, a third of it per
// cone. Sampling outside every cone, or a sample whose density is zero, fails.
TEST(CausticGuide, SamplingFitsTheDensity) {
  const glm::vec3 axes[3] = {glm::vec3(0, 0, 1), glm::normalize(glm::vec3(1, 1, 0)),
                             glm::normalize(glm::vec3(-1, 0.2f, -1))};
  for (const float theta : {0.4f, 0.01f}) {
    const float omc = 2.0f * std::sin(0.5f * theta) * std::sin(0.5f * theta);
    const CausticGuide::Cell c{axes, 3, omc};
    constexpr int kRings = 8, kSectors = 8, kSamples = 96000;
    std::vector<double> observed(3 * kRings * kSectors + 1, 0.0);
    std::vector<double> expected(observed.size(), 0.0);
    for (size_t i = 0; i + 1 < observed.size(); ++i) {
      expected[i] = static_cast<double>(kSamples) / static_cast<double>(3 * kRings * kSectors);
    }
    Pcg32 rng(7, 3);
    int zero_density = 0;
    for (int n = 0; n < kSamples; ++n) {
      const float u0 = rng.next_float();
      const glm::vec2 u(rng.next_float(), rng.next_float());
      const glm::vec3 w = CausticGuide::sample(c, u0, u);
      if (!(CausticGuide::pdf(c, w) > 0.0f)) ++zero_density;
      int k = 0;
      for (int a = 1; a < 3; ++a) {
        if (glm::dot(glm::dvec3(axes[a]), glm::dvec3(w)) >
            glm::dot(glm::dvec3(axes[k]), glm::dvec3(w))) {
          k = a;
        }
      }
      const Frame f = Frame::from_normal(axes[k]);
      const glm::dvec3 local(glm::dot(glm::dvec3(w), glm::dvec3(f.x)),
                             glm::dot(glm::dvec3(w), glm::dvec3(f.y)),
                             glm::dot(glm::dvec3(w), glm::dvec3(f.z)));
      // 1 - cos from the sine, accurately for narrow cones.
      const double sin2 = local.x * local.x + local.y * local.y;
      const double one_minus_cos = sin2 / (1.0 + local.z);
      const double r = one_minus_cos / static_cast<double>(omc);
      if (local.z <= 0.0 || r >= 1.0 + 1e-4) {
        observed.back() += 1.0;  // outside every cone: expected nowhere
        continue;
      }
      const int ring = std::min(kRings - 1, static_cast<int>(r * kRings));
      const double phi = std::atan2(local.y, local.x) + kPi;
      const int sector = std::min(kSectors - 1, static_cast<int>(phi / (2.0 * kPi) * kSectors));
      observed[static_cast<size_t>((k * kRings + ring) * kSectors + sector)] += 1.0;
    }
    EXPECT_EQ(zero_density, 0) << "theta " << theta;
    EXPECT_TRUE(chi_square_fits(observed, expected)) << "theta " << theta;
  }
}

}  // namespace
}  // namespace tritrace
