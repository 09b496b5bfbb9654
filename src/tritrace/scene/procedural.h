// Procedural scenes for speed work: a fractal height field ("terrain") inside the lab's room, with
// a chosen number of triangles, the same bit for bit on every run and machine (integer hashing and
// IEEE +, -, *, / only; no libm, no std::*_distribution).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "tritrace/scene/cornell_box.h"

namespace tritrace {

// "terrain:1m", "terrain:250k", "terrain:5000": the approximate triangle count of the height field.
// nullopt when `name` is not of that form or the count is outside [2, 50m].
std::optional<uint64_t> parse_terrain_triangles(std::string_view name);

// The lab's room (10 triangles, no blocks), its light and camera, and a height-field terrain of
// about `triangles` triangles on the floor, rising toward the back wall so that it covers most of
// the lab view.
Scene make_terrain_scene(uint64_t triangles, const CornellOptions& options = {});

// Whether `name` is one of the scene names below.
bool is_builtin_scene(std::string_view name);

// The scene names the CLI accepts: "cornell", "cornell-area" and "terrain:<count>". Throws
// Error(name, reason, kUsage) for anything else.
Scene make_builtin_scene(std::string_view name, const CornellOptions& options = {});

// For --help and error messages.
inline constexpr std::string_view kBuiltinSceneHelp =
    "cornell (the lab's box), cornell-area (the box lit by a ceiling light, for the path tracer) "
    "or terrain:<triangles> (e.g. terrain:1m, terrain:10m, terrain:250k)";

}  // namespace tritrace
