// The rendered Image as the window's texture pixels: ARGB8888 (a 32-bit word per pixel, alpha
// highest), the format SDL's renderers take without converting, with the same byte conversion
// that `tritrace render` writes: the lab's clamp for the lab integrator, the sRGB curve for path.
#pragma once

#include <cstdint>

#include "tritrace/image/image.h"
#include "tritrace/image/image_io.h"

namespace tritrace::view {

// Writes image.height() rows of image.width() pixels to `dst`, rows `pitch_bytes` apart, each
// channel converted as `encoding` says.
void pack_argb8888(const Image& image, uint8_t* dst, int pitch_bytes,
                   const ImageEncoding& encoding = ImageEncoding::lab());

}  // namespace tritrace::view
