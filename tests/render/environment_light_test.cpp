// The environment map against independent answers: its axis convention at hand-picked directions,
// the piecewise-constant distributions' densities by hand, chi-square of the map's sampling against
// its solid-angle pdf, the pdf integrated over the sphere, a single bright texel, HDR and EXR files
// read back, and the scene file's "environment" keys with their errors.
#include "tritrace/render/environment_light.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "../math/chi_square.h"
#include "tritrace/error.h"
#include "tritrace/image/image_io.h"
#include "tritrace/math/piecewise_constant.h"
#include "tritrace/math/random.h"
#include "tritrace/scene/io/scene_file.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;
constexpr double kPiD = std::numbers::pi;

void expect_near(glm::vec3 a, glm::vec3 b, float tol = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

EnvironmentMap map_of(int w, int h, const std::function<glm::vec3(int, int)>& texel) {
  EnvironmentMap m;
  m.width = w;
  m.height = h;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) m.texels.push_back(texel(x, y));
  }
  return m;
}

TEST(PiecewiseConstant, DensitiesAreWeightsOverTheirMean) {
  const std::vector<float> w{1.0f, 0.0f, 3.0f, 4.0f};
  const PiecewiseConstant1D d(w);
  // Mean weight 2: the densities are 1/2, 0, 3/2, 2 (they integrate to 1 over [0, 1)).
  EXPECT_FLOAT_EQ(d.pdf(0), 0.5f);
  EXPECT_FLOAT_EQ(d.pdf(1), 0.0f);
  EXPECT_FLOAT_EQ(d.pdf(2), 1.5f);
  EXPECT_FLOAT_EQ(d.pdf(3), 2.0f);
  // The CDF is 0, 1/8, 1/8, 4/8, 1: u = 0.3 is (0.3 - 1/8) / (3/8) = 7/15 into cell 2, so
  // x = (2 + 7/15) / 4 = 37/60.
  const PiecewiseConstant1D::Sample s = d.sample(0.3f);
  EXPECT_EQ(s.cell, 2u);
  EXPECT_NEAR(s.x, 37.0f / 60.0f, 1e-6f);
  EXPECT_FLOAT_EQ(s.pdf, 1.5f);
  // The zero-weight cell is never returned, even for u at its CDF.
  EXPECT_NE(d.sample(0.125f).cell, 1u);
  EXPECT_LT(d.sample(std::nextafter(1.0f, 0.0f)).x, 1.0f);
  EXPECT_TRUE(PiecewiseConstant1D(std::vector<float>{0.0f, 0.0f}).zero());
}

TEST(PiecewiseConstant, TwoDimensionalDensityIsCellsShareTimesCount) {
  // 2 x 2 cells, weights 1 2 / 3 4 (sum 10): the density of cell (x, y) is 4 w / 10.
  const std::vector<float> w{1.0f, 2.0f, 3.0f, 4.0f};
  const PiecewiseConstant2D d(w, 2, 2);
  EXPECT_FLOAT_EQ(d.pdf(0, 0), 0.4f);
  EXPECT_FLOAT_EQ(d.pdf(1, 0), 0.8f);
  EXPECT_FLOAT_EQ(d.pdf(0, 1), 1.2f);
  EXPECT_FLOAT_EQ(d.pdf(1, 1), 1.6f);
}

TEST(EnvironmentAxes, CentreFacesPlusZUpIsMinusYAndUGrowsTowardsPlusX) {
  const EnvironmentLight env(map_of(8, 4, [](int, int) { return glm::vec3(1.0f); }));
  expect_near(env.direction_of({0.5f, 0.5f}), {0.0f, 0.0f, 1.0f});
  expect_near(env.direction_of({0.75f, 0.5f}), {1.0f, 0.0f, 0.0f});
  expect_near(env.direction_of({0.25f, 0.5f}), {-1.0f, 0.0f, 0.0f});
  expect_near(env.direction_of({0.0f, 0.5f}), {0.0f, 0.0f, -1.0f});
  expect_near(env.direction_of({0.3f, 0.0f}), {0.0f, -1.0f, 0.0f});  // row 0: up
  expect_near(env.direction_of({0.3f, 1.0f}), {0.0f, 1.0f, 0.0f});
  // 45 degrees above the horizon, facing +z.
  const float s = std::sqrt(0.5f);
  expect_near(env.direction_of({0.5f, 0.25f}), {0.0f, -s, s});
}

TEST(EnvironmentAxes, RotateCarriesTheCentreFromPlusZTowardsPlusX) {
  EnvironmentMap m = map_of(8, 4, [](int, int) { return glm::vec3(1.0f); });
  m.rotate_degrees = 90.0f;
  const EnvironmentLight env(m);
  expect_near(env.direction_of({0.5f, 0.5f}), {1.0f, 0.0f, 0.0f});
  expect_near(env.direction_of({0.75f, 0.5f}), {0.0f, 0.0f, -1.0f});
  m.rotate_degrees = 30.0f;
  const EnvironmentLight env30(m);
  Pcg32 rng(5, 1);
  for (int i = 0; i < 1000; ++i) {
    const glm::vec2 uv(rng.next_float(), 0.01f + 0.98f * rng.next_float());
    const glm::vec2 back = env30.uv_of(env30.direction_of(uv));
    EXPECT_NEAR(back.x, uv.x, 1e-4f);
    EXPECT_NEAR(back.y, uv.y, 1e-4f);
  }
}

TEST(EnvironmentLookup, ReadsTheTexelTimesScale) {
  EnvironmentMap m = map_of(4, 2, [](int x, int y) { return glm::vec3(float(x), float(y), 1.0f); });
  m.scale = 2.0f;
  const EnvironmentLight env(m);
  // +x is u = 0.75: column 3; slightly above the horizon: row 0.
  expect_near(env.radiance(glm::normalize(glm::vec3(1.0f, -0.1f, 0.0f))), {6.0f, 0.0f, 2.0f});
  // -z is u = 0: column 0; below the horizon: row 1.
  expect_near(env.radiance(glm::normalize(glm::vec3(0.0f, 0.1f, -1.0f))), {0.0f, 2.0f, 2.0f});
}

// The mean luminance over the sphere, against the exact solid-angle averages: a constant map is
// its own luminance, and a map bright on the upper hemisphere only (rows 0 to H/2 - 1) half of it.
// The texels' solid angle is taken at their centres (the midpoint rule in theta), exact to
// (pi / H)^2 / 24 relative: 1e-4 at 64 rows.
TEST(EnvironmentLookup, MeanLuminanceIsTheAverageOverTheSphere) {
  const glm::vec3 c(0.5f, 1.0f, 2.0f);
  const double l = 0.2126 * 0.5 + 0.7152 * 1.0 + 0.0722 * 2.0;
  const EnvironmentLight constant(map_of(8, 64, [&](int, int) { return c; }));
  EXPECT_NEAR(constant.mean_luminance(), l, 2e-4 * l);
  const EnvironmentLight upper(
      map_of(8, 64, [&](int, int y) { return y < 32 ? c : glm::vec3(0.0f); }));
  EXPECT_NEAR(upper.mean_luminance(), 0.5 * l, 2e-4 * l);
}

// A map whose luminance varies over rows and columns, with a black texel, a bright spot and a
// rotation: the pdf's sin(theta) Jacobian, its rotation and the distribution all show.
EnvironmentMap test_map() {
  EnvironmentMap m = map_of(16, 8, [](int x, int y) {
    if (x == 3 && y == 2) return glm::vec3(0.0f);
    if (x == 11 && y == 5) return glm::vec3(40.0f, 20.0f, 5.0f);
    return glm::vec3(0.2f + 0.1f * x, 0.5f + 0.3f * y, 1.0f);
  });
  m.rotate_degrees = 30.0f;
  return m;
}

// The pdf in solid angle over the sphere, by a midpoint rule in (theta, phi) of world directions
// (theta from the up axis -y, phi from +x about it: a grid that knows nothing of the map's texels
// or its rotation), d(omega) = sin(theta) dtheta dphi: 1. The density grows as 1 / sin(theta)
// towards the poles (a texel there covers little solid angle), so a grid in cos(theta) would
// converge slowly; in theta the integrand is bounded. The bright texel's edges cross grid cells,
// whose error shrinks with the grid (1.0022 at 300 x 600; 1.00000 at 600 x 1200 and 1200 x 2400).
TEST(EnvironmentSampling, PdfIntegratesToOneOverTheSphere) {
  const EnvironmentLight env(test_map());
  constexpr int kN = 1200;
  double sum = 0.0;
  for (int i = 0; i < kN; ++i) {
    const double theta = (i + 0.5) * kPiD / kN;
    for (int j = 0; j < 2 * kN; ++j) {
      const double phi = (j + 0.5) * kPiD / kN;
      const glm::vec3 d(float(std::sin(theta) * std::cos(phi)), float(-std::cos(theta)),
                        float(std::sin(theta) * std::sin(phi)));
      sum += env.pdf(d) * std::sin(theta);
    }
  }
  sum *= (kPiD / kN) * (kPiD / kN);
  EXPECT_NEAR(sum, 1.0, 1e-3);
}

// Chi-square of sampled directions against the pdf: cells are the map's texels (a direction's
// cell from uv_of), each cell's expected count the pdf integrated over its solid angle (Simpson in
// (u, v), times d(omega) = 2 pi^2 sin(theta) du dv), so the solid-angle density, not the
// distribution's own table, is what is checked.
TEST(EnvironmentSampling, SamplingFitsThePdf) {
  const EnvironmentMap m = test_map();
  const EnvironmentLight env(m);
  constexpr int kSamples = 400000;
  const int cells = m.width * m.height;
  std::vector<double> observed(static_cast<size_t>(cells) + 1, 0.0),
      expected(static_cast<size_t>(cells) + 1, 0.0);
  Pcg32 rng(2024, 3);
  for (int i = 0; i < kSamples; ++i) {
    const EnvironmentLight::Sample s = env.sample({rng.next_float(), rng.next_float()});
    if (!(s.pdf > 0.0f)) {
      observed[static_cast<size_t>(cells)] += 1.0;
      continue;
    }
    EXPECT_NEAR(s.pdf, env.pdf(s.wi), 1e-3f * s.pdf);
    const glm::vec2 uv = env.uv_of(s.wi);
    const int x = std::min(m.width - 1, static_cast<int>(uv.x * m.width));
    const int y = std::min(m.height - 1, static_cast<int>(uv.y * m.height));
    observed[static_cast<size_t>(y * m.width + x)] += 1.0;
  }
  double total = 0.0;
  for (int y = 0; y < m.height; ++y) {
    for (int x = 0; x < m.width; ++x) {
      constexpr double kIn = 1e-5;  // off the texel's edges, where the pdf jumps
      const double u0 = double(x) / m.width + kIn, u1 = double(x + 1) / m.width - kIn;
      const double v0 = double(y) / m.height + kIn, v1 = double(y + 1) / m.height - kIn;
      const double p = simpson_2d(
                           [&](double u, double v) {
                             const glm::vec3 d = env.direction_of({float(u), float(v)});
                             return env.pdf(d) * 2.0 * kPiD * kPiD * std::sin(kPiD * v);
                           },
                           u0, u1, v0, v1, 8) *
                       (1.0 / m.width) * (1.0 / m.height) / ((u1 - u0) * (v1 - v0));
      expected[static_cast<size_t>(y * m.width + x)] = p * kSamples;
      total += p;
    }
  }
  expected[static_cast<size_t>(cells)] = std::max(0.0, 1.0 - total) * kSamples;
  EXPECT_EQ(observed[static_cast<size_t>(2 * m.width + 3)], 0.0) << "the black texel";
  EXPECT_TRUE(chi_square_fits(observed, expected));
}

TEST(EnvironmentSampling, OneBrightTexelTakesEverySample) {
  const EnvironmentMap m = map_of(8, 4, [](int x, int y) {
    return x == 5 && y == 1 ? glm::vec3(3.0f, 2.0f, 1.0f) : glm::vec3(0.0f);
  });
  const EnvironmentLight env(m);
  Pcg32 rng(9, 2);
  for (int i = 0; i < 10000; ++i) {
    const EnvironmentLight::Sample s = env.sample({rng.next_float(), rng.next_float()});
    ASSERT_GT(s.pdf, 0.0f);
    const glm::vec2 uv = env.uv_of(s.wi);
    // Texel (5, 1) covers u in [5/8, 6/8), v in [1/4, 2/4); float round trips may land 1e-5 off.
    EXPECT_GT(uv.x, 5.0f / 8.0f - 1e-5f);
    EXPECT_LT(uv.x, 6.0f / 8.0f + 1e-5f);
    EXPECT_GT(uv.y, 1.0f / 4.0f - 1e-5f);
    EXPECT_LT(uv.y, 2.0f / 4.0f + 1e-5f);
    EXPECT_EQ(s.radiance, glm::vec3(3.0f, 2.0f, 1.0f));
  }
  // Every other direction has density 0.
  EXPECT_EQ(env.pdf(env.direction_of({0.1f, 0.1f})), 0.0f);
}

TEST(EnvironmentSampling, BlackMapIsNeverSampled) {
  const EnvironmentLight env(map_of(4, 2, [](int, int) { return glm::vec3(0.0f); }));
  EXPECT_TRUE(env.black());
  EXPECT_EQ(env.sample({0.5f, 0.5f}).pdf, 0.0f);
}

// A temporary directory removed at the end of the test.
class EnvironmentFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string tmpl = (fs::temp_directory_path() / "tritrace-env-XXXXXX").string();
    ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string path(const std::string& name) const { return (fs::path(dir_) / name).string(); }
  // The reason of the Error parsing a scene with this "environment" value throws.
  std::string error_of(const std::string& environment) const {
    try {
      parse_scene_json(scene_text(environment), path("scene.json"));
    } catch (const Error& e) {
      EXPECT_EQ(e.subject(), path("scene.json"));
      EXPECT_EQ(e.reason().find('\n'), std::string::npos);
      return e.reason();
    }
    ADD_FAILURE() << "no error for " << environment;
    return "";
  }
  static std::string scene_text(const std::string& environment) {
    return R"({"environment": )" + environment +
           R"(, "meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]]}]})";
  }
  std::string dir_;
};

Image gradient(int w, int h) {
  Image image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) image.at(x, y) = glm::vec3(0.5f * x, 0.25f * y + 0.125f, 3.0f);
  }
  return image;
}

TEST_F(EnvironmentFiles, HdrAndExrReadBack) {
  const Image image = gradient(5, 3);
  write_radiance_hdr(image, path("a.hdr"));
  write_exr(image, path("a.EXR"));
  const Image hdr = read_image_float(path("a.hdr"));
  const Image exr = read_image_float(path("a.EXR"));
  ASSERT_EQ(hdr.width(), 5);
  ASSERT_EQ(hdr.height(), 3);
  ASSERT_EQ(exr.width(), 5);
  ASSERT_EQ(exr.height(), 3);
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 5; ++x) {
      // RGBE keeps 8 bits of mantissa relative to the largest channel (3 here): 3 / 256.
      expect_near(hdr.at(x, y), image.at(x, y), 3.0f / 256.0f);
      EXPECT_EQ(exr.at(x, y), image.at(x, y));
    }
  }
}

TEST_F(EnvironmentFiles, SceneReadsFileScaleAndRotate) {
  write_exr(gradient(4, 2), path("sky.exr"));
  const LoadedScene s = parse_scene_json(
      scene_text(R"({"file": "sky.exr", "scale": 2.5, "rotate": -45})"), path("scene.json"));
  ASSERT_TRUE(s.scene.environment_map);
  const EnvironmentMap& m = *s.scene.environment_map;
  EXPECT_EQ(m.width, 4);
  EXPECT_EQ(m.height, 2);
  EXPECT_EQ(m.scale, 2.5f);
  EXPECT_EQ(m.rotate_degrees, -45.0f);
  EXPECT_EQ(m.texels[5], glm::vec3(0.5f, 0.375f, 3.0f));  // (1, 1)
  EXPECT_EQ(s.scene.environment, glm::vec3(0.0f));
}

TEST_F(EnvironmentFiles, EachMistakeHasItsMessage) {
  write_radiance_hdr(gradient(4, 2), path("sky.hdr"));
  fs::copy_file(path("sky.hdr"), path("sky.png"));
  { std::ofstream(path("broken.hdr")) << "not an image"; }
  EXPECT_EQ(error_of(R"({"file": "none.hdr"})"),
            "/environment/file: 'none.hdr': cannot read image: no such file");
  EXPECT_EQ(error_of(R"({"file": "sky.png"})"),
            "/environment/file: 'sky.png': unknown image extension '.png' (use .hdr or .exr)");
  EXPECT_EQ(error_of(R"({"file": "broken.hdr"})")
                .rfind("/environment/file: 'broken.hdr': cannot "
                       "read image: ",
                       0),
            0u);
  EXPECT_EQ(error_of(R"({"file": "sky.hdr", "scale": -1})"),
            "/environment/scale: must not be negative, got -1");
  EXPECT_EQ(error_of(R"({"file": "sky.hdr", "color": [1, 1, 1]})"),
            "/environment: has both \"color\" and \"file\"; give one");
  EXPECT_EQ(error_of(R"({"color": [1, 1, 1], "rotate": 10})"),
            "/environment/rotate: applies to a \"file\" only");
  EXPECT_EQ(error_of(R"({"scale": 2})"), "/environment: missing \"color\" or \"file\"");
  EXPECT_EQ(error_of(R"({"file": "sky.hdr", "rotate": "left"})"),
            "/environment/rotate: must be a number, got 'left'");
  EXPECT_EQ(error_of(R"({"file": 3})"), "/environment/file: must be a string, got 3");
}

}  // namespace
}  // namespace tritrace
