// Textures against closed forms: the sRGB curve, bilinear filtering computed here from the texels,
// and the repeat, clamp and mirror wrap modes.
#include "tritrace/image/texture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "tritrace/error.h"

namespace tritrace {
namespace {

double srgb_closed_form(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

TEST(Texture, SrgbBytesDecodeByTheIecCurve) {
  TextureImage image{256, 1, {}, {}, true};
  for (int b = 0; b < 256; ++b) image.rgb.insert(image.rgb.end(), 3, static_cast<uint8_t>(b));
  const Texture t = Texture::from_srgb8(image);
  for (int b = 0; b < 256; ++b) {
    const double want = srgb_closed_form(b / 255.0);
    EXPECT_NEAR(t.texel(b, 0).x, want, 1e-6 + 1e-6 * want) << b;
    EXPECT_EQ(t.texel(b, 0).x, t.texel(b, 0).z);
  }
  EXPECT_EQ(t.texel(0, 0).x, 0.0f);
  EXPECT_EQ(t.texel(255, 0).x, 1.0f);
}

// A 3 x 2 texture of distinct texels, each channel a different function of (x, y).
Texture small() {
  std::vector<glm::vec3> texels;
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 3; ++x) {
      texels.emplace_back(0.1f + 0.2f * x + 0.05f * y, 0.9f - 0.3f * y, 0.01f * (x + 1) * (y + 2));
    }
  }
  return Texture(3, 2, texels);
}

// Bilinear interpolation written from its definition: the four texels around the point, with
// weights from its distances to their centres (x, y in texel units, centres at integers, the
// texels at the clamped indices).
glm::vec3 bilinear(const Texture& t, double x, double y) {
  auto at = [&](int i, int j) {
    i = std::clamp(i, 0, t.width() - 1);
    j = std::clamp(j, 0, t.height() - 1);
    return glm::dvec3(t.texel(i, j));
  };
  const int i = static_cast<int>(std::floor(x)), j = static_cast<int>(std::floor(y));
  const double a = x - i, b = y - j;
  const glm::dvec3 v = (1 - a) * (1 - b) * at(i, j) + a * (1 - b) * at(i + 1, j) +
                       (1 - a) * b * at(i, j + 1) + a * b * at(i + 1, j + 1);
  return glm::vec3(v);
}

void expect_near(glm::vec3 got, glm::vec3 want, const std::string& what) {
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 2e-6f) << what << " channel " << c;
}

TEST(Texture, TexelCentresGiveTheTexels) {
  const Texture t = small();
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 3; ++x) {
      // Texel (x, y) sits at u = (x + 0.5) / width, v = 1 - (y + 0.5) / height (v up, rows down).
      const glm::vec2 uv((x + 0.5f) / 3.0f, 1.0f - (y + 0.5f) / 2.0f);
      for (WrapMode m : {WrapMode::kRepeat, WrapMode::kClamp, WrapMode::kMirror}) {
        expect_near(t.lookup(uv, m, m), t.texel(x, y), "texel " + std::to_string(x));
      }
    }
  }
}

TEST(Texture, BilinearBetweenTexelCentres) {
  const Texture t = small();
  for (float u : {0.2f, 0.31f, 0.5f, 0.62f, 0.79f}) {
    for (float v : {0.26f, 0.4f, 0.5f, 0.73f}) {
      const double x = u * 3.0 - 0.5, y = (1.0 - v) * 2.0 - 0.5;
      expect_near(t.lookup({u, v}, WrapMode::kClamp, WrapMode::kClamp), bilinear(t, x, y),
                  "uv " + std::to_string(u) + " " + std::to_string(v));
    }
  }
}

TEST(Texture, WrapModes) {
  const Texture t = small();
  for (float u : {0.05f, 0.3f, 0.55f, 0.9f}) {
    for (float v : {0.1f, 0.45f, 0.8f}) {
      const glm::vec3 here = t.lookup({u, v}, WrapMode::kRepeat, WrapMode::kRepeat);
      // Repeat: a whole period away is the same place.
      expect_near(t.lookup({u + 1.0f, v}, WrapMode::kRepeat, WrapMode::kRepeat), here, "repeat u");
      expect_near(t.lookup({u - 2.0f, v + 3.0f}, WrapMode::kRepeat, WrapMode::kRepeat), here,
                  "repeat uv");
      // Mirror: reflected about 0 and about 1.
      const glm::vec3 m = t.lookup({u, v}, WrapMode::kMirror, WrapMode::kMirror);
      expect_near(t.lookup({-u, v}, WrapMode::kMirror, WrapMode::kMirror), m, "mirror at 0");
      expect_near(t.lookup({2.0f - u, 2.0f - v}, WrapMode::kMirror, WrapMode::kMirror), m,
                  "mirror at 1");
    }
  }
  // Clamp: beyond the edges, the edge texels (here the right column, bottom row: u > 1, v < 0).
  expect_near(t.lookup({1.7f, -0.4f}, WrapMode::kClamp, WrapMode::kClamp), t.texel(2, 1), "clamp");
  expect_near(t.lookup({-3.0f, 5.0f}, WrapMode::kClamp, WrapMode::kClamp), t.texel(0, 0), "clamp");
  // Repeat across the seam between the last and the first column: their mean half way.
  const glm::vec3 seam = t.lookup({1.0f, 1.0f - 0.25f}, WrapMode::kRepeat, WrapMode::kClamp);
  expect_near(seam, 0.5f * (t.texel(2, 0) + t.texel(0, 0)), "repeat seam");
  const glm::vec3 edge = t.lookup({1.0f, 1.0f - 0.25f}, WrapMode::kClamp, WrapMode::kClamp);
  expect_near(edge, t.texel(2, 0), "clamp seam");
  // Coordinates that are not finite still give a texel, not a crash.
  const float inf = std::numeric_limits<float>::infinity();
  for (WrapMode mode : {WrapMode::kRepeat, WrapMode::kClamp, WrapMode::kMirror}) {
    const glm::vec3 c = t.lookup({inf, std::nanf("")}, mode, mode);
    EXPECT_TRUE(std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z));
  }
}

TEST(Texture, MappedTexturesAreTheAffineMapOfTheLookup) {
  // Bilinear weights sum to 1, so mapping the texels maps every lookup: here the texels 0.2 and
  // 0.6 blend to 0.4 halfway, and 0.5 * 0.4 + 0.1 = 0.3.
  const Texture t(2, 1, {glm::vec3(0.2f), glm::vec3(0.6f)});
  const Texture m = t.mapped(glm::vec3(0.5f), glm::vec3(0.1f, 0.0f, 1.0f));
  expect_near(m.lookup({0.5f, 0.5f}, WrapMode::kClamp, WrapMode::kClamp),
              glm::vec3(0.3f, 0.2f, 1.2f), "mapped");
  const Texture u = small();
  const Texture um = u.mapped(glm::vec3(2.0f, 1.0f, 0.5f), glm::vec3(0.25f));
  for (float x : {0.1f, 0.45f, 0.8f}) {
    const glm::vec3 v = u.lookup({x, 0.3f}, WrapMode::kRepeat, WrapMode::kRepeat);
    expect_near(um.lookup({x, 0.3f}, WrapMode::kRepeat, WrapMode::kRepeat),
                glm::vec3(2.0f, 1.0f, 0.5f) * v + 0.25f, "mapped small");
  }
}

TEST(Texture, CheckerboardIsEvenWhereTheFloorsSumToAnEvenNumber) {
  // s = 3 u - 0.25, t = 0.5 v + 2: even (tex1) where floor(s) + floor(t) is even.
  Checkerboard board;
  board.scale = {3.0f, 0.5f};
  board.delta = {-0.25f, 2.0f};
  board.even = {1.0f, 0.5f, 0.0f};
  board.odd = {0.0f, 0.25f, 1.0f};
  const Texture t = Texture::checkerboard(board);
  const auto at = [&](float u, float v) {
    return t.lookup({u, v}, WrapMode::kClamp, WrapMode::kClamp);
  };
  EXPECT_EQ(at(0.1f, 0.1f), board.even);   // s 0.05, t 2.05: 0 + 2 = 2
  EXPECT_EQ(at(0.05f, 0.1f), board.odd);   // s -0.1: -1 + 2 = 1
  EXPECT_EQ(at(0.5f, 0.1f), board.odd);    // s 1.25: 1 + 2 = 3
  EXPECT_EQ(at(0.5f, 2.5f), board.even);   // t 3.25: 1 + 3 = 4
  EXPECT_EQ(at(-0.5f, 0.1f), board.even);  // s -1.75: -2 + 2 = 0
  EXPECT_EQ(t.checker()->even, board.even);
  EXPECT_EQ(t.texel(0, 0), glm::vec3(0.5f, 0.375f, 0.5f));  // the mean of the two colours
  const Texture m = t.mapped(glm::vec3(0.5f), glm::vec3(0.5f));
  EXPECT_EQ(m.lookup({0.5f, 2.5f}, WrapMode::kRepeat, WrapMode::kRepeat),
            glm::vec3(1.0f, 0.75f, 0.5f));
  EXPECT_EQ(m.lookup({0.5f, 0.1f}, WrapMode::kRepeat, WrapMode::kRepeat),
            glm::vec3(0.5f, 0.625f, 1.0f));
}

TEST(Texture, DecodesPnmBytesAndRejectsGarbage) {
  const std::string ppm =
      std::string("P6\n2 1\n255\n") + std::string("\x10\x20\x30\xff\x00\x80", 6);
  const TextureImage image = decode_texture_image(
      std::span(reinterpret_cast<const uint8_t*>(ppm.data()), ppm.size()), "two.ppm");
  EXPECT_EQ(image.width, 2);
  EXPECT_EQ(image.height, 1);
  EXPECT_EQ(image.rgb, (std::vector<uint8_t>{0x10, 0x20, 0x30, 0xff, 0x00, 0x80}));
  const std::string garbage = "not an image at all";
  try {
    (void)decode_texture_image(
        std::span(reinterpret_cast<const uint8_t*>(garbage.data()), garbage.size()), "bad.png");
    FAIL() << "garbage decoded";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "bad.png");
    EXPECT_EQ(e.reason().rfind("cannot read texture: ", 0), 0u) << e.reason();
  }
}

}  // namespace
}  // namespace tritrace
