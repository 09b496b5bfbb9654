// The chi-square machinery the sampling tests rely on, against published table values and the
// distribution's closed forms for small degrees of freedom.
#include "chi_square.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace tritrace {
namespace {

TEST(ChiSquarePValue, MatchesPublishedCriticalValues) {
  // Upper-tail critical values of the chi-square distribution (NIST/SEMATECH e-Handbook of
  // Statistical Methods, table 1.3.6.7.4), given to three decimals: the p-value at each is the
  // table's significance up to that rounding.
  struct Row {
    double dof, critical, p;
  };
  for (const Row& row : {Row{1, 6.635, 0.01}, Row{2, 9.210, 0.01}, Row{9, 21.666, 0.01},
                         Row{10, 23.209, 0.01}, Row{100, 135.807, 0.01}, Row{1, 3.841, 0.05},
                         Row{5, 11.070, 0.05}, Row{30, 43.773, 0.05}, Row{50, 67.505, 0.05}}) {
    EXPECT_NEAR(chi_square_p_value(row.critical, row.dof), row.p, 2e-5 * row.p / 0.01)
        << row.dof << " dof at " << row.critical;
  }
}

TEST(ChiSquarePValue, MatchesClosedFormsOnBothSidesOfTheSeriesSwitch) {
  // Q(chi2 >= x) is erfc(sqrt(x/2)) for 1 dof, exp(-x/2) for 2, exp(-x/2)(1 + x/2) for 4: these
  // cover x below a + 1 (series) and above (continued fraction).
  for (const double x : {0.01, 0.3, 1.0, 1.9, 2.5, 4.0, 7.0, 15.0, 40.0, 90.0}) {
    EXPECT_NEAR(chi_square_p_value(x, 1), std::erfc(std::sqrt(0.5 * x)), 1e-13) << x;
    EXPECT_NEAR(chi_square_p_value(x, 2), std::exp(-0.5 * x), 1e-13) << x;
    EXPECT_NEAR(chi_square_p_value(x, 4), std::exp(-0.5 * x) * (1.0 + 0.5 * x), 1e-13) << x;
    // Relative accuracy in the far tail, where a test's p-value is decided.
    EXPECT_NEAR(chi_square_p_value(x, 2) / std::exp(-0.5 * x), 1.0, 1e-12) << x;
    EXPECT_NEAR(regularized_gamma_p(1.0, x) + regularized_gamma_q(1.0, x), 1.0, 1e-14);
  }
  EXPECT_EQ(chi_square_p_value(0.0, 3), 1.0);
}

TEST(ChiSquarePValue, LargeDegreesOfFreedomCentreOnTheMean) {
  // For many degrees of freedom chi2 is close to normal with mean k and variance 2k: the p-value at
  // the mean tends to 1/2 (from below, since the right skew puts the median below the mean: by
  // Wilson and Hilferty's cube-root approximation 0.5 - 0.188 / sqrt(k)); at two standard
  // deviations above the mean it is near the normal tail 0.0228 (larger, by the skew).
  for (const double k : {400.0, 1600.0}) {
    EXPECT_NEAR(chi_square_p_value(k, k), 0.5 - 0.188 / std::sqrt(k), 1e-3) << k;
    const double two_sigma = chi_square_p_value(k + 2.0 * std::sqrt(2.0 * k), k);
    EXPECT_GT(two_sigma, 0.0228);
    EXPECT_LT(two_sigma, 0.0228 + 0.6 / std::sqrt(k));
  }
}

TEST(SidakSignificance, SpreadsAlphaOverTheFamily) {
  EXPECT_NEAR(sidak_significance(0.01, 1), 0.01, 1e-15);
  EXPECT_NEAR(sidak_significance(0.05, 2), 1.0 - std::sqrt(0.95), 1e-15);
  // 1 - (1 - s)^m gives back alpha.
  EXPECT_NEAR(1.0 - std::pow(1.0 - sidak_significance(0.01, 13), 13.0), 0.01, 1e-14);
}

TEST(ChiSquare, StatisticAndDegreesOfFreedomByHand) {
  const std::vector<double> observed{10, 20, 30};
  const std::vector<double> expected{20, 20, 20};
  const ChiSquareResult r = chi_square(observed, expected);
  EXPECT_DOUBLE_EQ(r.statistic, (100.0 + 0.0 + 100.0) / 20.0);
  EXPECT_EQ(r.dof, 2);
  EXPECT_NEAR(r.p_value, std::exp(-5.0), 1e-14);
}

TEST(ChiSquare, PoolsCellsWithFewExpectedSamples) {
  // Expected 1, 2, 3 are pooled into one cell (6 expected, 7 observed); 44 and 50 stand alone.
  const std::vector<double> observed{3, 50, 0, 43, 4};
  const std::vector<double> expected{2, 50, 1, 44, 3};
  const ChiSquareResult r = chi_square(observed, expected);
  EXPECT_EQ(r.pooled_cells, 3);
  EXPECT_EQ(r.cells, 3);
  EXPECT_EQ(r.dof, 2);
  EXPECT_DOUBLE_EQ(r.statistic, 1.0 / 6.0 + 0.0 + 1.0 / 44.0);
}

TEST(ChiSquare, PoolTooSmallOnItsOwnTakesTheNextCell) {
  // 1 + 2 is below five, so the next smallest cell (10) joins the pool: two cells remain.
  const std::vector<double> observed{1, 2, 10, 30};
  const std::vector<double> expected{1, 2, 10, 30};
  const ChiSquareResult r = chi_square(observed, expected);
  EXPECT_EQ(r.pooled_cells, 3);
  EXPECT_EQ(r.cells, 2);
  EXPECT_EQ(r.statistic, 0.0);
  EXPECT_EQ(r.p_value, 1.0);
}

TEST(ChiSquare, SampleWhereTheDensityIsZeroFails) {
  const std::vector<double> observed{10, 1, 10};
  const std::vector<double> expected{10.5, 0, 10.5};
  EXPECT_EQ(chi_square(observed, expected).p_value, 0.0);
  EXPECT_FALSE(chi_square_fits(observed, expected));
  // Empty cells with nothing expected are simply left out.
  const std::vector<double> no_sample{10, 0, 10};
  EXPECT_EQ(chi_square(no_sample, expected).dof, 1);
}

TEST(Simpson2d, ExactForCubics) {
  // The integral of x^3 y^2 over [0, 2] x [1, 3] is (16 / 4) (26 / 3).
  EXPECT_NEAR(simpson_2d([](double x, double y) { return x * x * x * y * y; }, 0, 2, 1, 3),
              4.0 * 26.0 / 3.0, 1e-12);
}

}  // namespace
}  // namespace tritrace
