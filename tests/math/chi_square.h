// Chi-square goodness-of-fit for the Monte Carlo tests: sampled histograms against expected counts
// integrated from a density, with the p-value from the chi-square distribution computed here.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <span>
#include <sstream>
#include <string>
#include <vector>

namespace tritrace {

// The significance of each chi-square test before correction, and the number of tests in the
// family the Sidak correction spreads it over: every chi-square goodness-of-fit test in
// tests/math/sampling_test.cpp (6), tests/math/sobol_test.cpp (1), tests/render/sampler_test.cpp
// (10: four run for both sampler kinds), tests/render/bsdf_test.cpp (22, one per BsdfLobes
// case), tests/render/environment_light_test.cpp (1, EnvironmentSampling.SamplingFitsThePdf) and
// tests/render/caustic_guide_test.cpp (2, CausticGuide.SamplingFitsTheDensity's two angles); count
// new ones here.
inline constexpr double kChiSquareAlpha = 0.01;
inline constexpr int kChiSquareTests = 42;

// The regularised lower incomplete gamma function P(a, x) = gamma(a, x) / Gamma(a) and its
// complement Q = 1 - P, each by the expansion that converges fast where it is used (Abramowitz and
// Stegun 6.5.29, the series, for x < a + 1; the continued fraction of 6.5.31 for Q otherwise,
// evaluated by Lentz's method), so neither is computed as 1 minus a number close to 1.
inline double gamma_prefactor(double a, double x) {
  return std::exp(a * std::log(x) - x - std::lgamma(a));
}
inline double gamma_p_series(double a, double x) {
  double term = 1.0 / a;
  double sum = term;
  for (int n = 1; n < 100000; ++n) {
    term *= x / (a + n);
    sum += term;
    if (std::fabs(term) < std::fabs(sum) * 1e-16) break;
  }
  return sum * gamma_prefactor(a, x);
}
inline double gamma_q_continued_fraction(double a, double x) {
  // Q = prefactor * 1 / (x + 1 - a - 1 (1 - a) / (x + 3 - a - 2 (2 - a) / (x + 5 - a - ...))).
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a;
  double c = 1.0 / kTiny;
  double d = 1.0 / b;
  double h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < 1e-16) break;
  }
  return h * gamma_prefactor(a, x);
}
inline double regularized_gamma_p(double a, double x) {
  if (x <= 0.0) return 0.0;
  return x < a + 1.0 ? gamma_p_series(a, x) : 1.0 - gamma_q_continued_fraction(a, x);
}
inline double regularized_gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  return x < a + 1.0 ? 1.0 - gamma_p_series(a, x) : gamma_q_continued_fraction(a, x);
}

// The probability that a chi-square variable with `dof` degrees of freedom is at least `statistic`.
inline double chi_square_p_value(double statistic, double dof) {
  return regularized_gamma_q(0.5 * dof, 0.5 * statistic);
}

// The per-test significance that keeps the chance of any false rejection among `tests` independent
// tests at alpha (Sidak 1967).
inline double sidak_significance(double alpha, int tests) {
  return 1.0 - std::pow(1.0 - alpha, 1.0 / tests);
}

struct ChiSquareResult {
  double statistic = 0.0;
  int dof = 0;
  double p_value = 1.0;
  int cells = 0;         // after pooling
  int pooled_cells = 0;  // merged into one because their expected counts were small
  std::string failure;   // non-empty when a sample fell where the density is zero
};

// Pearson's statistic over cells. Cells whose expected count is below min_expected are pooled
// into one (smallest first, as Mitsuba's and pbrt's tests do), since the chi-square approximation
// of the statistic needs about five expected samples per cell. A sample in a cell of expected count
// zero fails outright.
inline ChiSquareResult chi_square(std::span<const double> observed,
                                  std::span<const double> expected, double min_expected = 5.0) {
  ChiSquareResult r;
  std::vector<size_t> order;
  for (size_t i = 0; i < expected.size(); ++i) {
    if (expected[i] > 0.0) {
      order.push_back(i);
    } else if (observed[i] > 0.0) {
      r.failure = "cell " + std::to_string(i) + " has " + std::to_string(observed[i]) +
                  " samples where the density is zero";
      r.p_value = 0.0;
      r.statistic = std::numeric_limits<double>::infinity();
      return r;
    }
  }
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  double pool_observed = 0.0;
  double pool_expected = 0.0;
  for (const size_t i : order) {
    if (expected[i] < min_expected || (pool_expected > 0.0 && pool_expected < min_expected)) {
      pool_observed += observed[i];
      pool_expected += expected[i];
      ++r.pooled_cells;
    } else {
      const double diff = observed[i] - expected[i];
      r.statistic += diff * diff / expected[i];
      ++r.cells;
    }
  }
  if (pool_expected > 0.0) {
    const double diff = pool_observed - pool_expected;
    r.statistic += diff * diff / pool_expected;
    ++r.cells;
  }
  // The counts sum to the number of samples, which removes one degree of freedom.
  r.dof = r.cells - 1;
  r.p_value = r.dof > 0 ? chi_square_p_value(r.statistic, r.dof) : 1.0;
  return r;
}

// Passes when the histogram fits: p-value at least the Sidak-corrected significance.
inline ::testing::AssertionResult chi_square_fits(std::span<const double> observed,
                                                  std::span<const double> expected,
                                                  int tests = kChiSquareTests) {
  const ChiSquareResult r = chi_square(observed, expected);
  const double significance = sidak_significance(kChiSquareAlpha, tests);
  std::ostringstream s;
  s << "chi2 = " << r.statistic << " with " << r.dof << " dof (" << r.cells << " cells, "
    << r.pooled_cells << " pooled), p = " << r.p_value << ", significance " << significance;
  if (!r.failure.empty()) s << "; " << r.failure;
  // In the XML report (--gtest_output=xml), to see how far from the threshold a passing test is.
  ::testing::Test::RecordProperty("chi_square", s.str());
  if (r.failure.empty() && r.p_value >= significance)
    return ::testing::AssertionSuccess() << s.str();
  return ::testing::AssertionFailure() << s.str();
}

// Composite Simpson's rule over [x0, x1] x [y0, y1] with n (even) intervals on each axis: exact for
// cubics, so for the polynomial densities here the expected counts are exact up to rounding.
template <typename F>
double simpson_2d(F f, double x0, double x1, double y0, double y1, int n = 8) {
  const double hx = (x1 - x0) / n;
  const double hy = (y1 - y0) / n;
  const auto weight = [n](int i) { return i == 0 || i == n ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0); };
  double sum = 0.0;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= n; ++j) {
      sum += weight(i) * weight(j) * f(x0 + i * hx, y0 + j * hy);
    }
  }
  return sum * hx * hy / 9.0;
}

}  // namespace tritrace
