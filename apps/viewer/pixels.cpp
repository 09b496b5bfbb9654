// One pass over the float image per frame, on all cores like the render itself (a 1280 x 720
// frame is 2.8 million conversions); to_byte_lab is inline and branch-free so rows vectorise.
#include "pixels.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstring>

namespace tritrace::view {

void pack_argb8888(const Image& image, uint8_t* dst, int pitch_bytes) {
  const glm::vec3* src = image.pixels().data();
  const int width = image.width();
  tbb::parallel_for(tbb::blocked_range<int>(0, image.height(), 16),
                    [&](const tbb::blocked_range<int>& rows) {
                      for (int y = rows.begin(); y < rows.end(); ++y) {
                        uint8_t* row = dst + static_cast<ptrdiff_t>(y) * pitch_bytes;
                        const glm::vec3* in = src + static_cast<size_t>(y) * width;
                        for (int x = 0; x < width; ++x) {
                          const uint32_t word = 0xff000000u | uint32_t{to_byte_lab(in[x].r)} << 16 |
                                                uint32_t{to_byte_lab(in[x].g)} << 8 |
                                                uint32_t{to_byte_lab(in[x].b)};
                          std::memcpy(row + 4 * static_cast<size_t>(x), &word, sizeof word);
                        }
                      }
                    });
}

}  // namespace tritrace::view
