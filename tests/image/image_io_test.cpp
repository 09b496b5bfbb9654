// The lab's byte conversion, the PNG/PPM/PFM encoders read back independently, and atomic writes
// that leave no temporary file behind.
#include "tritrace/image/image_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

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
  EXPECT_THROW(write_image(sample_image(), path("a.jpg")), Error);
  EXPECT_EQ(entries(), 0u);
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
