// The viewer's reports: title text, the at-most-once-a-second "Render time" line, medians,
// screenshot names and texture pixels.
#include "frame_report.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "pixels.h"
#include "screenshot.h"

namespace tritrace::view {
namespace {

TEST(WindowTitle, MillisecondsFpsAndSize) {
  EXPECT_EQ(window_title(3.125, 500, 500), "tritrace \u2014 3.1 ms/frame (320 fps), 500x500");
  EXPECT_EQ(window_title(40.0, 1280, 720), "tritrace \u2014 40.0 ms/frame (25 fps), 1280x720");
}

TEST(WindowTitle, ThePathTracersSamplesSoFarAndTarget) {
  EXPECT_EQ(window_title(52.34, 500, 500, 37, 64),
            "tritrace \u2014 52.3 ms/frame, 37/64 spp, 500x500");
  EXPECT_EQ(window_title(8.0, 64, 48, 1, 1), "tritrace \u2014 8.0 ms/frame, 1/1 spp, 64x48");
}

TEST(WindowTitle, SaysWhenTheImageIsDenoised) {
  EXPECT_EQ(window_title(52.34, 500, 500, 37, 64, 32),
            "tritrace \u2014 52.3 ms/frame, 37/64 spp, 500x500, denoised at 32 spp");
  EXPECT_EQ(window_title(8.0, 64, 48, 1, 64, 0),
            "tritrace \u2014 8.0 ms/frame, 1/64 spp, 64x48, denoise on");
}

TEST(WindowTitle, SaysTheThresholdAndWhyRefinementStopped) {
  EXPECT_EQ(window_title(52.34, 500, 500,
                         PathTitle{.spp = 128, .target_spp = 1024, .noise_threshold = 0.05f}),
            "tritrace \u2014 52.3 ms/frame, 128/1024 spp, 500x500, noise threshold 0.05");
  EXPECT_EQ(window_title(8.0, 64, 48,
                         PathTitle{.spp = 40,
                                   .target_spp = 1000,
                                   .denoise = true,
                                   .denoised_spp = 32,
                                   .stopped = "time limit"}),
            "tritrace \u2014 8.0 ms/frame, 40/1000 spp, 64x48, denoised at 32 spp, stopped: time "
            "limit");
  EXPECT_EQ(
      window_title(8.0, 64, 48, PathTitle{.spp = 64, .target_spp = 64, .stopped = "spp reached"}),
      "tritrace \u2014 8.0 ms/frame, 64/64 spp, 64x48, stopped: spp reached");
}

TEST(RenderTimeReport, FirstFrameAtOnceThenAtMostOncePerSecond) {
  RenderTimeReport r;
  EXPECT_FALSE(r.pending());
  r.add_frame(10.0);
  ASSERT_TRUE(r.pending());
  EXPECT_EQ(r.seconds_until_due(5.0), 0.0);
  EXPECT_EQ(r.take_line(5.0), "Render time: 10.0 ms");
  EXPECT_FALSE(r.pending());
  r.add_frame(20.0);
  r.add_frame(30.0);
  EXPECT_DOUBLE_EQ(r.seconds_until_due(5.25), 0.75);
  EXPECT_EQ(r.seconds_until_due(6.0), 0.0);
  EXPECT_EQ(r.take_line(6.5), "Render time: 25.0 ms");  // the mean since the last line
  r.add_frame(1.0);
  EXPECT_DOUBLE_EQ(r.seconds_until_due(7.0), 0.5);
}

TEST(Median, OddEvenAndEmpty) {
  EXPECT_EQ(median({}), 0.0);
  EXPECT_EQ(median({3.0, 1.0, 2.0}), 2.0);
  EXPECT_EQ(median({4.0, 1.0, 3.0, 2.0}), 2.5);
}

TEST(ScreenshotPath, TakesTheFirstFreeNumber) {
  std::string pattern = (std::filesystem::temp_directory_path() / "tritrace_shot.XXXXXX").string();
  ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
  const std::filesystem::path folder = pattern;
  EXPECT_EQ(next_screenshot_path(folder), folder / "tritrace-view-001.png");
  std::ofstream(folder / "tritrace-view-001.png") << "x";
  std::ofstream(folder / "tritrace-view-003.png") << "x";
  EXPECT_EQ(next_screenshot_path(folder), folder / "tritrace-view-002.png");
  std::filesystem::remove_all(folder);
}

TEST(PackArgb8888, LabBytesAlphaOpaqueRowsAtThePitch) {
  Image image(2, 2);
  image.at(0, 0) = glm::vec3(0.5f, 1.0f, 0.0f);     // 127, 255, 0
  image.at(1, 0) = glm::vec3(-1.0f, 2.0f, 0.075f);  // 0, 255, 19 (19.125 truncated)
  image.at(0, 1) = glm::vec3(std::numeric_limits<float>::quiet_NaN(), 0.999f, 0.2f);  // 0, 254, 51
  image.at(1, 1) = glm::vec3(1.0f);
  const int pitch = 12;  // 8 bytes of pixels and 4 of padding per row
  uint8_t bytes[24];
  std::memset(bytes, 0xab, sizeof bytes);
  pack_argb8888(image, bytes, pitch);
  auto word = [&](int x, int y) {
    uint32_t w = 0;
    std::memcpy(&w, bytes + y * pitch + 4 * x, 4);
    return w;
  };
  EXPECT_EQ(word(0, 0), 0xff7fff00u);
  EXPECT_EQ(word(1, 0), 0xff00ff13u);
  EXPECT_EQ(word(0, 1), 0xff00fe33u);
  EXPECT_EQ(word(1, 1), 0xffffffffu);
  EXPECT_EQ(bytes[8], 0xab);  // padding untouched
  EXPECT_EQ(bytes[20], 0xab);
}

// The path tracer's pixels go through the sRGB curve, as `tritrace render` writes them: values
// here from the IEC 61966-2-1 formula by hand (12.92 c below 0.0031308, else
// 1.055 c^(1/2.4) - 0.055, times 255, rounded).
TEST(PackArgb8888, SrgbBytesForThePathTracer) {
  Image image(2, 1);
  image.at(0, 0) = glm::vec3(0.5f, 0.002f, 0.18f);  // 187.52 -> 188, 6.59 -> 7, 117.65 -> 118
  image.at(1, 0) = glm::vec3(0.05f, 10.0f, -1.0f);  // 63.19 -> 63, clamped 255, 0
  uint32_t words[2] = {0, 0};
  pack_argb8888(image, reinterpret_cast<uint8_t*>(words), 8, ImageEncoding::srgb());
  EXPECT_EQ(words[0], 0xffbc0776u);
  EXPECT_EQ(words[1], 0xff3fff00u);
  // One stop of exposure doubles the linear value first: 0.25 -> 0.5 -> 188.
  Image quarter(1, 1);
  quarter.at(0, 0) = glm::vec3(0.25f);
  uint32_t word = 0;
  pack_argb8888(quarter, reinterpret_cast<uint8_t*>(&word), 4, ImageEncoding::srgb(1.0f));
  EXPECT_EQ(word, 0xffbcbcbcu);
}

}  // namespace
}  // namespace tritrace::view
