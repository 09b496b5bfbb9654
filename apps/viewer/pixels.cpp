// One pass over the float image per frame, on all cores like the render itself (a 1280 x 720
// frame is 2.8 million conversions); to_byte_lab is inline and branch-free so rows vectorise.
// The sRGB curve costs a power per channel; it is the very function the image writer uses, so the
// window shows the bytes a screenshot or `tritrace render` writes.
#include "pixels.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstring>

namespace tritrace::view {
namespace {

template <typename ToByte>
void pack_rows(const Image& image, uint8_t* dst, int pitch_bytes, ToByte to_byte) {
  const glm::vec3* src = image.pixels().data();
  const int width = image.width();
  tbb::parallel_for(
      tbb::blocked_range<int>(0, image.height(), 16), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y < rows.end(); ++y) {
          uint8_t* row = dst + static_cast<ptrdiff_t>(y) * pitch_bytes;
          const glm::vec3* in = src + static_cast<size_t>(y) * width;
          for (int x = 0; x < width; ++x) {
            const uint32_t word = 0xff000000u | uint32_t{to_byte(in[x].r)} << 16 |
                                  uint32_t{to_byte(in[x].g)} << 8 | uint32_t{to_byte(in[x].b)};
            std::memcpy(row + 4 * static_cast<size_t>(x), &word, sizeof word);
          }
        }
      });
}

}  // namespace

void pack_argb8888(const Image& image, uint8_t* dst, int pitch_bytes,
                   const ImageEncoding& encoding) {
  if (encoding.curve == ImageEncoding::Curve::kLab) {
    pack_rows(image, dst, pitch_bytes, [](float c) { return to_byte_lab(c); });
    return;
  }
  const float scale = std::exp2(encoding.exposure_stops);
  pack_rows(image, dst, pitch_bytes, [scale](float c) { return to_byte_srgb(scale * c); });
}

}  // namespace tritrace::view
