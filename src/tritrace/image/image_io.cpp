// Image encoders and the extension dispatch.
#include "tritrace/image/image_io.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <climits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <openexr.h>
#include <cmath>

#include "stb_image.h"
#include "stb_image_write.h"
#include "tritrace/error.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/image/exr_memory_stream.h"
#include "tritrace/image/image_limits.h"

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
               ExrPixelType type, std::span<const ExrAttribute> attributes) {
  std::vector<uint8_t> bytes;
  try {
    bytes = encode_exr(image, aovs, type, attributes);
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

namespace {

std::vector<uint8_t> read_file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot read image: cannot open the file");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(path, "cannot read image: reading failed");
  return bytes;
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

// The least bytes stb_image's Radiance reader consumes for width x height pixels: a flat scanline
// is 4 bytes a pixel; a run-length encoded one (widths 8 to 32767) a 4-byte header, then for each
// of its 4 components at least one 2-byte run per 127 pixels.
uint64_t least_radiance_bytes(int64_t width, int64_t height) {
  const auto w = static_cast<uint64_t>(width);
  uint64_t line = 4 * w;
  if (width >= 8 && width < 32768) line = std::min(line, 4 + 4 * 2 * ((w + 126) / 127));
  return line * static_cast<uint64_t>(height);
}

// Errors from OpenEXR's core library: the message, kept for the exception, instead of its default
// print to stderr.
struct ExrCoreStream {
  std::span<const uint8_t> bytes;
  std::string message;
};

int64_t exr_core_read(exr_const_context_t, void* user, void* buffer, uint64_t size, uint64_t offset,
                      exr_stream_error_func_ptr_t) {
  const auto* stream = static_cast<const ExrCoreStream*>(user);
  if (offset >= stream->bytes.size()) return 0;
  const uint64_t n = std::min<uint64_t>(size, stream->bytes.size() - offset);
  std::memcpy(buffer, stream->bytes.data() + offset, n);
  return static_cast<int64_t>(n);
}

int64_t exr_core_size(exr_const_context_t, void* user) {
  return static_cast<int64_t>(static_cast<const ExrCoreStream*>(user)->bytes.size());
}

void exr_core_error(exr_const_context_t context, exr_result_t, const char* message) {
  void* user = nullptr;
  if (exr_get_user_data(context, &user) == EXR_ERR_SUCCESS && user != nullptr) {
    auto* stream = static_cast<ExrCoreStream*>(user);
    if (stream->message.empty()) stream->message = message;
  }
}

// Reads the header with OpenEXR's core library, which checks every attribute against the file's
// size, then the data window against kMaxImageSide and the file's size: the chunk offset table (8
// bytes a chunk) and kMaxPixelsPerFileByte. Imf::InputFile sizes its line buffers from the header,
// so this runs before it is made.
void check_exr_header(std::span<const uint8_t> bytes, const std::string& subject) {
  ExrCoreStream stream{bytes, {}};
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = exr_core_error;
  init.user_data = &stream;
  init.read_fn = exr_core_read;
  init.size_fn = exr_core_size;
  exr_context_t context = nullptr;
  exr_result_t result = exr_start_read(&context, subject.c_str(), &init);
  exr_attr_box2i_t window{};
  int32_t chunks = 0;
  if (result == EXR_ERR_SUCCESS) result = exr_get_data_window(context, 0, &window);
  if (result == EXR_ERR_SUCCESS) result = exr_get_chunk_count(context, 0, &chunks);
  exr_finish(&context);
  if (result != EXR_ERR_SUCCESS) {
    std::string reason =
        stream.message.empty() ? exr_get_default_error_message(result) : stream.message;
    std::replace(reason.begin(), reason.end(), '\n', ' ');
    throw Error(subject, "cannot read image: " + reason);
  }
  const int64_t width = int64_t{window.max.x} - window.min.x + 1;
  const int64_t height = int64_t{window.max.y} - window.min.y + 1;
  check_image_sides(width, height, subject);
  const uint64_t needed =
      8 * static_cast<uint64_t>(std::max(chunks, 0)) + least_bytes_for_pixels(width, height);
  check_file_holds_pixels(width, height, needed, bytes.size(), subject);
}

}  // namespace

Image decode_radiance_hdr(std::span<const uint8_t> bytes, const std::string& subject) {
  if (bytes.size() > static_cast<size_t>(INT_MAX)) {
    throw Error(subject, "cannot read image: the file is too large");
  }
  const auto* data = bytes.data();
  const int size = static_cast<int>(bytes.size());
  if (!stbi_is_hdr_from_memory(data, size)) {
    throw Error(subject, "cannot read image: not a Radiance HDR file");
  }
  int w = 0, h = 0, channels = 0;
  if (!stbi_info_from_memory(data, size, &w, &h, &channels)) {
    throw Error(subject, std::string("cannot read image: ") + stbi_failure_reason());
  }
  check_image_sides(w, h, subject);
  check_file_holds_pixels(w, h, least_radiance_bytes(w, h), bytes.size(), subject);
  float* pixels = stbi_loadf_from_memory(data, size, &w, &h, &channels, 3);
  if (!pixels) throw Error(subject, std::string("cannot read image: ") + stbi_failure_reason());
  Image image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float* p = pixels + (static_cast<size_t>(y) * static_cast<size_t>(w) + x) * 3;
      image.at(x, y) = glm::vec3(p[0], p[1], p[2]);
    }
  }
  stbi_image_free(pixels);
  return image;
}

Image decode_exr_image(std::span<const uint8_t> bytes, const std::string& subject) {
  check_exr_header(bytes, subject);
  try {
    ExrMemoryInputStream in(bytes, subject.c_str());
    Imf::InputFile file(in);
    const Imath::Box2i window = file.header().dataWindow();
    const int w = window.max.x - window.min.x + 1, h = window.max.y - window.min.y + 1;
    check_image_sides(w, h, subject);
    const Imf::ChannelList& channels = file.header().channels();
    const bool luminance_only = !channels.findChannel("R") && !channels.findChannel("G") &&
                                !channels.findChannel("B") && channels.findChannel("Y");
    std::vector<float> rgb(static_cast<size_t>(w) * static_cast<size_t>(h) * 3, 0.0f);
    Imf::FrameBuffer frame;
    // The slices' base is placed so that the data window's first pixel lands on rgb[0].
    const ptrdiff_t origin = static_cast<ptrdiff_t>(window.min.y) * w + window.min.x;
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < (luminance_only ? 1 : 3); ++c) {
      char* base = reinterpret_cast<char*>(rgb.data() + c - origin * 3);
      frame.insert(luminance_only ? "Y" : names[c], Imf::Slice(Imf::FLOAT, base, sizeof(float) * 3,
                                                               sizeof(float) * 3 * w, 1, 1, 0.0));
    }
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    Image image(w, h);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const float* p = rgb.data() + (static_cast<size_t>(y) * static_cast<size_t>(w) + x) * 3;
        image.at(x, y) = luminance_only ? glm::vec3(p[0]) : glm::vec3(p[0], p[1], p[2]);
      }
    }
    return image;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    std::string reason = e.what();
    std::replace(reason.begin(), reason.end(), '\n', ' ');
    throw Error(subject, "cannot read image: " + reason);
  }
}

Image read_image_float(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext != ".hdr" && ext != ".exr") {
    throw Error(path, "unknown image extension '" + ext + "' (use " +
                          std::string(kFloatImageExtensions) + ")");
  }
  if (!std::filesystem::is_regular_file(path)) throw Error(path, "cannot read image: no such file");
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  Image image = ext == ".hdr" ? decode_radiance_hdr(bytes, path) : decode_exr_image(bytes, path);
  for (const glm::vec3& c : image.pixels()) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(c[k]) || c[k] < 0.0f) {
        throw Error(path, "image with a non-finite or negative value");
      }
    }
  }
  return image;
}

std::vector<Image> read_exr_layers(const std::string& path,
                                   std::span<const std::array<std::string, 3>> layers,
                                   std::map<std::string, std::string>* strings) {
  if (!std::filesystem::is_regular_file(path)) throw Error(path, "cannot read image: no such file");
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  check_exr_header(bytes, path);
  try {
    ExrMemoryInputStream in(bytes, path.c_str());
    Imf::InputFile file(in);
    const Imath::Box2i window = file.header().dataWindow();
    const int w = window.max.x - window.min.x + 1, h = window.max.y - window.min.y + 1;
    check_image_sides(w, h, path);
    if (strings) {
      strings->clear();
      for (auto a = file.header().begin(); a != file.header().end(); ++a) {
        if (const auto* text = dynamic_cast<const Imf::StringAttribute*>(&a.attribute())) {
          (*strings)[a.name()] = text->value();
        }
      }
    }
    const Imf::ChannelList& channels = file.header().channels();
    const size_t pixels = static_cast<size_t>(w) * static_cast<size_t>(h);
    const ptrdiff_t origin = static_cast<ptrdiff_t>(window.min.y) * w + window.min.x;
    // One plane per distinct channel name read.
    std::vector<std::string> names;
    std::vector<std::vector<float>> planes;
    std::vector<bool> present(layers.size(), false);
    for (size_t l = 0; l < layers.size(); ++l) {
      std::string have, missing;
      for (const std::string& name : layers[l]) {
        std::string& slot = channels.findChannel(name) ? have : missing;
        if (slot.empty()) slot = name;
      }
      if (have.empty()) continue;
      if (!missing.empty()) throw Error(path, "has channel " + have + " but not " + missing);
      present[l] = true;
      for (const std::string& name : layers[l]) {
        if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
      }
    }
    planes.resize(names.size(), std::vector<float>(pixels, 0.0f));
    Imf::FrameBuffer frame;
    for (size_t c = 0; c < names.size(); ++c) {
      char* base = reinterpret_cast<char*>(planes[c].data() - origin);
      frame.insert(names[c],
                   Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * w, 1, 1, 0.0));
    }
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    std::vector<Image> out(layers.size());
    for (size_t l = 0; l < layers.size(); ++l) {
      if (!present[l]) continue;
      out[l] = Image(w, h);
      for (int k = 0; k < 3; ++k) {
        const size_t c = static_cast<size_t>(std::find(names.begin(), names.end(), layers[l][k]) -
                                             names.begin());
        for (int y = 0; y < h; ++y) {
          for (int x = 0; x < w; ++x) {
            const float v = planes[c][static_cast<size_t>(y) * w + x];
            if (!std::isfinite(v)) {
              throw Error(path, "channel " + names[c] + " is not finite at pixel (" +
                                    std::to_string(x) + ", " + std::to_string(y) + ")");
            }
            out[l].at(x, y)[k] = v;
          }
        }
      }
    }
    return out;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    std::string reason = e.what();
    std::replace(reason.begin(), reason.end(), '\n', ' ');
    throw Error(path, "cannot read image: " + reason);
  }
}

void write_radiance_hdr(const Image& image, const std::string& path) {
  std::vector<float> rgb;
  rgb.reserve(image.pixels().size() * 3);
  for (const glm::vec3& c : image.pixels()) rgb.insert(rgb.end(), {c.x, c.y, c.z});
  std::vector<uint8_t> out;
  auto append = [](void* context, void* data, int size) {
    auto* dst = static_cast<std::vector<uint8_t>*>(context);
    const auto* src = static_cast<const uint8_t*>(data);
    dst->insert(dst->end(), src, src + size);
  };
  if (!stbi_write_hdr_to_func(append, &out, image.width(), image.height(), 3, rgb.data())) {
    throw Error(path, "cannot encode a Radiance HDR image");
  }
  write_file_atomic(path, out);
}

}  // namespace tritrace
