// The limits on images that files describe, checked from their headers before any pixel is
// allocated: a side no longer than kMaxImageSide, and a file large enough to hold that many pixels.
// A crafted header (100000 x 100000 in a 1 KB file) is then an error at once, not gigabytes of
// allocation.
#pragma once

#include <cstdint>
#include <string>

namespace tritrace {

// The longest side of an image tritrace reads or renders.
inline constexpr int kMaxImageSide = 16384;

// The most pixels one byte of an image file may stand for, for formats whose own encoding gives no
// tighter bound. Deflate (PNG, EXR's ZIP) expands one byte to at most 1032, so a 1-bit PNG holds at
// most 8256 pixels per byte; GIF's LZW codes of at least 3 bits stand for at most 4096 pixels; a
// constant EXR under DWA (DCT plus deflate) about 5500. Real files stay far below this.
inline constexpr int64_t kMaxPixelsPerFileByte = 16384;

// Throws Error(subject, reason) unless width and height are in [1, kMaxImageSide].
void check_image_sides(int64_t width, int64_t height, const std::string& subject);

// Throws Error(subject, reason) when a file of `file_bytes` is smaller than `needed_bytes`, the
// least its format needs for width x height pixels.
void check_file_holds_pixels(int64_t width, int64_t height, uint64_t needed_bytes,
                             uint64_t file_bytes, const std::string& subject);

// The least bytes a file needs for width x height pixels at kMaxPixelsPerFileByte.
uint64_t least_bytes_for_pixels(int64_t width, int64_t height);

}  // namespace tritrace
