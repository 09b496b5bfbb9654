// Reading glTF materials from JSON (glTF 2.0 specification, sections 3.8 "Textures" and 3.9
// "Materials", and the KHR_texture_transform, KHR_materials_emissive_strength, KHR_materials_ior
// and KHR_materials_transmission extension specifications).
#include "tritrace/scene/io/gltf_materials.h"

#include <array>
#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "tritrace/error.h"

namespace tritrace {
namespace {

using Json = nlohmann::json;

class MaterialReader {
 public:
  explicit MaterialReader(const std::string& subject) : subject_(subject) {}

  GltfMaterialTable run(const Json& doc) {
    if (!doc.is_object()) fail("", "a glTF document must be a JSON object");
    doc_ = &doc;
    GltfMaterialTable out;
    const LoadOrder order = assimp_load_order(doc);
    read_images(doc, order, out);
    const Json& materials = member_array(doc, "materials", "");
    for (const size_t i : order.materials) {
      out.materials.push_back(read_material(materials[i], "/materials/" + std::to_string(i)));
      out.file_index.push_back(i);
    }
    return out;
  }

 private:
  [[noreturn]] void fail(const std::string& where, const std::string& reason) const {
    throw Error(subject_, where.empty() ? reason : where + ": " + reason);
  }

  // j[key] when present (an array), else an empty array.
  const Json& member_array(const Json& j, const char* key, const std::string& where) const {
    static const Json kEmpty = Json::array();
    if (!j.contains(key)) return kEmpty;
    if (!j[key].is_array()) fail(where + "/" + key, "must be an array");
    return j[key];
  }

  const Json* member_object(const Json& j, const char* key, const std::string& where) const {
    if (!j.contains(key)) return nullptr;
    if (!j[key].is_object()) fail(where + "/" + key, "must be an object");
    return &j[key];
  }

  double number(const Json& j, const char* key, double fallback, const std::string& where) const {
    if (!j.contains(key)) return fallback;
    const Json& v = j[key];
    if (!v.is_number() || !std::isfinite(v.get<double>())) {
      fail(where + "/" + key, "must be a finite number");
    }
    return v.get<double>();
  }

  size_t index(const Json& j, const char* key, size_t count, const std::string& where) const {
    const Json& v = j[key];
    if (!v.is_number_unsigned() || v.get<uint64_t>() >= count) {
      fail(where + "/" + key, "must be an index below " + std::to_string(count));
    }
    return static_cast<size_t>(v.get<uint64_t>());
  }

  template <size_t N>
  std::array<double, N> numbers(const Json& j, const char* key, std::array<double, N> fallback,
                                const std::string& where) const {
    if (!j.contains(key)) return fallback;
    const Json& a = j[key];
    if (!a.is_array() || a.size() != N) {
      fail(where + "/" + key, "must be an array of " + std::to_string(N) + " numbers");
    }
    std::array<double, N> v;
    for (size_t i = 0; i < N; ++i) {
      if (!a[i].is_number() || !std::isfinite(a[i].get<double>())) {
        fail(where + "/" + key + "/" + std::to_string(i), "must be a finite number");
      }
      v[i] = a[i].get<double>();
    }
    return v;
  }

  // The materials and images in the order assimp 5.2's glTF importer numbers them. It loads the
  // document's objects lazily, each when first referred to, and numbers them in that order
  // (glTF2Asset.inl, LazyDict::Retrieve): from the default scene's nodes, depth first, a node's
  // children before its own mesh, a mesh's primitives in order, a material's textures in the
  // order Material::Read reads them; then the nodes of skins and animations. Objects it never
  // meets (a material no drawn primitive uses) it does not import.
  struct LoadOrder {
    std::vector<size_t> materials, images;
  };

  LoadOrder assimp_load_order(const Json& doc) const {
    LoadOrder order;
    const Json& nodes = member_array(doc, "nodes", "");
    const Json& meshes = member_array(doc, "meshes", "");
    const Json& materials = member_array(doc, "materials", "");
    const Json& textures = member_array(doc, "textures", "");
    const Json& images = member_array(doc, "images", "");
    std::vector<bool> node_seen(nodes.size()), mesh_seen(meshes.size()),
        material_seen(materials.size()), image_seen(images.size());
    const auto index_in = [](const Json& j, const char* key,
                             size_t count) -> std::optional<size_t> {
      if (!j.is_object() || !j.contains(key) || !j[key].is_number_unsigned()) return std::nullopt;
      const uint64_t i = j[key].get<uint64_t>();
      return i < count ? std::optional<size_t>(i) : std::nullopt;
    };
    const auto used = [&](const char* extension) {
      if (!doc.contains("extensionsUsed") || !doc["extensionsUsed"].is_array()) return false;
      for (const Json& e : doc["extensionsUsed"]) {
        if (e.is_string() && e.get<std::string>() == extension) return true;
      }
      return false;
    };
    const auto visit_texture = [&](const Json* parent, const char* key) {
      if (parent == nullptr || !parent->is_object() || !parent->contains(key)) return;
      const auto t = index_in((*parent)[key], "index", textures.size());
      if (!t) return;
      const auto image = index_in(textures[*t], "source", images.size());
      if (image && !image_seen[*image]) {
        image_seen[*image] = true;
        order.images.push_back(*image);
      }
    };
    const auto visit_material = [&](size_t m) {
      if (material_seen[m]) return;
      material_seen[m] = true;
      order.materials.push_back(m);
      const Json& mat = materials[m];
      if (!mat.is_object()) return;
      const Json* pbr =
          mat.contains("pbrMetallicRoughness") ? &mat["pbrMetallicRoughness"] : nullptr;
      visit_texture(pbr, "baseColorTexture");
      visit_texture(pbr, "metallicRoughnessTexture");
      visit_texture(&mat, "normalTexture");
      visit_texture(&mat, "occlusionTexture");
      visit_texture(&mat, "emissiveTexture");
      if (!mat.contains("extensions") || !mat["extensions"].is_object()) return;
      const Json& ext = mat["extensions"];
      const auto in = [&](const char* name) {
        return used(name) && ext.contains(name) ? &ext[name] : nullptr;
      };
      const Json* sg = in("KHR_materials_pbrSpecularGlossiness");
      visit_texture(sg, "diffuseTexture");
      visit_texture(sg, "specularGlossinessTexture");
      const Json* sheen = in("KHR_materials_sheen");
      visit_texture(sheen, "sheenColorTexture");
      visit_texture(sheen, "sheenRoughnessTexture");
      const Json* coat = in("KHR_materials_clearcoat");
      visit_texture(coat, "clearcoatTexture");
      visit_texture(coat, "clearcoatRoughnessTexture");
      visit_texture(coat, "clearcoatNormalTexture");
      visit_texture(in("KHR_materials_transmission"), "transmissionTexture");
      visit_texture(in("KHR_materials_volume"), "thicknessTexture");
    };
    // Depth first with an explicit stack (a hostile file may nest deeply): a node's children are
    // all visited before its mesh.
    const auto visit_node = [&](size_t root) {
      struct Step {
        size_t node;
        bool children_done;
      };
      std::vector<Step> stack = {{root, false}};
      while (!stack.empty()) {
        const Step step = stack.back();
        stack.pop_back();
        const Json& node = nodes[step.node];
        if (!step.children_done) {
          if (node_seen[step.node]) continue;
          node_seen[step.node] = true;
          stack.push_back({step.node, true});
          if (node.is_object() && node.contains("children") && node["children"].is_array()) {
            const Json& children = node["children"];
            for (size_t c = children.size(); c-- > 0;) {
              const Json& child = children[c];
              if (child.is_number_unsigned() && child.get<uint64_t>() < nodes.size()) {
                stack.push_back({static_cast<size_t>(child.get<uint64_t>()), false});
              }
            }
          }
          continue;
        }
        const auto mesh = index_in(node, "mesh", meshes.size());
        if (!mesh || mesh_seen[*mesh]) continue;
        mesh_seen[*mesh] = true;
        const Json& m = meshes[*mesh];
        if (!m.is_object() || !m.contains("primitives") || !m["primitives"].is_array()) continue;
        for (const Json& p : m["primitives"]) {
          if (const auto mat = index_in(p, "material", materials.size())) visit_material(*mat);
        }
      }
    };
    const auto visit_nodes = [&](const Json& list) {
      if (!list.is_array()) return;
      for (const Json& n : list) {
        if (n.is_number_unsigned() && n.get<uint64_t>() < nodes.size()) {
          visit_node(static_cast<size_t>(n.get<uint64_t>()));
        }
      }
    };
    const Json& scenes = member_array(doc, "scenes", "");
    size_t scene = 0;
    if (doc.contains("scene") && doc["scene"].is_number_unsigned()) {
      scene = static_cast<size_t>(doc["scene"].get<uint64_t>());
    }
    if (scene < scenes.size() && scenes[scene].is_object() && scenes[scene].contains("nodes")) {
      visit_nodes(scenes[scene]["nodes"]);
    }
    for (const Json& skin : member_array(doc, "skins", "")) {
      if (!skin.is_object()) continue;
      if (skin.contains("joints")) visit_nodes(skin["joints"]);
      if (skin.contains("skeleton")) visit_nodes(Json::array({skin["skeleton"]}));
    }
    for (const Json& animation : member_array(doc, "animations", "")) {
      if (!animation.is_object() || !animation.contains("channels")) continue;
      for (const Json& channel : animation["channels"]) {
        if (channel.is_object() && channel.contains("target") && channel["target"].is_object() &&
            channel["target"].contains("node")) {
          visit_nodes(Json::array({channel["target"]["node"]}));
        }
      }
    }
    return order;
  }

  // Every image, in the file's order; assimp numbers those it decodes itself (bufferView or data:
  // URI) in its load order, from 0.
  void read_images(const Json& doc, const LoadOrder& order, GltfMaterialTable& out) const {
    const Json& images = member_array(doc, "images", "");
    for (size_t i = 0; i < images.size(); ++i) {
      const std::string where = "/images/" + std::to_string(i);
      const Json& image = images[i];
      if (!image.is_object()) fail(where, "must be an object");
      GltfImage g;
      if (image.contains("uri")) {
        if (!image["uri"].is_string()) fail(where + "/uri", "must be a string");
        g.uri = image["uri"].get<std::string>();
        if (g.uri.rfind("data:", 0) == 0) {
          g.uri.clear();
        } else {
          g.uri = percent_decoded(g.uri);
        }
      }
      if (g.uri.empty()) {
        if (!image.contains("uri") && !image.contains("bufferView")) {
          fail(where, "has neither a \"uri\" nor a \"bufferView\"");
        }
      }
      out.images.push_back(std::move(g));
    }
    int32_t embedded = 0;
    for (const size_t i : order.images) {
      if (out.images[i].uri.empty()) out.images[i].embedded = embedded++;
    }
  }

  // A relative URI's %XX escapes decoded (RFC 3986, section 2.1): the file name they stand for.
  static std::string percent_decoded(const std::string& uri) {
    const auto hex = [](char c) {
      return c >= '0' && c <= '9'   ? c - '0'
             : c >= 'a' && c <= 'f' ? c - 'a' + 10
             : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                    : -1;
    };
    std::string out;
    for (size_t i = 0; i < uri.size(); ++i) {
      if (uri[i] == '%' && i + 2 < uri.size() && hex(uri[i + 1]) >= 0 && hex(uri[i + 2]) >= 0) {
        out += static_cast<char>(16 * hex(uri[i + 1]) + hex(uri[i + 2]));
        i += 2;
      } else {
        out += uri[i];
      }
    }
    return out;
  }

  static WrapMode wrap(int64_t code) {
    switch (code) {
      case 33071:
        return WrapMode::kClamp;  // CLAMP_TO_EDGE
      case 33648:
        return WrapMode::kMirror;  // MIRRORED_REPEAT
      default:
        return WrapMode::kRepeat;  // REPEAT (10497), the default
    }
  }

  // A textureInfo (or normalTextureInfo) at `where`.
  GltfTextureRef read_texture(const Json& info, const std::string& where) const {
    if (!info.is_object()) fail(where, "must be an object");
    GltfTextureRef ref;
    const Json& textures = member_array(*doc_, "textures", "");
    const size_t t = index(info, "index", textures.size(), where);
    const std::string tw = "/textures/" + std::to_string(t);
    const Json& texture = textures[t];
    if (!texture.is_object()) fail(tw, "must be an object");
    if (!texture.contains("source")) return ref;  // only an extension's image (KTX2, WebP): none
    const size_t images = member_array(*doc_, "images", "").size();
    ref.image = static_cast<int32_t>(index(texture, "source", images, tw));
    if (texture.contains("sampler")) {
      const Json& samplers = member_array(*doc_, "samplers", "");
      const size_t s = index(texture, "sampler", samplers.size(), tw);
      const std::string sw = "/samplers/" + std::to_string(s);
      if (!samplers[s].is_object()) fail(sw, "must be an object");
      ref.wrap_s = wrap(static_cast<int64_t>(number(samplers[s], "wrapS", 10497, sw)));
      ref.wrap_t = wrap(static_cast<int64_t>(number(samplers[s], "wrapT", 10497, sw)));
    }
    double texcoord = number(info, "texCoord", 0, where);
    if (const Json* ext = member_object(info, "extensions", where)) {
      const std::string ew = where + "/extensions";
      if (const Json* tt = member_object(*ext, "KHR_texture_transform", ew)) {
        const std::string xw = ew + "/KHR_texture_transform";
        const auto offset = numbers<2>(*tt, "offset", {0.0, 0.0}, xw);
        const double rotation = number(*tt, "rotation", 0.0, xw);
        const auto scale = numbers<2>(*tt, "scale", {1.0, 1.0}, xw);
        texcoord = number(*tt, "texCoord", texcoord, xw);
        set_transform(offset, rotation, scale, ref);
      }
    }
    if (!(texcoord >= 0.0) || texcoord != std::floor(texcoord)) {
      fail(where + "/texCoord", "must be a whole number at least 0");
    }
    ref.texcoord = texcoord == 1.0 ? 1 : 0;
    return ref;
  }

  // KHR_texture_transform: glTF coordinates g become M g with M = T(offset) R(rotation) S(scale),
  // R = [[cos r, sin r], [-sin r, cos r]] (the extension's matrices). tritrace's coordinates are
  // (u, 1 - g.v), so its matrix is F M F with F(u, v) = (u, 1 - v):
  //   u' = A00 u - A01 v + (A01 + offset.x),  v' = -A10 u + A11 v + (1 - A11 - offset.y)
  // with A = R S.
  static void set_transform(const std::array<double, 2>& offset, double rotation,
                            const std::array<double, 2>& scale, GltfTextureRef& ref) {
    const double c = std::cos(rotation), s = std::sin(rotation);
    const double a00 = c * scale[0], a01 = s * scale[1];
    const double a10 = -s * scale[0], a11 = c * scale[1];
    const double m[6] = {a00, -a10, -a01, a11, a01 + offset[0], 1.0 - a11 - offset[1]};
    for (int i = 0; i < 6; ++i) ref.transform[i] = static_cast<float>(m[i]);
  }

  const Json* extension(const Json& material, const char* name, const std::string& where) const {
    const Json* ext = member_object(material, "extensions", where);
    return ext == nullptr ? nullptr : member_object(*ext, name, where + "/extensions");
  }

  GltfMaterial read_material(const Json& m, const std::string& where) const {
    if (!m.is_object()) fail(where, "must be an object");
    GltfMaterial out;
    if (m.contains("name") && m["name"].is_string()) out.name = m["name"].get<std::string>();
    if (const Json* pbr = member_object(m, "pbrMetallicRoughness", where)) {
      const std::string pw = where + "/pbrMetallicRoughness";
      if (pbr->contains("baseColorTexture")) {
        out.base_colour = read_texture((*pbr)["baseColorTexture"], pw + "/baseColorTexture");
      }
      if (pbr->contains("metallicRoughnessTexture")) {
        out.metallic_roughness =
            read_texture((*pbr)["metallicRoughnessTexture"], pw + "/metallicRoughnessTexture");
      }
    }
    if (m.contains("normalTexture")) {
      out.normal = read_texture(m["normalTexture"], where + "/normalTexture");
      out.normal_scale =
          static_cast<float>(number(m["normalTexture"], "scale", 1.0, where + "/normalTexture"));
    }
    if (m.contains("emissiveTexture")) {
      out.emissive = read_texture(m["emissiveTexture"], where + "/emissiveTexture");
    }
    const auto e = numbers<3>(m, "emissiveFactor", {0.0, 0.0, 0.0}, where);
    out.emissive_factor = glm::vec3(e[0], e[1], e[2]);
    const std::string ew = where + "/extensions";
    if (const Json* x = extension(m, "KHR_materials_emissive_strength", where)) {
      out.emissive_strength = static_cast<float>(
          number(*x, "emissiveStrength", 1.0, ew + "/KHR_materials_emissive_strength"));
    }
    if (const Json* x = extension(m, "KHR_materials_ior", where)) {
      out.ior = static_cast<float>(number(*x, "ior", 1.5, ew + "/KHR_materials_ior"));
    }
    if (const Json* x = extension(m, "KHR_materials_transmission", where)) {
      const std::string xw = ew + "/KHR_materials_transmission";
      out.transmission = static_cast<float>(number(*x, "transmissionFactor", 0.0, xw));
      if (x->contains("transmissionTexture")) {
        out.transmission_texture =
            read_texture((*x)["transmissionTexture"], xw + "/transmissionTexture");
      }
    }
    return out;
  }

  std::string subject_;
  const Json* doc_ = nullptr;
};

}  // namespace

GltfMaterialTable parse_gltf_materials(std::string_view json, const std::string& subject) {
  Json doc;
  try {
    doc = Json::parse(json);
  } catch (const Json::exception&) {
    throw Error(subject, "invalid glTF JSON (reading its materials)");
  }
  return MaterialReader(subject).run(doc);
}

}  // namespace tritrace
