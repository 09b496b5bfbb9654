// Texture lookups and decoding; stb_image does the file formats.
#include "tritrace/image/texture.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>

#include "stb_image.h"
#include "tritrace/error.h"
#include "tritrace/image/image_limits.h"

namespace tritrace {
namespace {

// Texel index i wrapped into [0, n).
int64_t wrap(int64_t i, int64_t n, WrapMode mode) {
  switch (mode) {
    case WrapMode::kClamp:
      return std::clamp<int64_t>(i, 0, n - 1);
    case WrapMode::kMirror: {
      const int64_t m = ((i % (2 * n)) + 2 * n) % (2 * n);
      return m < n ? m : 2 * n - 1 - m;
    }
    case WrapMode::kRepeat:
      break;
  }
  return ((i % n) + n) % n;
}

// The texel coordinate, in texel units with texel centres at integers, of a texture coordinate;
// bounded so that far-away and non-finite coordinates still give an index (wrapped or clamped).
double texel_coordinate(float c, int n) {
  const double x = static_cast<double>(c) * n - 0.5;
  if (!std::isfinite(x)) return x > 0 ? 1e15 : -1e15;
  return std::clamp(x, -1e15, 1e15);
}

}  // namespace

float srgb_to_linear(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

Texture::Texture(int width, int height, std::vector<glm::vec3> texels)
    : width_(width), height_(height), texels_(std::move(texels)) {}

Texture Texture::from_srgb8(const TextureImage& image) {
  std::array<float, 256> linear{};
  for (int b = 0; b < 256; ++b) linear[static_cast<size_t>(b)] = srgb_to_linear(b / 255.0f);
  std::vector<glm::vec3> texels(static_cast<size_t>(image.width) * image.height);
  for (size_t i = 0; i < texels.size(); ++i) {
    texels[i] = {linear[image.rgb[3 * i]], linear[image.rgb[3 * i + 1]],
                 linear[image.rgb[3 * i + 2]]};
  }
  return Texture(image.width, image.height, std::move(texels));
}

Texture Texture::from_linear8(const TextureImage& image) {
  std::vector<glm::vec3> texels(static_cast<size_t>(image.width) * image.height);
  for (size_t i = 0; i < texels.size(); ++i) {
    texels[i] = glm::vec3(image.rgb[3 * i], image.rgb[3 * i + 1], image.rgb[3 * i + 2]) / 255.0f;
  }
  return Texture(image.width, image.height, std::move(texels));
}

glm::vec3 Texture::lookup(glm::vec2 uv, WrapMode s, WrapMode t) const {
  const double x = texel_coordinate(uv.x, width_);
  const double y = texel_coordinate(1.0f - uv.y, height_);
  const double x0 = std::floor(x), y0 = std::floor(y);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const int64_t ix = static_cast<int64_t>(x0), iy = static_cast<int64_t>(y0);
  const int x_lo = static_cast<int>(wrap(ix, width_, s)),
            x_hi = static_cast<int>(wrap(ix + 1, width_, s));
  const int y_lo = static_cast<int>(wrap(iy, height_, t)),
            y_hi = static_cast<int>(wrap(iy + 1, height_, t));
  const glm::vec3 top = (1.0f - fx) * texel(x_lo, y_lo) + fx * texel(x_hi, y_lo);
  const glm::vec3 bottom = (1.0f - fx) * texel(x_lo, y_hi) + fx * texel(x_hi, y_hi);
  return (1.0f - fy) * top + fy * bottom;
}

TextureImage decode_texture_image(std::span<const uint8_t> bytes, const std::string& subject) {
  if (bytes.empty()) throw Error(subject, "cannot read texture: the file is empty");
  if (bytes.size() > static_cast<size_t>(INT_MAX)) {
    throw Error(subject, "cannot read texture: the file is too large");
  }
  int w = 0, h = 0, channels = 0;
  if (!stbi_info_from_memory(bytes.data(), static_cast<int>(bytes.size()), &w, &h, &channels)) {
    throw Error(subject, std::string("cannot read texture: ") + stbi_failure_reason());
  }
  try {
    check_image_sides(w, h, subject);
    check_file_holds_pixels(w, h, least_bytes_for_pixels(w, h), bytes.size(), subject);
  } catch (const Error& e) {
    throw Error(subject, "cannot read texture: " + e.reason());
  }
  uint8_t* data =
      stbi_load_from_memory(bytes.data(), static_cast<int>(bytes.size()), &w, &h, &channels, 3);
  if (!data) throw Error(subject, std::string("cannot read texture: ") + stbi_failure_reason());
  TextureImage image{w, h, std::vector<uint8_t>(data, data + static_cast<size_t>(w) * h * 3), true};
  stbi_image_free(data);
  return image;
}

}  // namespace tritrace
