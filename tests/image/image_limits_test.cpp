// The image readers check a file's header before allocating its pixels: sides within
// kMaxImageSide and a file long enough for the pixels it claims. Each reader (Radiance HDR, EXR,
// textures through stb_image) gets crafted tiny files whose headers lie; the byte counts the
// errors name are worked out here from each format's encoding.
#include "tritrace/image/image_limits.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/image/image_io.h"
#include "tritrace/image/texture.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;

std::span<const uint8_t> span_of(const std::string& bytes) {
  return {reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()};
}

std::string radiance_header(int width, int height) {
  return "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y " + std::to_string(height) + " +X " +
         std::to_string(width) + "\n";
}

// The reason of the Error that `decode` throws, or a failure.
template <typename Decode>
std::string reason_of(Decode decode, const std::string& subject) {
  try {
    decode();
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), subject);
    EXPECT_EQ(e.reason().find('\n'), std::string::npos) << e.reason();
    return e.reason();
  }
  ADD_FAILURE() << "decoded";
  return {};
}

TEST(ImageLimits, SidesBeyondTheLimitOrEmptyAreErrors) {
  EXPECT_NO_THROW(check_image_sides(1, 1, "f"));
  EXPECT_NO_THROW(check_image_sides(16384, 16384, "f"));
  EXPECT_THROW(check_image_sides(16385, 1, "f"), Error);
  EXPECT_THROW(check_image_sides(1, 16385, "f"), Error);
  EXPECT_THROW(check_image_sides(0, 5, "f"), Error);
  EXPECT_THROW(check_image_sides(5, -1, "f"), Error);
}

TEST(ImageLimits, LeastBytesRoundUp) {
  EXPECT_EQ(least_bytes_for_pixels(1, 1), 1u);
  EXPECT_EQ(least_bytes_for_pixels(16384, 1), 1u);
  EXPECT_EQ(least_bytes_for_pixels(16385, 1), 2u);
  EXPECT_EQ(least_bytes_for_pixels(16384, 16384), 16384u);
}

TEST(RadianceHdrHeader, HugeSidesInATinyFileAreAnError) {
  const std::string bytes = radiance_header(100000, 100000) + std::string(1024, '\0');
  const std::string reason =
      reason_of([&] { (void)decode_radiance_hdr(span_of(bytes), "big.hdr"); }, "big.hdr");
  EXPECT_NE(reason.find("100000 x 100000"), std::string::npos) << reason;
  EXPECT_NE(reason.find("16384"), std::string::npos) << reason;
}

TEST(RadianceHdrHeader, FileTooShortForItsPixelsIsAnError) {
  // 16384 run-length encoded scanlines: a 4-byte header each, then for 4 components 130 runs
  // (16384 / 127 rounded up) of 2 bytes: 16384 * (4 + 4 * 130 * 2) = 17104896 bytes at least.
  const std::string bytes = radiance_header(16384, 16384) + std::string(1024, '\0');
  const std::string reason =
      reason_of([&] { (void)decode_radiance_hdr(span_of(bytes), "short.hdr"); }, "short.hdr");
  EXPECT_NE(reason.find("17104896 bytes"), std::string::npos) << reason;
  EXPECT_NE(reason.find("has " + std::to_string(bytes.size())), std::string::npos) << reason;
}

TEST(RadianceHdrHeader, NarrowImagesNeedFourBytesAPixel) {
  // Below 8 pixels a scanline is never run-length encoded: 4 * 7 * 1000 = 28000 bytes.
  const std::string bytes = radiance_header(7, 1000) + std::string(100, '\0');
  const std::string reason =
      reason_of([&] { (void)decode_radiance_hdr(span_of(bytes), "n.hdr"); }, "n.hdr");
  EXPECT_NE(reason.find("28000 bytes"), std::string::npos) << reason;
}

TEST(RadianceHdrHeader, AFileThatHoldsItsPixelsDecodes) {
  // 2 x 1 flat RGBE pixels: (1, 0.5, 0.25) as mantissas 128, 64, 32 with exponent 129 (2^1).
  const std::string bytes =
      radiance_header(2, 1) + std::string("\x80\x40\x20\x81\x80\x40\x20\x81", 8);
  const Image image = decode_radiance_hdr(span_of(bytes), "ok.hdr");
  ASSERT_EQ(image.width(), 2);
  ASSERT_EQ(image.height(), 1);
  EXPECT_FLOAT_EQ(image.at(1, 0).x, 1.0f);
  EXPECT_FLOAT_EQ(image.at(1, 0).y, 0.5f);
  EXPECT_FLOAT_EQ(image.at(1, 0).z, 0.25f);
}

TEST(RadianceHdrHeader, OtherFormatsAreNotReadAsHdr) {
  const std::string ppm = std::string("P6\n1 1\n255\n") + "abc";
  const std::string reason =
      reason_of([&] { (void)decode_radiance_hdr(span_of(ppm), "p.hdr"); }, "p.hdr");
  EXPECT_NE(reason.find("not a Radiance HDR file"), std::string::npos) << reason;
}

// A real 4 x 4 EXR (ZIP, 16 scanlines a chunk) whose data window is then rewritten in place.
std::string exr_with_data_window(int max_x, int max_y) {
  std::vector<uint8_t> bytes = encode_exr(Image(4, 4));
  const std::string key("dataWindow\0box2i\0", 17);
  const std::string text(bytes.begin(), bytes.end());
  const size_t at = text.find(key);
  EXPECT_NE(at, std::string::npos);
  // After the name and type: the attribute's size (16), then xMin, yMin, xMax, yMax.
  const size_t box = at + key.size() + 4;
  std::memcpy(bytes.data() + box + 8, &max_x, 4);
  std::memcpy(bytes.data() + box + 12, &max_y, 4);
  return {bytes.begin(), bytes.end()};
}

TEST(ExrHeader, TheUnchangedFileDecodes) {
  const std::string bytes = exr_with_data_window(3, 3);
  const Image image = decode_exr_image(span_of(bytes), "ok.exr");
  EXPECT_EQ(image.width(), 4);
  EXPECT_EQ(image.height(), 4);
}

TEST(ExrHeader, HugeDataWindowInATinyFileIsAnError) {
  const std::string bytes = exr_with_data_window(99999, 99999);
  ASSERT_LT(bytes.size(), 1024u);
  const std::string reason =
      reason_of([&] { (void)decode_exr_image(span_of(bytes), "big.exr"); }, "big.exr");
  EXPECT_NE(reason.find("100000 x 100000"), std::string::npos) << reason;
}

TEST(ExrHeader, FileTooShortForItsDataWindowIsAnError) {
  // 16384 rows of ZIP chunks of 16 rows: 1024 offsets of 8 bytes, plus 16384^2 pixels at
  // 16384 pixels a byte: 8192 + 16384 = 24576 bytes at least.
  const std::string bytes = exr_with_data_window(16383, 16383);
  const std::string reason =
      reason_of([&] { (void)decode_exr_image(span_of(bytes), "short.exr"); }, "short.exr");
  EXPECT_NE(reason.find("24576 bytes"), std::string::npos) << reason;
}

TEST(ExrHeader, ReadImageFloatNamesTheFile) {
  const fs::path path =
      fs::temp_directory_path() / ("tritrace-limits-" + std::to_string(::getpid()) + "-short.exr");
  {
    const std::string bytes = exr_with_data_window(16383, 16383);
    std::ofstream(path, std::ios::binary) << bytes;
  }
  const std::string reason =
      reason_of([&] { (void)read_image_float(path.string()); }, path.string());
  fs::remove(path);
  EXPECT_NE(reason.find("24576 bytes"), std::string::npos) << reason;
}

// A PNG's signature and IHDR chunk (8-bit RGB) for width x height, then `tail` bytes of nothing:
// enough for stb_image to read the size, which is all that is checked before decoding.
std::string png_header(uint32_t width, uint32_t height, size_t tail) {
  auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
  };
  return std::string("\x89PNG\r\n\x1a\n", 8) + be32(13) + "IHDR" + be32(width) + be32(height) +
         std::string("\x08\x02\x00\x00\x00", 5) + be32(0) + std::string(tail, '\0');
}

TEST(TextureHeader, SidesBeyondTheLimitAreAnError) {
  // 20000 x 100 (stb_image itself refuses PNGs of more than 2^30 bytes, such as 100000 x 100000).
  const std::string bytes = png_header(20000, 100, 1000);
  const std::string reason =
      reason_of([&] { (void)decode_texture_image(span_of(bytes), "wide.png"); }, "wide.png");
  EXPECT_EQ(reason.rfind("cannot read texture: ", 0), 0u) << reason;
  EXPECT_NE(reason.find("20000 x 100 pixels"), std::string::npos) << reason;
  EXPECT_NE(reason.find("16384"), std::string::npos) << reason;
}

TEST(TextureHeader, FileTooShortForItsPixelsIsAnError) {
  // 16384 x 16384 pixels at 16384 a byte: 16384 bytes at least.
  const std::string bytes = png_header(16384, 16384, 1000);
  const std::string reason =
      reason_of([&] { (void)decode_texture_image(span_of(bytes), "short.png"); }, "short.png");
  EXPECT_NE(reason.find("16384 bytes"), std::string::npos) << reason;
  EXPECT_NE(reason.find("has " + std::to_string(bytes.size())), std::string::npos) << reason;
}

}  // namespace
}  // namespace tritrace
