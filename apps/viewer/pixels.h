// The rendered Image as the window's texture pixels: ARGB8888 (a 32-bit word per pixel, alpha
// highest), the format SDL's renderers take without converting, with the lab's byte conversion.
#pragma once

#include <cstdint>

#include "tritrace/image/image.h"

namespace tritrace::view {

// Writes image.height() rows of image.width() pixels to `dst`, rows `pitch_bytes` apart.
void pack_argb8888(const Image& image, uint8_t* dst, int pitch_bytes);

}  // namespace tritrace::view
