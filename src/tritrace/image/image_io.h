// Image files: PNG (8-bit, through stb_image_write), binary PPM (P6) and PFM (32-bit float), chosen
// by the file's extension; every write is atomic.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "tritrace/image/image.h"

namespace tritrace {

enum class ImageFormat { kPng, kPpm, kPfm };

// From the extension, case-insensitively: .png, .ppm, .pfm. nullopt for anything else.
std::optional<ImageFormat> image_format_for(const std::string& path);

// Encoded file contents. PNG and PPM use to_byte_lab; PFM stores the floats (rows bottom-up, as the
// format requires, little-endian).
std::vector<uint8_t> encode_image(const Image& image, ImageFormat format);

// Encodes by extension and writes atomically. Throws Error(path, reason).
void write_image(const Image& image, const std::string& path);

struct Rgb8Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgb;  // interleaved, row 0 first
};

// Reads an 8-bit RGB file back (PNG or PPM, through stb_image); for tests and tools.
Rgb8Image read_image_rgb8(const std::string& path);

}  // namespace tritrace
