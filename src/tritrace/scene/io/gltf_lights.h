// glTF 2.0 punctual lights (KHR_lights_punctual), read from the file's JSON rather than through
// assimp, which folds the intensity into the colour and keeps only a name to find the node by:
// here every light is placed by the world transform of each node that refers to it, and its
// photometric units are converted to tritrace's radiometric ones.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "tritrace/scene/scene.h"

namespace tritrace {

// Lumens per watt in the conversion Blender's glTF importer makes by default (its "Lighting Mode"
// Standard, PBR_WATTS_TO_LUMENS = 683, the luminous efficacy of 555 nm light): a point or spot
// light of I candela gets Blender power 4 pi I / 683 W, a directional light of E lux a strength
// of E / 683 W/m^2. In tritrace's units: intensity I / 683 W/sr (a point light's power
// 4 pi I / 683; a spot light's on-axis intensity, as Blender converts spots by the point light's
// factor) and irradiance E / 683 W/m^2 (docs/SCENE_FORMAT.md, "glTF lights").
inline constexpr double kGltfLumensPerWatt = 683.0;

struct PunctualLights {
  std::vector<PointLight> points;
  std::vector<SpotLight> spots;
  std::vector<DirectionalLight> directionals;

  bool empty() const { return points.empty() && spots.empty() && directionals.empty(); }
};

// Whether `path` names a glTF 2 file by its extension (.gltf or .glb, any case).
bool is_gltf_file(const std::string& path);

// The lights of a glTF document's JSON text, placed by the nodes of its default scene (the
// "scene" property, else the first scene): position the node's world origin, direction its
// world -z. colour times intensity, divided by kGltfLumensPerWatt; spot cones with the glTF
// falloff (SpotFalloff::kGltf). `range` is ignored (the lights fall off as 1/r^2 everywhere).
// Throws Error(subject, "<JSON location>: <reason>") for a malformed light or node.
PunctualLights parse_gltf_lights(std::string_view json, const std::string& subject);

// The same for a .gltf or .glb file (a .glb's first chunk is its JSON). Throws Error(path, ...).
PunctualLights read_gltf_lights(const std::string& path);

}  // namespace tritrace
