// Image files: PNG (8-bit, through stb_image_write), binary PPM (P6), PFM (32-bit float) and
// OpenEXR (float or half, with AOV layers), chosen by the file's extension; every write is atomic.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "tritrace/image/exr.h"
#include "tritrace/image/image.h"

namespace tritrace {

enum class ImageFormat { kPng, kPpm, kPfm, kExr };

// From the extension, case-insensitively: .png, .ppm, .pfm, .exr. nullopt for anything else.
std::optional<ImageFormat> image_format_for(const std::string& path);

// The extensions image_format_for knows, as error messages list them.
inline constexpr std::string_view kImageExtensions = ".png, .ppm, .pfm or .exr";

// True for the formats that store linear floats (PFM, EXR) rather than 8-bit encoded values.
inline bool is_float_format(ImageFormat format) {
  return format == ImageFormat::kPfm || format == ImageFormat::kExr;
}

// How 8-bit formats turn linear values into bytes: the lab's clamp without gamma (the lab
// integrator's images), or the sRGB curve after an exposure of 2^stops (physically based images).
// Float formats store the linear values whatever this says.
struct ImageEncoding {
  enum class Curve { kLab, kSrgb };
  Curve curve = Curve::kLab;
  float exposure_stops = 0.0f;
  static ImageEncoding lab() { return {}; }
  static ImageEncoding srgb(float stops = 0.0f) { return {Curve::kSrgb, stops}; }
};

// Encoded file contents. PNG and PPM use `encoding`; PFM stores the floats (rows bottom-up, as the
// format requires, little-endian) and EXR stores them as 32-bit float RGB (encode_exr).
std::vector<uint8_t> encode_image(const Image& image, ImageFormat format,
                                  const ImageEncoding& encoding = ImageEncoding::lab());

// Encodes by extension and writes atomically. Throws Error(path, reason).
void write_image(const Image& image, const std::string& path,
                 const ImageEncoding& encoding = ImageEncoding::lab());

// encode_exr, written atomically to `path` whatever its extension. Throws Error(path, reason).
void write_exr(const Image& image, const std::string& path, const AovImages& aovs = {},
               ExrPixelType type = ExrPixelType::kFloat,
               std::span<const ExrAttribute> attributes = {});

struct Rgb8Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgb;  // interleaved, row 0 first
};

// Reads an 8-bit RGB file back (PNG or PPM, through stb_image); for tests and tools.
Rgb8Image read_image_rgb8(const std::string& path);

// Reads linear float RGB, chosen by the extension (case-insensitively): Radiance HDR (.hdr, through
// stb_image) or OpenEXR (.exr: its R, G and B channels as 32-bit floats, a missing one as 0, or Y
// for all three when it has only luminance). Throws Error(path, reason) for another extension, an
// unreadable file, or a non-finite or negative value.
Image read_image_float(const std::string& path);

// read_image_float's two readers, on a file's bytes (the fuzz targets call them). Each checks the
// header first (image/image_limits.h): sides within kMaxImageSide and a file long enough for its
// pixels, before allocating them. Throw Error(subject, reason). Values are not checked here.
Image decode_radiance_hdr(std::span<const uint8_t> bytes, const std::string& subject);
Image decode_exr_image(std::span<const uint8_t> bytes, const std::string& subject);

// The extensions read_image_float knows, as error messages list them.
inline constexpr std::string_view kFloatImageExtensions = ".hdr or .exr";

// Layers of an OpenEXR file, each a triple of channel names (a single-channel layer such as the
// depth "Z" names it three times), read as 32-bit floats into one image per layer, in the order
// asked. A layer none of whose channels the file has comes back empty (0 x 0). Throws
// Error(path, reason) for an unreadable file, a layer with only some of its channels (naming the
// missing one), or a non-finite value (naming the channel and pixel). For `tritrace denoise`,
// which also asks for the header's string attributes (name to value) through `strings`.
std::vector<Image> read_exr_layers(const std::string& path,
                                   std::span<const std::array<std::string, 3>> layers,
                                   std::map<std::string, std::string>* strings = nullptr);

// Writes a Radiance HDR file (RGBE, run-length encoded, through stb_image_write), atomically.
void write_radiance_hdr(const Image& image, const std::string& path);

}  // namespace tritrace
