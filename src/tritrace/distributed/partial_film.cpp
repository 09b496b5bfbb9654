// Partial films in OpenEXR (float channels per block-tree layer, tritrace.* string attributes) and
// their merge: parts are checked to be of one render and to cover it exactly once, then their
// layers are pushed, in sample order per tile, through the block counter a single render uses.
#include "tritrace/distributed/partial_film.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <exception>
#include <functional>
#include <map>
#include <numeric>
#include <string_view>
#include <thread>

#include "tritrace/error.h"
#include "tritrace/image/exr_memory_stream.h"
#include "tritrace/math/random.h"

namespace tritrace {
namespace {

constexpr const char* kFormat = "tritrace partial film 1";

// A 64-bit hash of bytes, eight at a time through hash_combine (math/random.h), with the length
// absorbed last so that trailing zeros count.
class Hasher {
 public:
  void add(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
      uint64_t w;
      std::memcpy(&w, p + i, 8);
      h_ = hash_combine(h_, w);
    }
    uint64_t tail = 0;
    // Not for n - i == 0: an empty vector's data() may be null, which memcpy must not be given.
    if (n > i) std::memcpy(&tail, p + i, n - i);
    h_ = hash_combine(hash_combine(h_, tail), n);
  }
  template <typename T>
  void add_vector(const T& v) {  // any contiguous container
    add(v.data(), v.size() * sizeof(v[0]));
  }
  void add_value(const auto& v) { add(&v, sizeof v); }
  uint64_t value() const { return h_; }

 private:
  uint64_t h_ = 0x74726974726163ull;
};

std::string hex(uint64_t v) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(v));
  return text;
}

std::string aov_list(const AovSet& a) {
  std::string s;
  for (auto [on, name] : {std::pair{a.albedo, "albedo"}, std::pair{a.normal, "normal"},
                          std::pair{a.depth, "depth"}}) {
    if (!on) continue;
    if (!s.empty()) s += ",";
    s += name;
  }
  return s;
}

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
};

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

// "A:B" or "I/N" into two numbers.
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
    const std::string_view item = text.substr(0, comma);
    BlockNode n;
    if (!parse_pair(item, ':', n.level, n.index) || n.level > 62) {
      *ok = false;
      return {};
    }
    nodes.push_back(n);
    text = comma == std::string_view::npos ? std::string_view() : text.substr(comma + 1);
  }
  return nodes;
}

const std::string* attribute(const Imf::Header& header, const char* name) {
  const auto* a = header.findTypedAttribute<Imf::StringAttribute>(name);
  return a ? &a->value() : nullptr;
}

// The part's info and block nodes from a header; Error(path, reason) when anything is off.
PartInfo info_from_header(const std::string& path, const Imf::Header& header,
                          std::vector<BlockNode>* nodes) {
  const std::string* format = attribute(header, "tritrace.format");
  if (!format || *format != kFormat) {
    throw Error(path, "not a tritrace partial film (no '" + std::string(kFormat) +
                          "' attribute; render one with --spp-range or --tile)");
  }
  auto need = [&](const char* name) -> const std::string& {
    const std::string* v = attribute(header, name);
    if (!v) throw Error(path, std::string("partial film without its '") + name + "' attribute");
    return *v;
  };
  auto bad = [&](const char* name) {
    return Error(path, std::string("partial film with a malformed '") + name + "' attribute");
  };
  PartInfo info;
  RenderIdentity& r = info.render;
  r.hash = need("tritrace.render");
  r.settings = need("tritrace.settings");
  r.integrator = need("tritrace.integrator");
  if (!parse_number(need("tritrace.seed"), r.seed)) throw bad("tritrace.seed");
  if (!parse_number(need("tritrace.spp"), r.spp) || r.spp == 0) throw bad("tritrace.spp");
  const std::string& aovs = need("tritrace.aovs");
  r.aovs.albedo = aovs.find("albedo") != std::string::npos;
  r.aovs.normal = aovs.find("normal") != std::string::npos;
  r.aovs.depth = aovs.find("depth") != std::string::npos;
  if (aov_list(r.aovs) != aovs) throw bad("tritrace.aovs");
  PartRange& range = info.range;
  if (!parse_pair(std::string_view(need("tritrace.samples")), ':', range.first, range.end) ||
      range.first >= range.end || range.end > r.spp) {
    throw bad("tritrace.samples");
  }
  if (range.first % kSampleBlock != 0 || (range.end % kSampleBlock != 0 && range.end != r.spp)) {
    throw Error(path, "partial film of samples " + need("tritrace.samples") +
                          ", not split at multiples of " + std::to_string(kSampleBlock));
  }
  if (!parse_pair(std::string_view(need("tritrace.tile")), '/', range.tile, range.tiles) ||
      range.tiles < 1 || range.tile < 0 || range.tile >= range.tiles) {
    throw bad("tritrace.tile");
  }
  bool ok = false;
  *nodes = parse_nodes(need("tritrace.nodes"), &ok);
  if (!ok) throw bad("tritrace.nodes");
  const Imath::Box2i window = header.dataWindow();
  if (window.min.x != 0 || window.min.y != 0 || header.displayWindow() != window) {
    throw Error(path, "partial film whose data window is not the whole image");
  }
  r.width = window.max.x + 1;
  r.height = window.max.y + 1;
  return info;
}

}  // namespace

RenderIdentity render_identity(const Scene& scene, const IntegratorSpec& spec,
                               const RenderOptions& options, std::string_view accel,
                               std::string_view kernel, const AovSet& aovs) {
  RenderIdentity id;
  const bool path = spec.kind == IntegratorSpec::Kind::kPath;
  id.integrator = path ? "path" : "lab";
  id.seed = path ? options.seed : 0;
  id.spp = path ? options.spp : 1;
  id.width = scene.camera.width();
  id.height = scene.camera.height();
  id.aovs = aovs;
  id.settings = "integrator=" + id.integrator;
  if (path) {
    id.settings += " spp=" + std::to_string(id.spp) +
                   " max_depth=" + std::to_string(spec.max_depth) +
                   " seed=" + std::to_string(id.seed) +
                   " sampler=" + std::string(sampler_name(options.sampler)) +
                   " filter=" + std::string(filter_name(options.filter));
  }
  id.settings += " accel=" + std::string(accel) + " kernel=" + std::string(kernel) +
                 " size=" + std::to_string(id.width) + "x" + std::to_string(id.height);

  Hasher h;
  h.add(id.settings.data(), id.settings.size());
  const TriangleMesh& m = scene.mesh;
  h.add_vector(m.v0());
  h.add_vector(m.v1());
  h.add_vector(m.v2());
  h.add_vector(m.material());
  // Only a scene with instances adds these, so every other scene keeps its identity.
  for (const TriangleMesh& p : scene.prototypes) {
    h.add_vector(p.v0());
    h.add_vector(p.v1());
    h.add_vector(p.v2());
    h.add_vector(p.material());
  }
  for (const Instance& inst : scene.instances) {
    h.add_value(inst.prototype);
    for (int c = 0; c < 3; ++c) h.add_value(inst.to_world.linear[c]);
    h.add_value(inst.to_world.translation);
  }
  h.add_vector(m.corner_normals());
  h.add_vector(m.corner_uvs());
  for (const Texture& t : scene.textures) {
    h.add_value(t.width());
    h.add_value(t.height());
    h.add_vector(t.texels());
  }
  for (const Material& mat : scene.materials) {
    h.add_value(mat.albedo);
    h.add_value(mat.emission);
    h.add_value(static_cast<uint8_t>(mat.two_sided));
    h.add_value(static_cast<uint8_t>(mat.type));
    h.add_value(mat.roughness);
    h.add_value(mat.ior);
    h.add_value(mat.metallic);
    h.add_value(mat.transmission);
    h.add_value(mat.conductor_eta);
    h.add_value(mat.conductor_k);
    for (const TextureRef& r : {mat.albedo_texture, mat.emission_texture}) {
      h.add_value(r.index);
      h.add_value(static_cast<uint8_t>(r.wrap_s));
      h.add_value(static_cast<uint8_t>(r.wrap_t));
    }
  }
  for (const PointLight& l : scene.lights) {
    h.add_value(l.position);
    h.add_value(l.power);
  }
  h.add_value(scene.ambient);
  h.add_value(scene.environment);
  if (const EnvironmentMap* env = scene.environment_map.get()) {
    h.add_value(env->width);
    h.add_value(env->height);
    h.add_vector(env->texels);
    h.add_value(env->scale);
    h.add_value(env->rotate_degrees);
  }
  const Camera& c = scene.camera;
  for (glm::vec3 v : {c.position(), c.right(), c.down(), c.forward()}) h.add_value(v);
  h.add_value(c.focal_px());
  id.hash = hex(h.value());
  return id;
}

std::string PartRange::describe() const {
  std::string s = "samples [" + std::to_string(first) + ", " + std::to_string(end) + ")";
  if (tiles > 1) s += " of tile " + std::to_string(tile) + "/" + std::to_string(tiles);
  return s;
}

std::vector<uint8_t> encode_partial_film(const Film& film, const PartInfo& info) {
  const RenderIdentity& r = info.render;
  Imf::Header header(film.width(), film.height());
  header.compression() = Imf::ZIP_COMPRESSION;
  header.lineOrder() = Imf::INCREASING_Y;
  header.insert("tritrace.format", Imf::StringAttribute(kFormat));
  header.insert("tritrace.render", Imf::StringAttribute(r.hash));
  header.insert("tritrace.settings", Imf::StringAttribute(r.settings));
  header.insert("tritrace.integrator", Imf::StringAttribute(r.integrator));
  header.insert("tritrace.seed", Imf::StringAttribute(std::to_string(r.seed)));
  header.insert("tritrace.spp", Imf::StringAttribute(std::to_string(r.spp)));
  header.insert("tritrace.aovs", Imf::StringAttribute(aov_list(r.aovs)));
  header.insert("tritrace.samples", Imf::StringAttribute(std::to_string(info.range.first) + ":" +
                                                         std::to_string(info.range.end)));
  header.insert("tritrace.tile", Imf::StringAttribute(std::to_string(info.range.tile) + "/" +
                                                      std::to_string(info.range.tiles)));
  header.insert("tritrace.nodes", Imf::StringAttribute(nodes_text(film.nodes())));

  Imf::FrameBuffer frame;
  const size_t width = static_cast<size_t>(film.width());
  for (size_t k = 0; k < film.layer_count(); ++k) {
    for (const LayerChannel& c : kLayerChannels) {
      if (c.aov && !c.kept(film.aovs())) continue;
      const std::string name = channel_name(k, c);
      header.channels().insert(name, Imf::Channel(Imf::FLOAT));
      // Slices take char* but writing only reads through it.
      char* base = c.aov ? reinterpret_cast<char*>(const_cast<AovSums*>(film.aov_sums(k)))
                         : reinterpret_cast<char*>(const_cast<glm::vec4*>(film.sums(k)));
      const size_t stride = c.aov ? sizeof(AovSums) : sizeof(glm::vec4);
      frame.insert(name, Imf::Slice(Imf::FLOAT, base + c.offset, stride, stride * width));
    }
  }
  ExrMemoryStream stream;
  try {
    Imf::OutputFile file(stream, header, exr_threads());
    file.setFrameBuffer(frame);
    file.writePixels(film.height());
  } catch (const std::exception& e) {
    throw Error("exr", "OpenEXR: " + one_line(e.what()));
  }
  return stream.take();
}

PartInfo read_part_info(const std::string& path) {
  try {
    Imf::InputFile file(path.c_str());
    std::vector<BlockNode> nodes;
    return info_from_header(path, file.header(), &nodes);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path, "cannot read the partial film: " + one_line(e.what()));
  }
}

PartialFilm read_partial_film(const std::string& path) {
  try {
    Imf::InputFile file(path.c_str(), exr_threads());
    const Imf::Header& header = file.header();
    std::vector<BlockNode> nodes;
    PartialFilm part{info_from_header(path, header, &nodes), Film()};
    const PartInfo& info = part.info;
    part.film = Film(info.render.width, info.render.height, info.render.aovs);
    try {
      part.film.set_layout(info.range.first, info.range.end, nodes);
    } catch (const Error& e) {
      throw Error(path,
                  "partial film whose block nodes do not match its samples (" + e.reason() + ")");
    }
    Imf::FrameBuffer frame;
    const size_t width = static_cast<size_t>(info.render.width);
    for (size_t k = 0; k < part.film.layer_count(); ++k) {
      for (const LayerChannel& c : kLayerChannels) {
        if (c.aov && !c.kept(info.render.aovs)) continue;
        const std::string name = channel_name(k, c);
        const Imf::Channel* channel = header.channels().findChannel(name);
        if (!channel || channel->type != Imf::FLOAT) {
          throw Error(path, "partial film without its 32-bit float channel " + name);
        }
        char* base = c.aov ? reinterpret_cast<char*>(part.film.aov_sums(k))
                           : reinterpret_cast<char*>(part.film.sums(k));
        const size_t stride = c.aov ? sizeof(AovSums) : sizeof(glm::vec4);
        frame.insert(name, Imf::Slice(Imf::FLOAT, base + c.offset, stride, stride * width));
      }
    }
    file.setFrameBuffer(frame);
    file.readPixels(0, info.render.height - 1);
    return part;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path, "cannot read the partial film: " + one_line(e.what()));
  }
}

std::string describe_part(const PartInfo& info) {
  const RenderIdentity& r = info.render;
  std::string s;
  s += "partial film: " + info.range.describe() + " of " + std::to_string(r.spp) + " spp\n";
  s += "render: " + r.hash + "\n";
  s += "integrator: " + r.integrator + "\n";
  s += "seed: " + std::to_string(r.seed) + "\n";
  s += "spp: " + std::to_string(r.spp) + "\n";
  s += "size: " + std::to_string(r.width) + "x" + std::to_string(r.height) + "\n";
  s += "samples: " + std::to_string(info.range.first) + ":" + std::to_string(info.range.end) + "\n";
  s += "tile: " + std::to_string(info.range.tile) + "/" + std::to_string(info.range.tiles) + "\n";
  s += "aovs: " + (r.aovs.any() ? aov_list(r.aovs) : std::string("none")) + "\n";
  s += "settings: " + r.settings + "\n";
  return s;
}

std::vector<size_t> plan_merge(const std::vector<std::string>& paths,
                               const std::vector<PartInfo>& parts) {
  if (parts.empty()) throw Error("merge", "no parts given", ExitCode::kUsage);
  const RenderIdentity& ref = parts[0].render;
  const int tiles = parts[0].range.tiles;
  for (size_t i = 1; i < parts.size(); ++i) {
    const RenderIdentity& r = parts[i].render;
    if (!(r == ref)) {
      const bool aovs_only = r.hash == ref.hash && r.settings == ref.settings;
      throw Error(paths[i],
                  "foreign part: " +
                      (aovs_only ? "its AOVs (" + aov_list(r.aovs) + ") differ from " + paths[0] +
                                       "'s (" + aov_list(ref.aovs) + ")"
                                 : "render " + r.hash + " (" + r.settings + "), not render " +
                                       ref.hash + " (" + ref.settings + ") of " + paths[0]));
    }
    if (parts[i].range.tiles != tiles) {
      throw Error(paths[i], "split into " + std::to_string(parts[i].range.tiles) +
                                " tile parts, but " + paths[0] + " into " + std::to_string(tiles) +
                                " (all parts must use one --tile N)");
    }
  }
  std::vector<size_t> order(parts.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const PartRange &ra = parts[a].range, &rb = parts[b].range;
    return ra.tile != rb.tile ? ra.tile < rb.tile : ra.first < rb.first;
  });
  std::vector<std::string> missing;
  auto gap = [&](int tile, uint32_t a, uint32_t b) {
    missing.push_back(PartRange{a, b, tile, tiles}.describe());
  };
  size_t k = 0;
  for (int tile = 0; tile < tiles; ++tile) {
    uint32_t covered = 0;
    size_t previous = order.size();
    for (; k < order.size() && parts[order[k]].range.tile == tile; ++k) {
      const PartRange& r = parts[order[k]].range;
      if (r.first < covered) {
        const PartRange& p = parts[order[previous]].range;
        throw Error(paths[order[k]],
                    "overlaps " + paths[order[previous]] + ": both hold " +
                        PartRange{r.first, std::min(r.end, p.end), tile, tiles}.describe());
      }
      if (r.first > covered) gap(tile, covered, r.first);
      covered = r.end;
      previous = k;
    }
    if (covered < ref.spp) gap(tile, covered, ref.spp);
  }
  if (!missing.empty()) {
    std::string list;
    for (size_t i = 0; i < missing.size() && i < 8; ++i) list += (i ? "; " : "") + missing[i];
    if (missing.size() > 8) list += "; and " + std::to_string(missing.size() - 8) + " more";
    throw Error("merge", "parts missing: " + list + " (render " + ref.hash + ")");
  }
  return order;
}

std::vector<size_t> tile_group_pixels(int width, int height, int tile, int tiles) {
  std::vector<size_t> pixels;
  const int tiles_x = (width + kPartTileSize - 1) / kPartTileSize;
  const int tiles_y = (height + kPartTileSize - 1) / kPartTileSize;
  if (tiles == 1) {
    pixels.resize(static_cast<size_t>(width) * static_cast<size_t>(height));
    std::iota(pixels.begin(), pixels.end(), size_t{0});
    return pixels;
  }
  for (int t = tile; t < tiles_x * tiles_y; t += tiles) {
    const int x0 = (t % tiles_x) * kPartTileSize, y0 = (t / tiles_x) * kPartTileSize;
    for (int y = y0; y < std::min(y0 + kPartTileSize, height); ++y) {
      for (int x = x0; x < std::min(x0 + kPartTileSize, width); ++x) {
        pixels.push_back(static_cast<size_t>(y) * static_cast<size_t>(width) +
                         static_cast<size_t>(x));
      }
    }
  }
  return pixels;
}

Film merge_parts(const std::vector<std::string>& paths) {
  std::vector<PartInfo> infos;
  infos.reserve(paths.size());
  for (const std::string& p : paths) infos.push_back(read_part_info(p));
  const std::vector<size_t> order = plan_merge(paths, infos);
  return merge_planned(infos, order, [&](size_t i) {
    PartialFilm part = read_partial_film(paths[i]);
    if (!(part.info.render == infos[i].render)) {
      throw Error(paths[i], "changed while merging (its render differs now)");
    }
    return std::move(part.film);
  });
}

Film merge_planned(const std::vector<PartInfo>& infos, const std::vector<size_t>& order,
                   const std::function<Film(size_t)>& load) {
  const RenderIdentity& r = infos[0].render;
  const int tiles = infos[0].range.tiles;
  const bool with_aovs = r.aovs.any();

  Film merged(r.width, r.height, r.aovs);
  {
    BlockCounter whole;
    whole.push_blocks(0, r.spp / kSampleBlock);
    merged.set_layout(0, r.spp, std::vector<BlockNode>(whole.nodes().begin(), whole.nodes().end()));
  }
  // The stack of one tile group's layers, full-size and reused; only the group's pixels are read.
  std::vector<std::vector<glm::vec4>> stack;
  std::vector<std::vector<AovSums>> aov_stack;
  const size_t image_pixels = static_cast<size_t>(r.width) * static_cast<size_t>(r.height);

  size_t k = 0;
  for (int tile = 0; tile < tiles; ++tile) {
    const std::vector<size_t> pixels = tile_group_pixels(r.width, r.height, tile, tiles);
    BlockCounter counter;
    size_t depth = 0;
    auto push_layer = [&](const Film& film, size_t layer) {
      if (stack.size() <= depth) {
        stack.emplace_back(image_pixels);
        if (with_aovs) aov_stack.emplace_back(image_pixels);
      }
      const glm::vec4* src = film.sums(layer);
      glm::vec4* dst = stack[depth].data();
      for (size_t p : pixels) dst[p] = src[p];
      if (with_aovs) {
        const AovSums* asrc = film.aov_sums(layer);
        AovSums* adst = aov_stack[depth].data();
        for (size_t p : pixels) adst[p] = asrc[p];
      }
      ++depth;
    };
    for (; k < order.size() && infos[order[k]].range.tile == tile; ++k) {
      const Film film = load(order[k]);
      for (size_t j = 0; j < film.nodes().size(); ++j) {
        push_layer(film, j);
        const int merges = counter.push(film.nodes()[j]);
        for (int m = 0; m < merges; ++m, --depth) {
          glm::vec4* left = stack[depth - 2].data();
          const glm::vec4* right = stack[depth - 1].data();
          for (size_t p : pixels) left[p] = left[p] + right[p];
          if (with_aovs) {
            AovSums* aleft = aov_stack[depth - 2].data();
            const AovSums* aright = aov_stack[depth - 1].data();
            for (size_t p : pixels) aleft[p] = aleft[p] + aright[p];
          }
        }
      }
      if (film.has_partial_block()) push_layer(film, film.layer_count() - 1);
    }
    // A covered group's stack is the whole render's layout, layer for layer.
    if (depth != merged.layer_count()) {
      throw Error("merge", "internal error: the merged layers do not match the whole render's");
    }
    for (size_t layer = 0; layer < depth; ++layer) {
      glm::vec4* dst = merged.sums(layer);
      const glm::vec4* src = stack[layer].data();
      for (size_t p : pixels) dst[p] = src[p];
      if (with_aovs) {
        AovSums* adst = merged.aov_sums(layer);
        const AovSums* asrc = aov_stack[layer].data();
        for (size_t p : pixels) adst[p] = asrc[p];
      }
    }
  }
  return merged;
}

}  // namespace tritrace
