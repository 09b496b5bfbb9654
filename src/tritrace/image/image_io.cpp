// Image encoders and the extension dispatch.
#include "tritrace/image/image_io.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <string>

#include "stb_image.h"
#include "stb_image_write.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"

namespace tritrace {
namespace {

std::vector<uint8_t> bytes_of(const Image& image, const ImageEncoding& encoding) {
  return encoding.curve == ImageEncoding::Curve::kSrgb
             ? to_rgb8_srgb(image, encoding.exposure_stops)
             : to_rgb8_lab(image);
}

std::vector<uint8_t> encode_png(const Image& image, const ImageEncoding& encoding) {
  const std::vector<uint8_t> rgb = bytes_of(image, encoding);
  std::vector<uint8_t> out;
  auto append = [](void* context, void* data, int size) {
    auto* dst = static_cast<std::vector<uint8_t>*>(context);
    const auto* src = static_cast<const uint8_t*>(data);
    dst->insert(dst->end(), src, src + size);
  };
  const int ok = stbi_write_png_to_func(append, &out, image.width(), image.height(), 3, rgb.data(),
                                        image.width() * 3);
  if (!ok) throw Error("png", "encoding failed");
  return out;
}

std::vector<uint8_t> encode_ppm(const Image& image, const ImageEncoding& encoding) {
  const std::string header =
      "P6\n" + std::to_string(image.width()) + " " + std::to_string(image.height()) + "\n255\n";
  std::vector<uint8_t> out(header.begin(), header.end());
  const std::vector<uint8_t> rgb = bytes_of(image, encoding);
  out.insert(out.end(), rgb.begin(), rgb.end());
  return out;
}

std::vector<uint8_t> encode_pfm(const Image& image) {
  static_assert(std::endian::native == std::endian::little, "PFM writer assumes little-endian");
  // A negative scale marks little-endian data.
  const std::string header =
      "PF\n" + std::to_string(image.width()) + " " + std::to_string(image.height()) + "\n-1.0\n";
  std::vector<uint8_t> out(header.begin(), header.end());
  const size_t row_bytes = static_cast<size_t>(image.width()) * 3 * sizeof(float);
  out.resize(header.size() + row_bytes * image.height());
  uint8_t* dst = out.data() + header.size();
  for (int y = image.height() - 1; y >= 0; --y) {  // PFM rows run bottom to top
    std::memcpy(dst, &image.at(0, y), row_bytes);
    dst += row_bytes;
  }
  return out;
}

}  // namespace

std::optional<ImageFormat> image_format_for(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".png") return ImageFormat::kPng;
  if (ext == ".ppm") return ImageFormat::kPpm;
  if (ext == ".pfm") return ImageFormat::kPfm;
  if (ext == ".exr") return ImageFormat::kExr;
  return std::nullopt;
}

std::vector<uint8_t> encode_image(const Image& image, ImageFormat format,
                                  const ImageEncoding& encoding) {
  switch (format) {
    case ImageFormat::kPng:
      return encode_png(image, encoding);
    case ImageFormat::kPpm:
      return encode_ppm(image, encoding);
    case ImageFormat::kPfm:
      return encode_pfm(image);
    case ImageFormat::kExr:
      return encode_exr(image);
  }
  return {};
}

void write_image(const Image& image, const std::string& path, const ImageEncoding& encoding) {
  const std::optional<ImageFormat> format = image_format_for(path);
  if (!format) {
    throw Error(path, "unknown image extension (use " + std::string(kImageExtensions) + ")");
  }
  if (*format == ImageFormat::kExr) {
    write_exr(image, path);
    return;
  }
  write_file_atomic(path, encode_image(image, *format, encoding));
}

void write_exr(const Image& image, const std::string& path, const AovImages& aovs,
               ExrPixelType type) {
  std::vector<uint8_t> bytes;
  try {
    bytes = encode_exr(image, aovs, type);
  } catch (const Error& e) {
    throw Error(path, e.reason(), e.exit_code());
  }
  write_file_atomic(path, bytes);
}

Rgb8Image read_image_rgb8(const std::string& path) {
  int w = 0, h = 0, channels = 0;
  uint8_t* data = stbi_load(path.c_str(), &w, &h, &channels, 3);
  if (!data) throw Error(path, std::string("cannot read image: ") + stbi_failure_reason());
  Rgb8Image image{w, h, std::vector<uint8_t>(data, data + static_cast<size_t>(w) * h * 3)};
  stbi_image_free(data);
  return image;
}

}  // namespace tritrace
