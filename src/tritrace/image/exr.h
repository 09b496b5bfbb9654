// OpenEXR encoding: linear float RGB plus optional AOV layers (albedo, normal, depth, variance),
// the inputs denoisers such as Open Image Denoise take, in one single-part scanline file.
#pragma once

#include <string_view>

#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "tritrace/image/image.h"

namespace tritrace {

// How an EXR stores radiance, albedo and normal: 32-bit floats, or 16-bit half floats (half the
// size; 11 significant bits, largest finite value 65504, larger values become infinity). Depth is
// always 32-bit: half would round distances beyond 2048 to whole units and lose the far plane.
// Variance too: a converged pixel's variance (1e-6 and less) is below half's normal range.
enum class ExrPixelType { kFloat, kHalf };

// The AOVs to store beside the radiance; an empty (0 x 0) image is left out. Each must have the
// radiance image's size. Channel names follow the OpenEXR layer convention (layer.channel) that
// Nuke, Blender, oiiotool and OpenImageIO read:
//   radiance R, G, B; albedo albedo.R, albedo.G, albedo.B; normal normal.X, normal.Y, normal.Z;
//   depth Z, OpenEXR's standard depth channel (the red channel of `depth`); variance variance.R,
//   variance.G, variance.B (the estimated variance of the pixel's mean, per channel).
struct AovImages {
  Image albedo;
  Image normal;
  Image depth;
  Image variance;
  Image spp;  // samples per pixel, in all three channels; written as the one channel "spp"
};

// A header attribute beside OpenEXR's standard ones, for what made the image (tritrace writes
// "tritrace.spp", "tritrace.renderSeconds", ...: see docs/PERFORMANCE.md's adaptive section):
// an int, float or string value, stored as OpenEXR's IntAttribute, FloatAttribute or
// StringAttribute, which any EXR reader (exrheader, OpenImageIO, Nuke) lists.
struct ExrAttribute {
  std::string name;
  std::variant<int, float, std::string> value;
};

// The OpenEXR library this build uses ("3.1.5").
std::string_view openexr_version();

// The file's bytes: scanlines top row first, ZIP compression (lossless), values stored as they
// are (no clamp, no curve, NaN and infinity kept), with `attributes` in the header. Throws
// Error("exr", reason) when the AOVs' sizes differ from the image's, an attribute's name is empty
// or one of OpenEXR's own, or OpenEXR fails.
std::vector<uint8_t> encode_exr(const Image& image, const AovImages& aovs = {},
                                ExrPixelType type = ExrPixelType::kFloat,
                                std::span<const ExrAttribute> attributes = {});

}  // namespace tritrace
