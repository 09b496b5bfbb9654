// Header checks shared by the image readers (HDR, EXR, textures).
#include "tritrace/image/image_limits.h"

#include "tritrace/error.h"

namespace tritrace {
namespace {

std::string size_text(int64_t width, int64_t height) {
  return std::to_string(width) + " x " + std::to_string(height);
}

}  // namespace

void check_image_sides(int64_t width, int64_t height, const std::string& subject) {
  if (width < 1 || height < 1) {
    throw Error(subject, "image of " + size_text(width, height) + " pixels has no pixels");
  }
  if (width > kMaxImageSide || height > kMaxImageSide) {
    throw Error(subject, "image of " + size_text(width, height) +
                             " pixels is larger than the limit of " +
                             std::to_string(kMaxImageSide) + " pixels a side");
  }
}

void check_file_holds_pixels(int64_t width, int64_t height, uint64_t needed_bytes,
                             uint64_t file_bytes, const std::string& subject) {
  if (file_bytes < needed_bytes) {
    throw Error(subject, "the header says " + size_text(width, height) + " pixels, which need at " +
                             "least " + std::to_string(needed_bytes) + " bytes, but the file has " +
                             std::to_string(file_bytes));
  }
}

uint64_t least_bytes_for_pixels(int64_t width, int64_t height) {
  const auto pixels = static_cast<uint64_t>(width) * static_cast<uint64_t>(height);
  return (pixels + kMaxPixelsPerFileByte - 1) / kMaxPixelsPerFileByte;
}

}  // namespace tritrace
