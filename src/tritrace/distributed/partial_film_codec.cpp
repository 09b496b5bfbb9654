// Partial films in OpenEXR. The header is parsed here first (the format's attribute list: name,
// type, size, value), so that a forged size or data window is refused before OpenEXR allocates
// line buffers for it; only then does OpenEXR decode the pixels from memory.
#include "tritrace/distributed/partial_film_codec.h"

#include <IexBaseExc.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstddef>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <string_view>
#include <thread>

#include "tritrace/error.h"
#include "tritrace/image/exr_memory_stream.h"
#include "tritrace/scene/io/loaded_scene.h"

namespace tritrace {
namespace {

constexpr const char* kFormat = "tritrace partial film 2";
// Our headers are a few KB; a larger one is not ours.
constexpr size_t kMaxHeaderBytes = size_t{1} << 20;
// OpenEXR's ZIP compresses 16 scanlines per chunk; a chunk stores its y and size (8 bytes) and
// has an 8-byte entry in the offset table. zlib's deflate never compresses by more than 1032:1,
// so 2048:1 bounds the data of any real file from below.
constexpr size_t kZipLines = 16;
constexpr size_t kMaxDeflateRatio = 2048;

// OpenEXR (de)compresses a file's blocks of scanlines on this many threads: a 4K part is about
// 8 million pixels of 4 to 11 floats, and ZIP on one core dominates a merge.
int exr_threads() {
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

std::string one_line(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

// A layer's channels: name suffix, byte offset in the pixel's vec4 or AovSums, whether an AOV.
struct LayerChannel {
  const char* suffix;
  size_t offset;
  bool aov;
  bool (*kept)(const AovSet&);
};
constexpr LayerChannel kLayerChannels[] = {
    {"R", 0, false, nullptr},
    {"G", 4, false, nullptr},
    {"B", 8, false, nullptr},
    {"W", 12, false, nullptr},
    {"albedo.R", offsetof(AovSums, albedo), true, [](const AovSet& a) { return a.albedo; }},
    {"albedo.G", offsetof(AovSums, albedo) + 4, true, [](const AovSet& a) { return a.albedo; }},
    {"albedo.B", offsetof(AovSums, albedo) + 8, true, [](const AovSet& a) { return a.albedo; }},
    {"normal.X", offsetof(AovSums, normal), true, [](const AovSet& a) { return a.normal; }},
    {"normal.Y", offsetof(AovSums, normal) + 4, true, [](const AovSet& a) { return a.normal; }},
    {"normal.Z", offsetof(AovSums, normal) + 8, true, [](const AovSet& a) { return a.normal; }},
    {"Z", offsetof(AovSums, depth), true, [](const AovSet& a) { return a.depth; }},
    {"even.R", offsetof(AovSums, even), true, [](const AovSet& a) { return a.variance; }},
    {"even.G", offsetof(AovSums, even) + 4, true, [](const AovSet& a) { return a.variance; }},
    {"even.B", offsetof(AovSums, even) + 8, true, [](const AovSet& a) { return a.variance; }},
    {"even.W", offsetof(AovSums, even) + 12, true, [](const AovSet& a) { return a.variance; }},
    {"samples", offsetof(AovSums, samples), true, [](const AovSet& a) { return a.spp; }},
};

// The light image (Film::splats, bdpt's light tracing): per colour channel one 64-bit integer,
// stored as two 32-bit unsigned EXR channels (low and high word, read in place on a
// little-endian machine). Present when the header has tritrace.splats.
constexpr const char* kSplatAttribute = "tritrace.splats";
constexpr const char* kSplatFormat = "fixed64 2^-28";
constexpr size_t kSplatChannels = 6;
static_assert(std::endian::native == std::endian::little,
              "the light image's words are read in place");
std::string splat_channel(size_t k) {
  return std::string("splat.") + "RGB"[k / 2] + (k % 2 == 0 ? ".lo" : ".hi");
}

size_t channels_per_layer(const AovSet& aovs) {
  size_t n = 0;
  for (const LayerChannel& c : kLayerChannels) n += !c.aov || c.kept(aovs);
  return n;
}

std::string channel_name(size_t layer, const LayerChannel& c) {
  return "layer" + std::to_string(layer) + "." + c.suffix;
}

std::string nodes_text(const std::vector<BlockNode>& nodes) {
  std::string s;
  for (const BlockNode& n : nodes) {
    if (!s.empty()) s += ",";
    s += std::to_string(n.level) + ":" + std::to_string(n.index);
  }
  return s;
}

template <typename T>
bool parse_number(std::string_view text, T& out) {
  const auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && p == text.data() + text.size();
}

// "A:B", "I/N" or "WxH" into two numbers.
template <typename A, typename B>
bool parse_pair(std::string_view text, char sep, A& a, B& b) {
  const size_t at = text.find(sep);
  return at != std::string_view::npos && parse_number(text.substr(0, at), a) &&
         parse_number(text.substr(at + 1), b);
}

std::vector<BlockNode> parse_nodes(std::string_view text, bool* ok) {
  std::vector<BlockNode> nodes;
  *ok = true;
  while (!text.empty()) {
    const size_t comma = text.find(',');
    BlockNode n;
    if (!parse_pair(text.substr(0, comma), ':', n.level, n.index) || n.level > 62 ||
        nodes.size() >= BlockCounter::kMaxNodes) {
      *ok = false;
      return {};
    }
    nodes.push_back(n);
    text = comma == std::string_view::npos ? std::string_view() : text.substr(comma + 1);
  }
  return nodes;
}

struct Box {
  int32_t x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  bool operator==(const Box&) const = default;
};

// What the header says, read without OpenEXR.
struct HeaderFacts {
  size_t end = 0;  // offset of the first byte after the header
  bool have_data_window = false;
  Box data_window, display_window;
  int compression = -1;
  std::vector<std::pair<std::string, int32_t>> channels;    // name, pixel type (2: float)
  std::map<std::string, std::string, std::less<>> strings;  // the tritrace.* string attributes
};

// A bounds-checked reader over the header's bytes.
class Reader {
 public:
  Reader(std::span<const uint8_t> bytes, const std::string& name) : bytes_(bytes), name_(name) {}
  size_t at() const { return at_; }
  int32_t int32() {
    const uint8_t* p = take(4);
    return static_cast<int32_t>(uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 |
                                uint32_t{p[3]} << 24);
  }
  uint8_t byte() { return *take(1); }
  // A null-terminated name of at most `limit` characters.
  std::string_view text(size_t limit) {
    const size_t start = at_;
    while (true) {
      if (at_ >= bytes_.size()) throw truncated();
      if (bytes_[at_] == 0) break;
      if (at_ - start >= limit)
        throw Error(name_,
                    "not an OpenEXR file (a name in its header "
                    "is longer than the format allows)");
      ++at_;
    }
    const std::string_view s(reinterpret_cast<const char*>(bytes_.data()) + start, at_ - start);
    ++at_;
    return s;
  }
  std::span<const uint8_t> bytes(size_t n) { return {take(n), n}; }

 private:
  const uint8_t* take(size_t n) {
    if (n > bytes_.size() - at_) throw truncated();
    const uint8_t* p = bytes_.data() + at_;
    at_ += n;
    return p;
  }
  Error truncated() const {
    return Error(name_, bytes_.size() >= kMaxHeaderBytes
                            ? "not a tritrace partial film (its OpenEXR header is over 1 MiB)"
                            : "truncated OpenEXR header");
  }
  std::span<const uint8_t> bytes_;
  const std::string& name_;
  size_t at_ = 0;
};

Box read_box(Reader& r) {
  Box b;
  b.x0 = r.int32();
  b.y0 = r.int32();
  b.x1 = r.int32();
  b.y1 = r.int32();
  return b;
}

// Parses an OpenEXR header (single-part scanline files only). `bytes` may end after the header.
HeaderFacts parse_header(std::span<const uint8_t> bytes, const std::string& name) {
  Reader r(bytes, name);
  if (bytes.size() < 8 || r.int32() != 20000630) {
    throw Error(name,
                "not an OpenEXR file (no magic number); a partial film comes from "
                "render --spp-range or --tile");
  }
  const int32_t version = r.int32();
  if ((version & 0xff) != 2 || (version & 0x1a00) != 0) {
    throw Error(name, "not a tritrace partial film (a tiled, deep or multi-part OpenEXR file)");
  }
  const size_t name_limit = (version & 0x400) ? 255 : 31;
  HeaderFacts f;
  while (true) {
    const std::string_view attr = r.text(name_limit);
    if (attr.empty()) break;
    const std::string_view type = r.text(name_limit);
    const int32_t size = r.int32();
    if (size < 0) throw Error(name, "corrupt OpenEXR header (attribute of negative size)");
    const std::span<const uint8_t> value = r.bytes(static_cast<size_t>(size));
    Reader v(value, name);
    if (attr == "dataWindow" && type == "box2i" && size == 16) {
      f.data_window = read_box(v);
      f.have_data_window = true;
    } else if (attr == "displayWindow" && type == "box2i" && size == 16) {
      f.display_window = read_box(v);
    } else if (attr == "compression" && type == "compression" && size == 1) {
      f.compression = v.byte();
    } else if (attr == "channels" && type == "chlist") {
      while (true) {
        const std::string_view channel = v.text(name_limit);
        if (channel.empty()) break;
        const int32_t pixel_type = v.int32();
        v.bytes(12);  // linear flag, reserved, x and y sampling
        f.channels.emplace_back(channel, pixel_type);
      }
    } else if (type == "string" && attr.starts_with("tritrace.")) {
      f.strings.emplace(attr,
                        std::string(reinterpret_cast<const char*>(value.data()), value.size()));
    }
  }
  f.end = r.at();
  return f;
}

// The part's info and block nodes from the header, every fact checked against the others and
// against the file's size before any pixel memory is allocated.
PartInfo check_header(const HeaderFacts& f, const std::string& name, uint64_t file_size,
                      std::vector<BlockNode>* nodes) {
  const auto format = f.strings.find("tritrace.format");
  if (format == f.strings.end() || !format->second.starts_with("tritrace partial film")) {
    throw Error(name, "not a tritrace partial film (no '" + std::string(kFormat) +
                          "' attribute; render one with --spp-range or --tile)");
  }
  if (format->second != kFormat) {
    throw Error(name, "a " + format->second + ", not a " + kFormat +
                          " (written by another tritrace version; render it again)");
  }
  auto need = [&](const char* attr) -> const std::string& {
    const auto it = f.strings.find(attr);
    if (it == f.strings.end()) {
      throw Error(name, std::string("partial film without its '") + attr + "' attribute");
    }
    return it->second;
  };
  auto bad = [&](const char* attr) {
    return Error(name, std::string("partial film with a malformed '") + attr + "' attribute");
  };
  PartInfo info;
  RenderIdentity& r = info.render;
  r.hash = need("tritrace.render");
  r.settings = need("tritrace.settings");
  r.build = need("tritrace.build");
  r.integrator = need("tritrace.integrator");
  if (!parse_number(need("tritrace.seed"), r.seed)) throw bad("tritrace.seed");
  if (!parse_number(need("tritrace.spp"), r.spp) || r.spp == 0) throw bad("tritrace.spp");
  const std::string& aovs = need("tritrace.aovs");
  r.aovs.albedo = aovs.find("albedo") != std::string::npos;
  r.aovs.normal = aovs.find("normal") != std::string::npos;
  r.aovs.depth = aovs.find("depth") != std::string::npos;
  r.aovs.variance = aovs.find("variance") != std::string::npos;
  r.aovs.spp = aovs.find("spp") != std::string::npos;
  if (aov_list(r.aovs) != aovs) throw bad("tritrace.aovs");
  if (!parse_pair(std::string_view(need("tritrace.size")), 'x', r.width, r.height)) {
    throw bad("tritrace.size");
  }
  if (r.width < 1 || r.height < 1 || r.width > kMaxImageSide || r.height > kMaxImageSide) {
    throw Error(name, "partial film of a " + need("tritrace.size") +
                          " image (width and height "
                          "must be 1 to " +
                          std::to_string(kMaxImageSide) + ")");
  }
  PartRange& range = info.range;
  if (!parse_pair(std::string_view(need("tritrace.samples")), ':', range.first, range.end) ||
      range.first >= range.end || range.end > r.spp) {
    throw bad("tritrace.samples");
  }
  if (range.first % kSampleBlock != 0 || (range.end % kSampleBlock != 0 && range.end != r.spp)) {
    throw Error(name, "partial film of samples " + need("tritrace.samples") +
                          ", not split at multiples of " + std::to_string(kSampleBlock));
  }
  const int64_t tile_count = int64_t{(r.width + kPartTileSize - 1) / kPartTileSize} *
                             ((r.height + kPartTileSize - 1) / kPartTileSize);
  if (!parse_pair(std::string_view(need("tritrace.tile")), '/', range.tile, range.tiles) ||
      range.tiles < 1 || range.tile < 0 || range.tile >= range.tiles || range.tiles > tile_count) {
    throw bad("tritrace.tile");
  }
  bool ok = false;
  *nodes = parse_nodes(need("tritrace.nodes"), &ok);
  BlockCounter counter;
  counter.push_blocks(range.first / kSampleBlock, range.end / kSampleBlock);
  if (!ok ||
      !std::equal(nodes->begin(), nodes->end(), counter.nodes().begin(), counter.nodes().end())) {
    throw Error(name, "partial film whose block nodes '" + need("tritrace.nodes") +
                          "' do not match its samples " + need("tritrace.samples"));
  }

  const PackedShape shape = packed_shape(r.width, r.height, range.tile, range.tiles);
  const Box expected{0, 0, shape.width - 1, shape.height - 1};
  if (!f.have_data_window || f.data_window != expected || f.display_window != expected) {
    const Box& w = f.data_window;
    throw Error(name,
                "partial film whose data window (" + std::to_string(int64_t{w.x1} - w.x0 + 1) +
                    " x " + std::to_string(int64_t{w.y1} - w.y0 + 1) + ") is not the " +
                    std::to_string(shape.width) + " x " + std::to_string(shape.height) +
                    " pixels of " + range.describe() + " of a " + need("tritrace.size") + " image");
  }
  if (f.compression != 3) throw Error(name, "partial film not ZIP-compressed");
  const size_t per_layer = channels_per_layer(r.aovs);
  const size_t layers = nodes->size() + (range.end % kSampleBlock != 0 ? 1 : 0);
  const auto splats = f.strings.find(kSplatAttribute);
  if (splats != f.strings.end() && (splats->second != kSplatFormat || range.tiles != 1)) {
    throw bad(kSplatAttribute);
  }
  const size_t splat_channels = splats != f.strings.end() ? kSplatChannels : 0;
  if (f.channels.size() != layers * per_layer + splat_channels) {
    throw Error(name, "partial film with " + std::to_string(f.channels.size()) +
                          " channels, not the " + std::to_string(layers * per_layer) + " of its " +
                          std::to_string(layers) + " layers" +
                          (splat_channels ? " and its light image's 6" : ""));
  }
  const size_t chunks = (static_cast<size_t>(shape.height) + kZipLines - 1) / kZipLines;
  const uint64_t raw = static_cast<uint64_t>(shape.width) * static_cast<uint64_t>(shape.height) *
                       f.channels.size() * sizeof(float);
  const uint64_t least = f.end + 16 * chunks + raw / kMaxDeflateRatio;
  if (file_size < least) {
    throw Error(name, "truncated partial film: " + std::to_string(file_size) + " bytes, but its " +
                          std::to_string(shape.width) + " x " + std::to_string(shape.height) +
                          " pixels of " + std::to_string(f.channels.size()) +
                          " channels need at least " + std::to_string(least));
  }
  return info;
}

// OpenEXR reads the file from memory; reading past the end is an error, as a short file is.
class ExrMemoryInput final : public Imf::IStream {
 public:
  explicit ExrMemoryInput(std::span<const uint8_t> bytes)
      : Imf::IStream("(in memory)"), bytes_(bytes) {}
  bool read(char c[], int n) override {
    if (n < 0 || static_cast<size_t>(n) > bytes_.size() - pos_) {
      throw Iex::InputExc("unexpected end of file");
    }
    std::memcpy(c, bytes_.data() + pos_, static_cast<size_t>(n));
    pos_ += static_cast<size_t>(n);
    return pos_ < bytes_.size();
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override { pos_ = std::min<uint64_t>(pos, bytes_.size()); }

 private:
  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
};

std::vector<uint8_t> read_bytes(const std::string& path, size_t limit) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open the partial film");
  std::vector<uint8_t> bytes;
  char buffer[65536];
  while (bytes.size() < limit && in.read(buffer, sizeof buffer).gcount() > 0) {
    bytes.insert(bytes.end(), buffer, buffer + in.gcount());
  }
  if (in.bad()) throw Error(path, "cannot read the partial film");
  return bytes;
}

// The table of chunk offsets after the header: each chunk (y, size, data) must lie in the file
// and hold its own lines. OpenEXR would rebuild a broken table by scanning, and read a chunk of
// size 0 as zeros.
void check_chunks(std::span<const uint8_t> bytes, size_t header_end, int height,
                  const std::string& name) {
  const size_t chunks = (static_cast<size_t>(height) + kZipLines - 1) / kZipLines;
  auto word = [&](size_t at, int n) {
    uint64_t v = 0;
    for (int k = n; k-- > 0;) v = v << 8 | bytes[at + static_cast<size_t>(k)];
    return v;
  };
  const size_t table_end = header_end + 8 * chunks;
  for (size_t c = 0; c < chunks; ++c) {
    const uint64_t at = word(header_end + 8 * c, 8);
    const std::string which = "chunk " + std::to_string(c) + " of " + std::to_string(chunks);
    if (at < table_end) {
      throw Error(name, "corrupt partial film: " + which + " is not where its offset table says");
    }
    if (at > bytes.size() - 8) {
      throw Error(name, "truncated partial film: " + std::to_string(bytes.size()) + " bytes, but " +
                            which + " starts at byte " + std::to_string(at));
    }
    const uint64_t end = at + 8 + word(at + 4, 4);
    if (end > bytes.size()) {
      throw Error(name, "truncated partial film: " + std::to_string(bytes.size()) + " bytes, but " +
                            which + " ends at byte " + std::to_string(end));
    }
    if (word(at, 4) != c * kZipLines || end == at + 8) {
      throw Error(name, "corrupt partial film: " + which + " is not where its offset table says");
    }
  }
}

}  // namespace

std::vector<uint8_t> encode_partial_film(const Film& packed, const PartInfo& info) {
  const RenderIdentity& r = info.render;
  Imf::Header header(packed.width(), packed.height());
  header.compression() = Imf::ZIP_COMPRESSION;
  header.lineOrder() = Imf::INCREASING_Y;
  header.insert("tritrace.format", Imf::StringAttribute(kFormat));
  header.insert("tritrace.render", Imf::StringAttribute(r.hash));
  header.insert("tritrace.settings", Imf::StringAttribute(r.settings));
  header.insert("tritrace.build", Imf::StringAttribute(r.build));
  header.insert("tritrace.integrator", Imf::StringAttribute(r.integrator));
  header.insert("tritrace.seed", Imf::StringAttribute(std::to_string(r.seed)));
  header.insert("tritrace.spp", Imf::StringAttribute(std::to_string(r.spp)));
  header.insert("tritrace.aovs", Imf::StringAttribute(aov_list(r.aovs)));
  header.insert("tritrace.size",
                Imf::StringAttribute(std::to_string(r.width) + "x" + std::to_string(r.height)));
  header.insert("tritrace.samples", Imf::StringAttribute(std::to_string(info.range.first) + ":" +
                                                         std::to_string(info.range.end)));
  header.insert("tritrace.tile", Imf::StringAttribute(std::to_string(info.range.tile) + "/" +
                                                      std::to_string(info.range.tiles)));
  header.insert("tritrace.nodes", Imf::StringAttribute(nodes_text(packed.nodes())));

  Imf::FrameBuffer frame;
  const size_t width = static_cast<size_t>(packed.width());
  for (size_t k = 0; k < packed.layer_count(); ++k) {
    for (const LayerChannel& c : kLayerChannels) {
      if (c.aov && !c.kept(packed.aovs())) continue;
      const std::string name = channel_name(k, c);
      header.channels().insert(name, Imf::Channel(Imf::FLOAT));
      // Slices take char* but writing only reads through it.
      char* base = c.aov ? reinterpret_cast<char*>(const_cast<AovSums*>(packed.aov_sums(k)))
                         : reinterpret_cast<char*>(const_cast<glm::vec4*>(packed.sums(k)));
      const size_t stride = c.aov ? sizeof(AovSums) : sizeof(glm::vec4);
      frame.insert(name, Imf::Slice(Imf::FLOAT, base + c.offset, stride, stride * width));
    }
  }
  if (packed.has_splats()) {
    header.insert(kSplatAttribute, Imf::StringAttribute(kSplatFormat));
    char* base = reinterpret_cast<char*>(const_cast<uint64_t*>(packed.splats().data().data()));
    constexpr size_t stride = 3 * sizeof(uint64_t);
    for (size_t k = 0; k < kSplatChannels; ++k) {
      header.channels().insert(splat_channel(k), Imf::Channel(Imf::UINT));
      frame.insert(splat_channel(k),
                   Imf::Slice(Imf::UINT, base + (k / 2) * sizeof(uint64_t) + (k % 2) * 4, stride,
                              stride * width));
    }
  }
  ExrMemoryStream stream;
  try {
    Imf::OutputFile file(stream, header, exr_threads());
    file.setFrameBuffer(frame);
    file.writePixels(packed.height());
  } catch (const std::exception& e) {
    throw Error("exr", "OpenEXR: " + one_line(e.what()));
  }
  return stream.take();
}

PartialFilm decode_partial_film(std::span<const uint8_t> bytes, const std::string& name) {
  std::vector<BlockNode> nodes;
  const HeaderFacts facts =
      parse_header(bytes.first(std::min(bytes.size(), kMaxHeaderBytes)), name);
  PartialFilm part{check_header(facts, name, bytes.size(), &nodes), Film()};
  const PartInfo& info = part.info;
  const PackedShape shape =
      packed_shape(info.render.width, info.render.height, info.range.tile, info.range.tiles);
  check_chunks(bytes, facts.end, shape.height, name);
  try {
    ExrMemoryInput stream(bytes);
    Imf::InputFile file(stream, exr_threads());
    const Imf::Header& header = file.header();
    part.film = Film(shape.width, shape.height, info.render.aovs);
    part.film.set_layout(info.range.first, info.range.end, nodes);
    Imf::FrameBuffer frame;
    const size_t width = static_cast<size_t>(shape.width);
    for (size_t k = 0; k < part.film.layer_count(); ++k) {
      for (const LayerChannel& c : kLayerChannels) {
        if (c.aov && !c.kept(info.render.aovs)) continue;
        const std::string channel_text = channel_name(k, c);
        const Imf::Channel* channel = header.channels().findChannel(channel_text);
        if (!channel || channel->type != Imf::FLOAT || channel->xSampling != 1 ||
            channel->ySampling != 1) {
          throw Error(name, "partial film without its 32-bit float channel " + channel_text);
        }
        char* base = c.aov ? reinterpret_cast<char*>(part.film.aov_sums(k))
                           : reinterpret_cast<char*>(part.film.sums(k));
        const size_t stride = c.aov ? sizeof(AovSums) : sizeof(glm::vec4);
        frame.insert(channel_text, Imf::Slice(Imf::FLOAT, base + c.offset, stride, stride * width));
      }
    }
    if (facts.strings.contains(kSplatAttribute)) {
      part.film.enable_splats();
      char* base = reinterpret_cast<char*>(part.film.splats().data().data());
      constexpr size_t stride = 3 * sizeof(uint64_t);
      for (size_t k = 0; k < kSplatChannels; ++k) {
        const Imf::Channel* channel = header.channels().findChannel(splat_channel(k));
        if (!channel || channel->type != Imf::UINT || channel->xSampling != 1 ||
            channel->ySampling != 1) {
          throw Error(name, "partial film without its 32-bit unsigned channel " + splat_channel(k));
        }
        frame.insert(splat_channel(k),
                     Imf::Slice(Imf::UINT, base + (k / 2) * sizeof(uint64_t) + (k % 2) * 4, stride,
                                stride * width));
      }
    }
    file.setFrameBuffer(frame);
    file.readPixels(0, shape.height - 1);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(name, "cannot read the partial film: " + one_line(e.what()));
  }
  return part;
}

PartialFilm read_partial_film(const std::string& path) {
  const std::vector<uint8_t> bytes = read_bytes(path, SIZE_MAX);
  return decode_partial_film(bytes, path);
}

PartInfo read_part_info(const std::string& path) {
  const std::vector<uint8_t> head = read_bytes(path, kMaxHeaderBytes);
  std::error_code ec;
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw Error(path, "cannot read the partial film: " + ec.message());
  std::vector<BlockNode> nodes;
  return check_header(
      parse_header(std::span(head).first(std::min(head.size(), kMaxHeaderBytes)), path), path, size,
      &nodes);
}

}  // namespace tritrace
