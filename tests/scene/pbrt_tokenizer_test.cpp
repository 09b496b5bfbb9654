// The pbrt-v4 tokenizer and parameter lists: tokens and their places, typed values, named and
// blackbody spectra, and one-line errors that name FILE:LINE:COL.
#include "tritrace/scene/io/pbrt_tokenizer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/scene/io/pbrt_params.h"

namespace tritrace {
namespace {

std::vector<PbrtToken> all_tokens(const std::string& text) {
  PbrtTokenizer t(text, "t.pbrt");
  std::vector<PbrtToken> out;
  while (auto token = t.next()) out.push_back(*token);
  return out;
}

// The message main() would print after "tritrace: " for what `f` throws.
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.subject() + ": " + e.reason();
  }
  return "(no error)";
}

TEST(PbrtTokenizer, TokensCarryTheirLineAndColumn) {
  const auto t =
      all_tokens("Shape \"sphere\" # a comment \"not a string\"\n  \"float radius\" [2.5]");
  ASSERT_EQ(t.size(), 6u);
  EXPECT_EQ(t[0].kind, PbrtToken::Kind::kWord);
  EXPECT_EQ(t[0].text, "Shape");
  EXPECT_EQ(t[1].kind, PbrtToken::Kind::kString);
  EXPECT_EQ(t[1].text, "sphere");
  EXPECT_EQ(t[1].at.describe(), "t.pbrt:1:7");
  EXPECT_EQ(t[2].text, "float radius");
  EXPECT_EQ(t[2].at.describe(), "t.pbrt:2:3");
  EXPECT_EQ(t[3].kind, PbrtToken::Kind::kOpen);
  EXPECT_EQ(t[3].at.describe(), "t.pbrt:2:18");
  EXPECT_EQ(t[4].text, "2.5");
  EXPECT_EQ(t[4].at.describe(), "t.pbrt:2:19");
  EXPECT_EQ(t[5].kind, PbrtToken::Kind::kClose);
}

TEST(PbrtTokenizer, BracketsSplitFromTheirNeighbours) {
  const auto t = all_tokens("[1 2][\"a\"]");
  ASSERT_EQ(t.size(), 7u);
  EXPECT_EQ(t[0].kind, PbrtToken::Kind::kOpen);
  EXPECT_EQ(t[2].text, "2");
  EXPECT_EQ(t[3].kind, PbrtToken::Kind::kClose);
  EXPECT_EQ(t[4].kind, PbrtToken::Kind::kOpen);
  EXPECT_EQ(t[5].text, "a");
}

TEST(PbrtTokenizer, StringEscapesAreResolved) {
  const auto t = all_tokens(R"("a\"b\\c\td")");
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t[0].text, "a\"b\\c\td");
}

TEST(PbrtTokenizer, UnterminatedStringNamesWhereItStarts) {
  EXPECT_EQ(error_of([] { all_tokens("Shape\n  \"sphere"); }),
            "t.pbrt:2:3: unterminated string (a string ends with '\"' on the line it starts)");
  EXPECT_EQ(error_of([] { all_tokens("\"a\\q\""); }),
            "t.pbrt:1:3: unknown escape '\\q' in a string");
}

PbrtParams params_of(const std::string& text) {
  PbrtTokenizer t(text, "p.pbrt");
  return parse_pbrt_params(t);
}

TEST(PbrtParams, TypedValuesAreLookedUpByName) {
  const PbrtParams p = params_of(
      "\"float fov\" [45] \"rgb reflectance\" [.5 .25 1e-1] \"string filename\" \"x.png\" "
      "\"bool twosided\" true \"integer indices\" [0 1 2] \"point3 from\" [1 2 3]");
  EXPECT_EQ(p.get_float("fov", 0.0), 45.0);
  EXPECT_EQ(p.get_float("missing", 7.0), 7.0);
  EXPECT_EQ(*p.get_rgb("reflectance"), glm::vec3(0.5f, 0.25f, 0.1f));
  EXPECT_EQ(p.get_string("filename", ""), "x.png");
  EXPECT_TRUE(p.get_bool("twosided", false));
  EXPECT_EQ(p.get_ints("indices"), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(*p.get_point("from"), glm::dvec3(1, 2, 3));
  EXPECT_TRUE(p.unused().empty());
}

TEST(PbrtParams, OlderTypeSpellingsAndQuotedBoolsAreAccepted) {
  const PbrtParams p = params_of("\"color Kd\" [1 0 0] \"point P\" [0 0 0] \"bool b\" \"false\"");
  EXPECT_EQ(*p.get_rgb("Kd"), glm::vec3(1, 0, 0));
  EXPECT_TRUE(p.get_point("P").has_value());
  EXPECT_FALSE(p.get_bool("b", true));
}

TEST(PbrtParams, MalformedListsAreOneLineErrors) {
  EXPECT_EQ(error_of([] { params_of("\"float fov\" [4x5]"); }),
            "p.pbrt:1:14: \"float fov\": expected a number, got '4x5'");
  EXPECT_EQ(error_of([] { params_of("\"float fov\" [45"); }),
            "p.pbrt:1:13: unterminated '[' (no matching ']' before the end of the file)");
  EXPECT_EQ(error_of([] { params_of("\"fov\" 45"); }),
            "p.pbrt:1:1: expected a parameter declaration \"type name\", got \"fov\"");
  EXPECT_EQ(error_of([] { params_of("\"quaternion q\" 45"); }),
            "p.pbrt:1:1: unknown parameter type \"quaternion\" in \"quaternion q\"");
  EXPECT_EQ(error_of([] { params_of("\"float fov\""); }),
            "p.pbrt:1:12: unexpected end of file: \"float fov\" needs a value");
  EXPECT_EQ(error_of([] { params_of("\"bool b\" 1"); }),
            "p.pbrt:1:10: \"bool b\": expected true or false, got '1'");
  EXPECT_EQ(error_of([] { params_of("\"float fov\" [1 2]").get_float("fov", 0); }),
            "p.pbrt:1:1: \"float fov\" takes one value");
  EXPECT_EQ(error_of([] { params_of("\"integer n\" [1 2.5]"); }),
            "p.pbrt:1:16: \"integer n\": expected an integer, got '2.5'");
  EXPECT_EQ(error_of([] { params_of("\"integer n\" 1e12"); }),
            "p.pbrt:1:13: \"integer n\": expected an integer, got '1e12'");
  EXPECT_EQ(error_of([] { params_of("\"float x\" 1e39"); }),
            "p.pbrt:1:11: \"float x\": '1e39' is beyond float range");
  EXPECT_EQ(error_of([] { params_of("\"float x\" [nan]"); }),
            "p.pbrt:1:12: \"float x\": expected a number, got 'nan'");
}

TEST(PbrtParams, NamedSpectraBecomeRgb) {
  const PbrtParams p = params_of(
      "\"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\" \"spectrum g\" "
      "\"glass-BK7\" \"spectrum flat\" [300 .5 800 .5]");
  // Gold reflects red more than green and green more than blue: F0 from n and k.
  const glm::vec3 n = *p.get_rgb("eta"), k = *p.get_rgb("k");
  glm::vec3 f0;
  for (int c = 0; c < 3; ++c) {
    f0[c] = ((n[c] - 1) * (n[c] - 1) + k[c] * k[c]) / ((n[c] + 1) * (n[c] + 1) + k[c] * k[c]);
  }
  EXPECT_GT(f0.r, f0.g);
  EXPECT_GT(f0.g, f0.b);
  EXPECT_GT(f0.r, 0.9f);
  // Schott's catalogue: N-BK7 has n_d = 1.5168.
  EXPECT_FLOAT_EQ(p.get_rgb("g")->y, 1.5168f);
  EXPECT_EQ(*p.get_rgb("flat"), glm::vec3(0.5f));
  EXPECT_EQ(
      error_of([] { params_of("\"spectrum s\" \"metal-Xx-eta\"").get_rgb("s"); }),
      "p.pbrt:1:1: \"spectrum s\": unknown named spectrum \"metal-Xx-eta\" (spectrum files are "
      "not read; give an rgb)");
}

TEST(PbrtParams, BlackbodyIsNormalisedToLuminanceOne) {
  // D65, the sRGB white point, is close to a 6504 K blackbody: nearly equal channels.
  const glm::vec3 d65 = blackbody_rgb(6504.0);
  const double y = 0.2126 * d65.r + 0.7152 * d65.g + 0.0722 * d65.b;  // sRGB luminance
  EXPECT_NEAR(y, 1.0, 0.02);
  EXPECT_NEAR(d65.r, 1.0, 0.06);
  EXPECT_NEAR(d65.g, 1.0, 0.06);
  EXPECT_NEAR(d65.b, 1.0, 0.06);
  // A 2700 K lamp is orange: red over green over blue.
  const glm::vec3 warm = blackbody_rgb(2700.0);
  EXPECT_GT(warm.r, warm.g);
  EXPECT_GT(warm.g, warm.b);
}

}  // namespace
}  // namespace tritrace
