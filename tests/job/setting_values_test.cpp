// The shared flag parsers and formatters: what the viewer prints must parse back to exactly the
// value it rendered with.
#include "tritrace/job/setting_values.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

namespace tritrace::cli {
namespace {

bool same_bits(float a, float b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

TEST(FormatNumbers, ShortestForms) {
  EXPECT_EQ(format_double(0.1234), "0.1234");
  EXPECT_EQ(format_double(0.75), "0.75");
  EXPECT_EQ(format_double(-0.0), "-0");
  EXPECT_EQ(format_float(3.0f), "3");
  EXPECT_EQ(format_float(-0.7f), "-0.7");
  EXPECT_EQ(format_float(0.1f), "0.1");
  EXPECT_EQ(format_vec3(glm::vec3(0.0f, -0.5f, -0.7f)), "0,-0.5,-0.7");
}

TEST(FormatNumbers, FloatsRoundTripThroughTheCliParser) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<uint32_t> bits;
  int tested = 0;
  while (tested < 200000) {
    const uint32_t b = bits(rng);
    float f = 0.0f;
    std::memcpy(&f, &b, sizeof f);
    if (!std::isfinite(f)) continue;
    ++tested;
    const std::optional<float> back = parse_float(format_float(f));
    ASSERT_TRUE(back.has_value()) << format_float(f);
    ASSERT_TRUE(same_bits(*back, f)) << format_float(f);
  }
  EXPECT_TRUE(same_bits(*parse_float(format_float(-0.0f)), -0.0f));
  const float max = std::numeric_limits<float>::max();
  EXPECT_EQ(*parse_float(format_float(max)), max);
}

TEST(FormatNumbers, DoublesRoundTripThroughTheCliParser) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> yaw(-100.0, 100.0);
  for (int i = 0; i < 100000; ++i) {
    const double y = yaw(rng);
    ASSERT_EQ(*parse_finite(format_double(y)), y) << format_double(y);
  }
}

TEST(Distance, PositiveFloatsOnly) {
  EXPECT_EQ(check_distance("3"), "");
  EXPECT_EQ(check_distance("0.001"), "");
  EXPECT_NE(check_distance("0"), "");
  EXPECT_NE(check_distance("-2"), "");
  EXPECT_NE(check_distance("1e-50"), "");  // rounds to float 0
  EXPECT_NE(check_distance("1e39"), "");   // beyond float
  EXPECT_NE(check_distance("inf"), "");
}

}  // namespace
}  // namespace tritrace::cli
