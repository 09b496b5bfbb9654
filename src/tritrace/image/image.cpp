// Image storage and the lab's byte conversion.
#include "tritrace/image/image.h"

#include <algorithm>
#include <cmath>

namespace tritrace {

Image::Image(int width, int height)
    : width_(width),
      height_(height),
      pixels_(static_cast<size_t>(width) * height, glm::vec3(0.0f)) {}

std::vector<uint8_t> to_rgb8_lab(const Image& image) {
  std::vector<uint8_t> bytes;
  bytes.reserve(image.pixels().size() * 3);
  for (const glm::vec3& p : image.pixels()) {
    bytes.push_back(to_byte_lab(p.r));
    bytes.push_back(to_byte_lab(p.g));
    bytes.push_back(to_byte_lab(p.b));
  }
  return bytes;
}

uint8_t to_byte_srgb(float linear) {
  if (!(linear > 0.0f)) return 0;
  if (!(linear < 1.0f)) return 255;
  const float encoded =
      linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
  return static_cast<uint8_t>(std::clamp(std::lround(255.0f * encoded), 0L, 255L));
}

std::vector<uint8_t> to_rgb8_srgb(const Image& image, float exposure_stops) {
  const float scale = std::exp2(exposure_stops);
  std::vector<uint8_t> out;
  out.reserve(image.pixels().size() * 3);
  for (const glm::vec3& p : image.pixels()) {
    for (int c = 0; c < 3; ++c) out.push_back(to_byte_srgb(scale * p[c]));
  }
  return out;
}

}  // namespace tritrace
