// The lab's byte conversion and the sRGB curve at hand-computed points, the PNG/PPM/PFM/EXR
// encoders read back independently (EXR through OpenEXR's reader), and atomic writes that leave no
// temporary file behind.
#include "tritrace/image/image_io.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <string>

#include "exr_read_back.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;

class TempDir : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string tmpl = (fs::temp_directory_path() / "tritrace-image-XXXXXX").string();
    ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  size_t entries() const {
    return static_cast<size_t>(
        std::distance(fs::directory_iterator(dir_), fs::directory_iterator{}));
  }
  static std::string slurp(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  fs::path dir_;
};

// A 3 x 2 image whose values cover the conversion's corner cases.
Image sample_image() {
  Image img(3, 2);
  img.at(0, 0) = {0.0f, 0.5f, 1.0f};
  img.at(1, 0) = {2.0f, -1.0f, 0.25f};
  img.at(2, 0) = {0.999f, 0.001f, 0.75f};
  img.at(0, 1) = {0.1f, 0.2f, 0.3f};
  img.at(1, 1) = {0.4f, 0.6f, 0.8f};
  img.at(2, 1) = {1.0f, 1.0f, 0.0f};
  return img;
}

TEST(LabBytes, TruncateAfterClampingTimes255) {
  EXPECT_EQ(to_byte_lab(0.5f), 127);  // 127.5 truncates
  EXPECT_EQ(to_byte_lab(1.0f), 255);
  EXPECT_EQ(to_byte_lab(3.0f), 255);
  EXPECT_EQ(to_byte_lab(0.0f), 0);
  EXPECT_EQ(to_byte_lab(-0.5f), 0);
  EXPECT_EQ(to_byte_lab(0.999f), 254);  // 254.745
  EXPECT_EQ(to_byte_lab(0.075f), 19);   // 19.125, the shadowed green floor's red channel
  EXPECT_EQ(to_byte_lab(std::numeric_limits<float>::quiet_NaN()), 0);
  EXPECT_EQ(to_byte_lab(std::numeric_limits<float>::infinity()), 255);
}

// Expected bytes from IEC 61966-2-1: 255 * (12.92 c) for c <= 0.0031308, else
// 255 * (1.055 c^(1/2.4) - 0.055), rounded to nearest; computed by hand (in double precision).
TEST(SrgbBytes, FollowTheIec61966CurveAtHandComputedPoints) {
  EXPECT_EQ(to_byte_srgb(0.0f), 0);
  EXPECT_EQ(to_byte_srgb(1.0f), 255);   // 254.99999999999997 (1.055 - 0.055 in double)
  EXPECT_EQ(to_byte_srgb(0.5f), 188);   // 1.055 * 0.749154 - 0.055 = 0.735357 -> 187.516
  EXPECT_EQ(to_byte_srgb(0.18f), 118);  // 1.055 * 0.489456 - 0.055 = 0.461376 -> 117.646
  EXPECT_EQ(to_byte_srgb(0.25f), 137);  // 136.960
  EXPECT_EQ(to_byte_srgb(0.8f), 231);   // 231.115
  EXPECT_EQ(to_byte_srgb(0.05f), 63);   // 63.189
  EXPECT_EQ(to_byte_srgb(0.01f), 25);   // 25.462 (the linear segment would give 32.9 -> 33)
  EXPECT_EQ(to_byte_srgb(0.001f), 3);   // 12.92 * 0.001 * 255 = 3.295 (the power: 1.1 -> 1)
  // Both segments meet at the boundary: 12.92 * 0.0031308 * 255 = 10.315.
  EXPECT_EQ(to_byte_srgb(0.0031308f), 10);
  EXPECT_EQ(to_byte_srgb(std::nextafter(0.0031308f, 1.0f)), 10);
  EXPECT_EQ(to_byte_srgb(-0.5f), 0);
  EXPECT_EQ(to_byte_srgb(2.0f), 255);
  EXPECT_EQ(to_byte_srgb(std::numeric_limits<float>::infinity()), 255);
  EXPECT_EQ(to_byte_srgb(std::numeric_limits<float>::quiet_NaN()), 0);
}

TEST(SrgbBytes, ExposureScalesByTwoToTheStopsBeforeTheCurve) {
  Image img(3, 1);
  img.at(0, 0) = {0.25f, 0.09f, 1.0f};
  img.at(1, 0) = {0.5f, 0.0f, 0.005f};
  img.at(2, 0) = {0.0625f, 0.0f, 0.0f};
  const std::vector<uint8_t> zero = to_rgb8_srgb(img, 0.0f);
  const std::vector<uint8_t> expected_zero = {137, 85, 255, 188, 0, 16, 71, 0, 0};
  EXPECT_EQ(zero, expected_zero);
  // 0.005 -> 15.557, 0.0625 -> 70.713. +1 doubles: 0.5 -> 188, 0.18 -> 118, 2 -> 255, 1 -> 255,
  // 0.01 -> 25, 0.125 -> 99.086.
  const std::vector<uint8_t> plus_one = to_rgb8_srgb(img, 1.0f);
  const std::vector<uint8_t> expected_plus_one = {188, 118, 255, 255, 0, 25, 99, 0, 0};
  EXPECT_EQ(plus_one, expected_plus_one);
  // +3 multiplies by 8 (0.0625 -> 0.5); -1 halves (1 -> 0.5).
  EXPECT_EQ(to_rgb8_srgb(img, 3.0f)[6], 188);
  EXPECT_EQ(to_rgb8_srgb(img, -1.0f)[2], 188);
  // Through the 8-bit writers: the PPM's bytes are the exposed sRGB bytes.
  const std::vector<uint8_t> ppm = encode_image(img, ImageFormat::kPpm, ImageEncoding::srgb(1.0f));
  const std::string header = "P6\n3 1\n255\n";
  ASSERT_EQ(ppm.size(), header.size() + 9);
  EXPECT_EQ(std::vector<uint8_t>(ppm.begin() + static_cast<long>(header.size()), ppm.end()),
            expected_plus_one);
}

TEST(FloatFormats, IgnoreTheEightBitEncoding) {
  Image img(1, 1);
  img.at(0, 0) = {0.25f, 2.0f, 0.0f};
  EXPECT_EQ(encode_image(img, ImageFormat::kPfm, ImageEncoding::srgb(3.0f)),
            encode_image(img, ImageFormat::kPfm, ImageEncoding::lab()));
  EXPECT_EQ(encode_image(img, ImageFormat::kExr, ImageEncoding::srgb(3.0f)),
            encode_image(img, ImageFormat::kExr, ImageEncoding::lab()));
  EXPECT_TRUE(is_float_format(ImageFormat::kPfm));
  EXPECT_TRUE(is_float_format(ImageFormat::kExr));
  EXPECT_FALSE(is_float_format(ImageFormat::kPng));
  EXPECT_FALSE(is_float_format(ImageFormat::kPpm));
}

TEST_F(TempDir, PngRoundTripsTheLabBytes) {
  const Image img = sample_image();
  write_image(img, path("a.png"));
  const Rgb8Image back = read_image_rgb8(path("a.png"));
  ASSERT_EQ(back.width, 3);
  ASSERT_EQ(back.height, 2);
  const uint8_t expected[18] = {0,  127, 255, 255, 0,   63,  254, 0,   191,
                                25, 51,  76,  102, 153, 204, 255, 255, 0};
  ASSERT_EQ(back.rgb.size(), 18u);
  for (size_t i = 0; i < 18; ++i) EXPECT_EQ(back.rgb[i], expected[i]) << "byte " << i;
}

TEST_F(TempDir, PpmHasHeaderThenRowsTopFirst) {
  write_image(sample_image(), path("a.PPM"));  // extension is case-insensitive
  const std::string bytes = slurp(path("a.PPM"));
  const std::string header = "P6\n3 2\n255\n";
  ASSERT_EQ(bytes.size(), header.size() + 18);
  EXPECT_EQ(bytes.substr(0, header.size()), header);
  EXPECT_EQ(static_cast<uint8_t>(bytes[header.size() + 1]), 127);  // pixel (0,0) green
  EXPECT_EQ(static_cast<uint8_t>(bytes[header.size() + 9]), 25);   // pixel (0,1) red
}

TEST_F(TempDir, PfmStoresFloatsBottomRowFirst) {
  const Image img = sample_image();
  write_image(img, path("a.pfm"));
  const std::string bytes = slurp(path("a.pfm"));
  const std::string header = "PF\n3 2\n-1.0\n";
  ASSERT_EQ(bytes.size(), header.size() + 3 * 2 * 3 * sizeof(float));
  EXPECT_EQ(bytes.substr(0, header.size()), header);
  float first[3];
  std::memcpy(first, bytes.data() + header.size(), sizeof(first));
  EXPECT_EQ(first[0], 0.1f);  // the bottom row (y = 1) comes first
  EXPECT_EQ(first[2], 0.3f);
  float unclamped;
  std::memcpy(&unclamped, bytes.data() + header.size() + 3 * 3 * sizeof(float) + 3 * sizeof(float),
              sizeof(float));
  EXPECT_EQ(unclamped, 2.0f);  // pixel (1, 0) red, not clamped
}

TEST_F(TempDir, WriteReplacesExistingFileAndLeavesNoTemporary) {
  { std::ofstream(path("a.png")) << "an old, longer file that must be replaced entirely"; }
  write_image(sample_image(), path("a.png"));
  EXPECT_EQ(read_image_rgb8(path("a.png")).width, 3);
  EXPECT_EQ(entries(), 1u);
  EXPECT_EQ(fs::status(path("a.png")).permissions() & fs::perms::owner_read, fs::perms::owner_read);
}

TEST_F(TempDir, WriteIntoMissingFolderThrowsNamingThePath) {
  const std::string p = path("missing/a.png");
  try {
    write_image(sample_image(), p);
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), p);
  }
  EXPECT_EQ(entries(), 0u);
}

TEST_F(TempDir, UnknownExtensionIsRejectedBeforeWriting) {
  EXPECT_FALSE(image_format_for("x.jpg").has_value());
  EXPECT_FALSE(image_format_for("png").has_value());
  EXPECT_EQ(image_format_for("dir.v2/x.Png"), ImageFormat::kPng);
  EXPECT_EQ(image_format_for("x.exr"), ImageFormat::kExr);
  EXPECT_EQ(image_format_for("X.EXR"), ImageFormat::kExr);
  EXPECT_FALSE(image_format_for("x.exr.tmp").has_value());
  try {
    write_image(sample_image(), path("a.jpg"));
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), path("a.jpg"));
    EXPECT_NE(e.reason().find(".png, .ppm, .pfm or .exr"), std::string::npos) << e.reason();
  }
  EXPECT_EQ(entries(), 0u);
}

// ---- OpenEXR ----------------------------------------------------------------------------------

using testing::ExrContents;
using testing::read_exr_channels;

uint32_t bits(float f) {
  return std::bit_cast<uint32_t>(f);
}

// Values a float file must keep exactly: above 1, negative, tiny, huge, signed zero, infinity, NaN.
Image float_corner_cases() {
  Image img(4, 3);
  const float values[] = {
      0.0f,   -0.0f,  0.5f,    1.0f,    2.0f,  10.0f, -1.0f, 0.1f, 1e-30f, 1e30f,  1e-42f,  3.4e38f,
      0.333f, 0.667f, 65504.f, 70000.f, 0.75f, 1.25f, 7.0f,  8.0f, 9.0f,   12.0f,  0.001f,  1e-5f,
      0.18f,  0.0f,   1.0f,    4.0f,    5.0f,  6.0f,  0.2f,  0.3f, 0.25f,  0.125f, 0.0625f, 100.0f};
  int i = 0;
  for (int y = 0; y < img.height(); ++y) {
    for (int x = 0; x < img.width(); ++x) {
      img.at(x, y) = {values[i], values[i + 1], values[i + 2]};
      i += 3;
    }
  }
  img.at(3, 2).g = std::numeric_limits<float>::infinity();
  img.at(3, 2).b = std::numeric_limits<float>::quiet_NaN();
  return img;
}

// The channel `name` of `contents` as pixel (x, y)'s value.
float channel_at(const ExrContents& contents, const std::string& name, int x, int y) {
  return contents.channels.at(name).values.at(static_cast<size_t>(y) * contents.width + x);
}

std::set<std::string> channel_names(const ExrContents& contents) {
  std::set<std::string> names;
  for (const auto& entry : contents.channels) names.insert(entry.first);
  return names;
}

TEST_F(TempDir, ExrFloatRoundTripsBitForBit) {
  const Image img = float_corner_cases();
  write_image(img, path("a.exr"));
  EXPECT_EQ(entries(), 1u);
  const ExrContents back = read_exr_channels(path("a.exr"));
  ASSERT_EQ(back.width, 4);
  ASSERT_EQ(back.height, 3);
  EXPECT_EQ(back.compression, Imf::ZIP_COMPRESSION);
  EXPECT_EQ(channel_names(back), (std::set<std::string>{"R", "G", "B"}));
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(back.channels.at(names[c]).stored, Imf::FLOAT) << names[c];
    for (int y = 0; y < img.height(); ++y) {
      for (int x = 0; x < img.width(); ++x) {
        EXPECT_EQ(bits(channel_at(back, names[c], x, y)), bits(img.at(x, y)[c]))
            << names[c] << " at " << x << "," << y;
      }
    }
  }
}

TEST_F(TempDir, ExrHalfKeepsValuesWithinHalfPrecision) {
  const Image img = float_corner_cases();
  write_exr(img, path("h.exr"), {}, ExrPixelType::kHalf);
  const ExrContents back = read_exr_channels(path("h.exr"));
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(back.channels.at(names[c]).stored, Imf::HALF) << names[c];
    for (int y = 0; y < img.height(); ++y) {
      for (int x = 0; x < img.width(); ++x) {
        const float v = img.at(x, y)[c];
        const float h = channel_at(back, names[c], x, y);
        SCOPED_TRACE(std::string(names[c]) + " = " + std::to_string(v));
        if (std::isnan(v)) {
          EXPECT_TRUE(std::isnan(h));
        } else if (std::fabs(v) > 65519.0f) {
          // Beyond half's largest value (65504) plus half a step: infinity of the same sign.
          EXPECT_TRUE(std::isinf(h) && std::signbit(h) == std::signbit(v)) << h;
        } else if (std::fabs(v) >= 6.103515625e-05f) {
          // Normal halves: 11 significant bits, rounded to nearest, so relative error <= 2^-11.
          EXPECT_LE(std::fabs(h - v), std::fabs(v) * 0x1p-11f) << h;
        } else {
          // Subnormal halves are spaced 2^-24 apart; anything smaller rounds to (signed) zero.
          EXPECT_LE(std::fabs(h - v), 0x1p-25f) << h;
        }
      }
    }
  }
  // Values halves hold exactly come back exactly.
  EXPECT_EQ(bits(channel_at(back, "G", 0, 0)), bits(-0.0f));
  EXPECT_EQ(channel_at(back, "R", 2, 1), 7.0f);
  EXPECT_EQ(channel_at(back, "B", 1, 2), 6.0f);
  EXPECT_EQ(channel_at(back, "B", 0, 1), 65504.0f);  // the largest half
  EXPECT_EQ(channel_at(back, "R", 3, 2), 0.125f);
  // A half file is smaller than a float one of the same noisy data.
  write_exr(img, path("f.exr"), {}, ExrPixelType::kFloat);
  EXPECT_LT(fs::file_size(path("h.exr")), fs::file_size(path("f.exr")));
}

// Distinct values per layer and pixel, so that a channel read from the wrong layer, component or
// pixel is caught.
Image layer_image(int width, int height, float base) {
  Image img(width, height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float p = base + static_cast<float>(y * width + x) * 0.0625f;
      img.at(x, y) = {p, p + 0.25f, -p};
    }
  }
  return img;
}

TEST_F(TempDir, ExrAovLayersHaveTheirNamesAndValues) {
  const Image radiance = layer_image(5, 3, 1.0f);
  AovImages aovs{layer_image(5, 3, 10.0f), layer_image(5, 3, 20.0f), layer_image(5, 3, 30.0f),
                 layer_image(5, 3, 40.0f), Image()};
  write_exr(radiance, path("aov.exr"), aovs);
  const ExrContents back = read_exr_channels(path("aov.exr"));
  EXPECT_EQ(channel_names(back),
            (std::set<std::string>{"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X",
                                   "normal.Y", "normal.Z", "Z", "variance.R", "variance.G",
                                   "variance.B"}));
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 5; ++x) {
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(channel_at(back, std::string(1, "RGB"[c]), x, y), radiance.at(x, y)[c]);
        EXPECT_EQ(channel_at(back, std::string("albedo.") + "RGB"[c], x, y),
                  aovs.albedo.at(x, y)[c]);
        EXPECT_EQ(channel_at(back, std::string("normal.") + "XYZ"[c], x, y),
                  aovs.normal.at(x, y)[c]);
        EXPECT_EQ(channel_at(back, std::string("variance.") + "RGB"[c], x, y),
                  aovs.variance.at(x, y)[c]);
      }
      EXPECT_EQ(channel_at(back, "Z", x, y), aovs.depth.at(x, y).r);
    }
  }
  for (const auto& [name, data] : back.channels) EXPECT_EQ(data.stored, Imf::FLOAT) << name;
}

TEST_F(TempDir, ExrHalfKeepsDepthAndVarianceInFloat) {
  const Image radiance = layer_image(2, 2, 1.0f);
  Image depth(2, 2), variance(2, 2);
  depth.at(1, 1) = glm::vec3(4097.3f);   // half would store 4096
  variance.at(1, 0) = glm::vec3(1e-7f);  // half's subnormals step by 6e-8
  write_exr(radiance, path("d.exr"), {Image(), layer_image(2, 2, 0.5f), depth, variance, Image()},
            ExrPixelType::kHalf);
  const ExrContents back = read_exr_channels(path("d.exr"));
  EXPECT_EQ(channel_names(back),
            (std::set<std::string>{"R", "G", "B", "normal.X", "normal.Y", "normal.Z", "Z",
                                   "variance.R", "variance.G", "variance.B"}));
  EXPECT_EQ(back.channels.at("variance.G").stored, Imf::FLOAT);
  EXPECT_EQ(channel_at(back, "variance.B", 1, 0), 1e-7f);
  EXPECT_EQ(back.channels.at("Z").stored, Imf::FLOAT);
  EXPECT_EQ(back.channels.at("normal.X").stored, Imf::HALF);
  EXPECT_EQ(back.channels.at("R").stored, Imf::HALF);
  EXPECT_EQ(channel_at(back, "Z", 1, 1), 4097.3f);
  EXPECT_EQ(channel_at(back, "Z", 0, 0), 0.0f);
}

TEST_F(TempDir, ExrWithOnlyDepthHasRgbAndZ) {
  Image depth(2, 1);
  depth.at(0, 0) = glm::vec3(2.5f);
  write_exr(layer_image(2, 1, 0.0f), path("z.exr"), {Image(), Image(), depth, Image(), Image()});
  const ExrContents back = read_exr_channels(path("z.exr"));
  EXPECT_EQ(channel_names(back), (std::set<std::string>{"R", "G", "B", "Z"}));
  EXPECT_EQ(channel_at(back, "Z", 0, 0), 2.5f);
}

// Header attributes come back through OpenEXR's reader with their types and values; a name that
// is empty or one of OpenEXR's own (which would replace the file's channel list or compression)
// is refused before anything is written.
TEST_F(TempDir, ExrHeaderAttributesRoundTripAndOpenExrsOwnNamesAreRefused) {
  const std::vector<ExrAttribute> attributes = {{"tritrace.spp", 256},
                                                {"tritrace.renderSeconds", 1.25f},
                                                {"tritrace.stoppedBy", std::string("time limit")}};
  write_exr(layer_image(4, 4, 0.5f), path("a.exr"), {}, ExrPixelType::kFloat, attributes);
  const ExrContents back = read_exr_channels(path("a.exr"));
  EXPECT_EQ(back.numbers.at("tritrace.spp"), 256.0);
  EXPECT_EQ(back.numbers.at("tritrace.renderSeconds"), 1.25);
  EXPECT_EQ(back.strings.at("tritrace.stoppedBy"), "time limit");
  EXPECT_EQ(channel_at(back, "G", 1, 1), 0.5f + 5 * 0.0625f + 0.25f);  // layer_image's pixel
  for (const char* bad : {"", "compression", "channels"}) {
    const std::vector<ExrAttribute> one = {{bad, 1}};
    EXPECT_THROW(write_exr(layer_image(4, 4, 0.0f), path("b.exr"), {}, ExrPixelType::kFloat, one),
                 Error)
        << bad;
  }
  EXPECT_EQ(entries(), 1u);
}

TEST_F(TempDir, ExrAovOfAnotherSizeThrowsAndWritesNothing) {
  const std::string p = path("bad.exr");
  try {
    write_exr(layer_image(4, 4, 0.0f), p,
              {layer_image(4, 3, 0.0f), Image(), Image(), Image(), Image()});
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), p);
    EXPECT_NE(e.reason().find("albedo"), std::string::npos) << e.reason();
  }
  EXPECT_EQ(entries(), 0u);
}

TEST_F(TempDir, ExrReplacesAnExistingFileAndLeavesNoTemporary) {
  { std::ofstream(path("a.exr")) << "not an exr"; }
  write_image(layer_image(3, 2, 0.5f), path("a.exr"));
  EXPECT_EQ(entries(), 1u);
  EXPECT_EQ(channel_at(read_exr_channels(path("a.exr")), "G", 2, 1), 0.5f + 5 * 0.0625f + 0.25f);
}

TEST_F(TempDir, CheckWritablePathRejectsFoldersAndMissingParents) {
  EXPECT_NO_THROW(check_writable_path(path("new.png")));
  EXPECT_THROW(check_writable_path(path("nope/new.png")), Error);
  fs::create_directory(path("sub"));
  EXPECT_THROW(check_writable_path(path("sub")), Error);
  EXPECT_THROW(check_writable_path(path("new.png/x.png")), Error);
}

}  // namespace
}  // namespace tritrace
