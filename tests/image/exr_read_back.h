// Reads an EXR file back with OpenEXR's own reader, channel by channel, for the image and CLI
// tests: the check on tritrace's writer goes through code tritrace did not write.
#pragma once

#include <ImfChannelList.h>
#include <ImfFloatAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfStringAttribute.h>

#include <map>
#include <string>
#include <vector>

namespace tritrace::testing {

struct ExrChannelData {
  Imf::PixelType stored = Imf::FLOAT;  // the type in the file
  std::vector<float> values;           // width * height, row 0 (top) first, converted to float
};

struct ExrContents {
  int width = 0;
  int height = 0;
  Imf::Compression compression = Imf::NO_COMPRESSION;
  std::map<std::string, ExrChannelData> channels;  // by full name, e.g. "albedo.R"
  // The header's int and float attributes (as double) and string attributes, by name, beyond
  // OpenEXR's own (tritrace.spp, tritrace.renderSeconds, ...).
  std::map<std::string, double> numbers;
  std::map<std::string, std::string> strings;
};

inline ExrContents read_exr_channels(const std::string& path) {
  Imf::InputFile file(path.c_str());
  const Imf::Header& header = file.header();
  const Imath::Box2i window = header.dataWindow();
  ExrContents contents;
  contents.width = window.max.x - window.min.x + 1;
  contents.height = window.max.y - window.min.y + 1;
  contents.compression = header.compression();
  for (auto it = header.begin(); it != header.end(); ++it) {
    if (const auto* i = dynamic_cast<const Imf::IntAttribute*>(&it.attribute())) {
      contents.numbers[it.name()] = i->value();
    } else if (const auto* f = dynamic_cast<const Imf::FloatAttribute*>(&it.attribute())) {
      contents.numbers[it.name()] = f->value();
    } else if (const auto* t = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) {
      contents.strings[it.name()] = t->value();
    }
  }
  const size_t count = static_cast<size_t>(contents.width) * contents.height;
  for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
    ExrChannelData& data = contents.channels[it.name()];
    data.stored = it.channel().type;
    data.values.assign(count, 0.0f);
  }
  Imf::FrameBuffer frame;
  for (auto& [name, data] : contents.channels) {
    // The slice's base is where pixel (0, 0) would be, so that data-window offsets work too.
    char* base = reinterpret_cast<char*>(data.values.data()) -
                 (static_cast<ptrdiff_t>(window.min.y) * contents.width + window.min.x) *
                     static_cast<ptrdiff_t>(sizeof(float));
    frame.insert(name, Imf::Slice(Imf::FLOAT, base, sizeof(float),
                                  sizeof(float) * static_cast<size_t>(contents.width)));
  }
  file.setFrameBuffer(frame);
  file.readPixels(window.min.y, window.max.y);
  return contents;
}

}  // namespace tritrace::testing
