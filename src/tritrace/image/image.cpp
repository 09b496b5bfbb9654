// Image storage and the lab's byte conversion.
#include "tritrace/image/image.h"

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

}  // namespace tritrace
