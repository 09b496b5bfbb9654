// The one mapping from a file's material keys to tritrace's Material, and external texture files,
// shared by the assimp path (mesh_import.cpp) and the native OBJ reader (obj_reader.cpp).
#include "tritrace/scene/io/material_mapping.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/image/texture.h"

namespace tritrace {
namespace {

float unit_channel(float c) {
  return std::isfinite(c) ? std::clamp(c, 0.0f, 1.0f) : kNeutralGrey.x;
}

std::optional<glm::vec3> unit_colour(const std::optional<glm::vec3>& c) {
  if (!c) return std::nullopt;
  return glm::vec3(unit_channel(c->x), unit_channel(c->y), unit_channel(c->z));
}

// A non-negative finite colour (emission may exceed 1).
glm::vec3 radiance_colour(glm::vec3 c) {
  auto channel = [](float x) { return std::isfinite(x) ? std::max(x, 0.0f) : 0.0f; };
  return {channel(c.x), channel(c.y), channel(c.z)};
}

std::optional<float> finite(const std::optional<float>& value) {
  if (value && std::isfinite(*value)) return value;
  return std::nullopt;
}

// GGX width from a Phong exponent: alpha = sqrt(2 / (Ns + 2)) (Walter et al. 2007, section 5.2,
// the Beckmann-Phong correspondence), and roughness = sqrt(alpha).
float roughness_from_phong(float ns) {
  return std::sqrt(std::sqrt(2.0f / (std::max(ns, 0.0f) + 2.0f)));
}

float max_channel(glm::vec3 c) {
  return std::max({c.x, c.y, c.z});
}

}  // namespace

Material map_material(const MaterialKeys& keys) {
  Material out{kNeutralGrey};
  out.two_sided = true;
  const std::optional<float> metallic = finite(keys.metallic);
  const std::optional<float> roughness = finite(keys.roughness);
  const std::optional<glm::vec3> base = unit_colour(keys.base_colour);
  const std::optional<glm::vec3> diffuse = unit_colour(keys.diffuse);
  if (keys.emissive) {
    out.emission = radiance_colour(*keys.emissive);
    if (const std::optional<float> strength = finite(keys.emissive_intensity)) {
      out.emission *= std::max(*strength, 0.0f);
    }
  }
  const std::optional<float> ior = finite(keys.ior);
  // assimp reports 1 for an MTL without Ni, which would make glass vanish: 1.5 then.
  // Indices within kMinIorOffset of 1, which the BSDFs do not handle, keep 1.5 too.
  if (ior && *ior > 1.0f && *ior <= 4.0f && ior_supported(*ior)) out.ior = *ior;
  out.albedo_texture = keys.albedo_texture;
  out.emission_texture = keys.emission_texture;
  if (metallic || roughness) {
    out.type = MaterialType::kPrincipled;
    out.albedo = base ? *base : diffuse ? *diffuse : glm::vec3(1.0f);
    out.metallic = std::clamp(metallic.value_or(1.0f), 0.0f, 1.0f);  // glTF's defaults
    out.roughness = std::clamp(roughness.value_or(1.0f), 0.0f, 1.0f);
    if (const std::optional<float> t = finite(keys.transmission)) {
      out.transmission = std::clamp(*t, 0.0f, 1.0f);
    }
    return out;
  }
  if (base || diffuse) out.albedo = base ? *base : *diffuse;
  const glm::vec3 specular = unit_colour(keys.specular).value_or(glm::vec3(0.0f));
  const std::optional<float> shininess = finite(keys.shininess);
  const float rough = shininess ? roughness_from_phong(*shininess) : 0.0f;
  const float opacity = finite(keys.opacity).value_or(1.0f);
  if (opacity < 1.0f) {
    out.type = MaterialType::kDielectric;
    out.albedo = glm::vec3(1.0f);
    out.roughness = max_channel(specular) > 0.0f ? rough : 0.0f;
  } else if (max_channel(specular) > 0.0f && max_channel(out.albedo) == 0.0f &&
             !out.albedo_texture.present()) {
    out.type = MaterialType::kConductor;
    out.albedo = specular;
    out.roughness = rough;
  } else if (max_channel(specular) > 0.0f) {
    out.type = MaterialType::kPrincipled;
    out.metallic = 0.0f;
    out.roughness = rough;
  }
  return out;
}

int32_t ExternalTextures::index_of(const std::string& name) {
  if (const auto it = loaded_.find(name); it != loaded_.end()) return it->second;
  namespace fs = std::filesystem;
  // Files written on Windows name textures with backslashes (".\\wood.jpg").
  std::string path = name;
  std::replace(path.begin(), path.end(), '\\', '/');
  const std::string referenced = " (referenced by " + subject_ + ")";
  if (directory_.empty()) {
    throw Error(path, "cannot read texture: a model read from memory has no folder" + referenced);
  }
  const fs::path file = fs::path(path).is_absolute() ? fs::path(path) : fs::path(directory_) / path;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(file.string(), "cannot read texture: no such file" + referenced);
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
  TextureImage image;
  try {
    image = decode_texture_image(bytes, file.string());
  } catch (const Error& e) {
    throw Error(e.subject(), e.reason() + referenced);
  }
  out_.textures.push_back(std::move(image));
  const auto index = static_cast<int32_t>(out_.textures.size() - 1);
  loaded_.emplace(name, index);
  return index;
}

}  // namespace tritrace
