// encode_exr through OpenEXR's C++ API, into memory, so that the file itself is written atomically
// by write_file_atomic like every other format.
#include "tritrace/image/exr.h"

#include <ImfChannelList.h>
#include <ImfFloatAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <OpenEXRConfig.h>
#include <half.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <string>
#include <thread>
#include <utility>

#include "tritrace/error.h"
#include "tritrace/image/exr_memory_stream.h"

namespace tritrace {
namespace {

static_assert(sizeof(glm::vec3) == 3 * sizeof(float), "slices step over packed float RGB pixels");

struct Channel {
  std::string name;
  const Image* image;
  int component;  // 0, 1, 2: the float of each pixel's vec3 this channel reads
  Imf::PixelType type;
};

std::vector<Channel> channels_of(const Image& image, const AovImages& aovs, ExrPixelType type) {
  const Imf::PixelType colour = type == ExrPixelType::kHalf ? Imf::HALF : Imf::FLOAT;
  std::vector<Channel> channels = {
      {"R", &image, 0, colour}, {"G", &image, 1, colour}, {"B", &image, 2, colour}};
  auto add_layer = [&](const Image& aov, const char* layer, const char* names,
                       Imf::PixelType pixel = Imf::NUM_PIXELTYPES) {
    if (aov.width() == 0 && aov.height() == 0) return;
    if (aov.width() != image.width() || aov.height() != image.height()) {
      throw Error("exr", std::string("the ") + layer + " AOV's size differs from the image's");
    }
    for (int c = 0; c < 3; ++c) {
      channels.push_back({std::string(layer) + "." + names[c], &aov, c,
                          pixel == Imf::NUM_PIXELTYPES ? colour : pixel});
    }
  };
  add_layer(aovs.albedo, "albedo", "RGB");
  add_layer(aovs.normal, "normal", "XYZ");
  if (aovs.depth.width() != 0 || aovs.depth.height() != 0) {
    if (aovs.depth.width() != image.width() || aovs.depth.height() != image.height()) {
      throw Error("exr", "the depth AOV's size differs from the image's");
    }
    channels.push_back({"Z", &aovs.depth, 0, Imf::FLOAT});
  }
  add_layer(aovs.variance, "variance", "RGB", Imf::FLOAT);
  if (aovs.spp.width() != 0 || aovs.spp.height() != 0) {
    if (aovs.spp.width() != image.width() || aovs.spp.height() != image.height()) {
      throw Error("exr", "the spp AOV's size differs from the image's");
    }
    channels.push_back({"spp", &aovs.spp, 0, Imf::FLOAT});
  }
  return channels;
}

// OpenEXR's messages may span lines; errors print as one.
std::string one_line(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

}  // namespace

std::string_view openexr_version() {
  return OPENEXR_VERSION_STRING;
}

std::vector<uint8_t> encode_exr(const Image& image, const AovImages& aovs, ExrPixelType type,
                                std::span<const ExrAttribute> attributes) {
  if (image.width() <= 0 || image.height() <= 0) throw Error("exr", "the image is empty");
  const std::vector<Channel> channels = channels_of(image, aovs, type);

  Imf::Header header(image.width(), image.height());
  header.compression() = Imf::ZIP_COMPRESSION;
  header.lineOrder() = Imf::INCREASING_Y;  // row 0 at the top, as Image and EXR both count
  for (const ExrAttribute& a : attributes) {
    // Replacing one of the header's own (channels, compression, ...) would corrupt the file.
    if (a.name.empty() || header.find(a.name) != header.end()) {
      throw Error("exr", "'" + a.name + "' cannot be a header attribute's name");
    }
    if (const int* i = std::get_if<int>(&a.value)) {
      header.insert(a.name, Imf::IntAttribute(*i));
    } else if (const float* f = std::get_if<float>(&a.value)) {
      header.insert(a.name, Imf::FloatAttribute(*f));
    } else {
      header.insert(a.name, Imf::StringAttribute(std::get<std::string>(a.value)));
    }
  }
  Imf::FrameBuffer frame;
  const size_t width = static_cast<size_t>(image.width());
  const size_t pixels = width * static_cast<size_t>(image.height());
  // OpenEXR converts pixel types when reading but not when writing, so half channels get their
  // own buffers (Imath's float-to-half conversion rounds to nearest even).
  std::vector<std::vector<half>> halves;
  halves.reserve(channels.size());
  for (const Channel& c : channels) {
    header.channels().insert(c.name, Imf::Channel(c.type));
    const float* floats = &c.image->at(0, 0)[c.component];
    if (c.type == Imf::HALF) {
      std::vector<half>& h = halves.emplace_back(pixels);
      for (size_t i = 0; i < pixels; ++i) h[i] = half(floats[3 * i]);
      frame.insert(c.name, Imf::Slice(Imf::HALF, reinterpret_cast<char*>(h.data()), sizeof(half),
                                      sizeof(half) * width));
    } else {
      // Slices take char* but writing only reads through it.
      frame.insert(c.name,
                   Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(floats)),
                              sizeof(glm::vec3), sizeof(glm::vec3) * width));
    }
  }

  ExrMemoryStream stream;
  try {
    // The OutputFile writes the offset table when it is destroyed, so it lives only in this scope.
    // Compressed on every core: OpenEXR's line blocks are compressed independently and written
    // in order, so the bytes are the same as with one thread.
    const int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    Imf::OutputFile file(stream, header, threads);
    file.setFrameBuffer(frame);
    file.writePixels(image.height());
  } catch (const std::exception& e) {
    throw Error("exr", "OpenEXR: " + one_line(e.what()));
  }
  return stream.take();
}

}  // namespace tritrace
