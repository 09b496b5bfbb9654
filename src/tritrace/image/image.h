// Image: a width x height grid of linear float RGB, row 0 at the top, and the lab's conversion to
// 8-bit (clamp to [0,1], times 255, truncate; no gamma).
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

namespace tritrace {

class Image {
 public:
  Image() = default;
  Image(int width, int height);

  int width() const { return width_; }
  int height() const { return height_; }
  glm::vec3& at(int x, int y) { return pixels_[static_cast<size_t>(y) * width_ + x]; }
  const glm::vec3& at(int x, int y) const { return pixels_[static_cast<size_t>(y) * width_ + x]; }
  const std::vector<glm::vec3>& pixels() const { return pixels_; }

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<glm::vec3> pixels_;
};

// The lab's byte: truncate(clamp(255 * c, 0, 255)), so 0.5 -> 127. NaN maps to 0. Inline so that
// the viewer's per-frame conversion of a whole image vectorises.
inline uint8_t to_byte_lab(float c) {
  // Selects rather than branches, so that loops over pixels vectorise. NaN fails the first compare
  // and becomes 0.
  float scaled = 255.0f * c;
  scaled = scaled > 0.0f ? scaled : 0.0f;
  scaled = scaled < 255.0f ? scaled : 255.0f;
  return static_cast<uint8_t>(static_cast<int>(scaled));
}

// Interleaved RGB bytes, row 0 first, using to_byte_lab.
std::vector<uint8_t> to_rgb8_lab(const Image& image);

// A linear value as an sRGB byte: the IEC 61966-2-1 transfer curve (12.92 c below 0.0031308, else
// 1.055 c^(1/2.4) - 0.055), clamped to [0, 1] and rounded to the nearest of 0..255. NaN maps to 0.
uint8_t to_byte_srgb(float linear);

// Interleaved sRGB bytes, row 0 first, of the image scaled by 2^exposure_stops.
std::vector<uint8_t> to_rgb8_srgb(const Image& image, float exposure_stops = 0.0f);

}  // namespace tritrace
