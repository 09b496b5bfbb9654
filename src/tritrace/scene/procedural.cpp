// The terrain generator: value noise summed over octaves (fractal Brownian motion) on a ramp.
#include "tritrace/scene/procedural.h"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "tritrace/error.h"

namespace tritrace {
namespace {

constexpr uint64_t kMaxTerrainTriangles = 50'000'000;
const glm::vec3 kTerrainAlbedo(0.62f, 0.56f, 0.44f);

// A 32-bit integer hash (the "lowbias32" mixer by Chris Wellons): good avalanche, portable.
uint32_t hash32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

// A lattice value in [0, 1), exactly representable (24 bits).
float lattice(int32_t i, int32_t j, uint32_t octave) {
  const uint32_t h = hash32(static_cast<uint32_t>(i) * 0x9E3779B1U ^
                            hash32(static_cast<uint32_t>(j) + 0x632BE5ABU * (octave + 1)));
  return static_cast<float>(h >> 8) * (1.0f / 16777216.0f);
}

float smooth(float t) {
  return t * t * (3.0f - 2.0f * t);
}

// Value noise at (x, z), bilinear with a smoothstep fade between lattice points.
float value_noise(float x, float z, uint32_t octave) {
  const float fx = std::floor(x), fz = std::floor(z);
  const int32_t i = static_cast<int32_t>(fx), j = static_cast<int32_t>(fz);
  const float tx = smooth(x - fx), tz = smooth(z - fz);
  const float a = lattice(i, j, octave), b = lattice(i + 1, j, octave);
  const float c = lattice(i, j + 1, octave), d = lattice(i + 1, j + 1, octave);
  const float top = a + (b - a) * tx, bottom = c + (d - c) * tx;
  return top + (bottom - top) * tz;
}

// Height above the floor at (x, z) in [-1, 1]^2: a valley that rises toward the back wall and up
// the side walls, plus five octaves of noise. Stays within [0, 1.9], below the ceiling (height 2).
float terrain_height(float x, float z) {
  const float s = (z + 1.0f) * 0.5f;
  const float x2 = x * x;
  float h = 0.45f + 1.25f * s * s + 1.0f * x2 * x2;
  float amplitude = 0.32f, frequency = 2.5f;
  for (uint32_t octave = 0; octave < 5; ++octave) {
    h += amplitude * (value_noise(x * frequency + 17.0f, z * frequency + 31.0f, octave) - 0.5f);
    amplitude *= 0.5f;
    frequency *= 2.0f;
  }
  // Taper to the floor along the open front, so that the terrain is a solid-looking hill, not a
  // sheet the camera can look under.
  const float front = std::min(1.0f, (z + 1.0f) * 6.0f);
  return std::clamp(h * front, 0.0f, 1.9f);
}

}  // namespace

std::optional<uint64_t> parse_terrain_triangles(std::string_view name) {
  constexpr std::string_view kPrefix = "terrain:";
  if (!name.starts_with(kPrefix)) return std::nullopt;
  std::string_view count = name.substr(kPrefix.size());
  uint64_t scale = 1;
  if (!count.empty() && (count.back() == 'k' || count.back() == 'K')) scale = 1000;
  if (!count.empty() && (count.back() == 'm' || count.back() == 'M')) scale = 1000000;
  if (scale != 1) count.remove_suffix(1);
  uint64_t value = 0;
  const auto [ptr, ec] = std::from_chars(count.data(), count.data() + count.size(), value);
  if (ec != std::errc() || ptr != count.data() + count.size() || count.empty()) return std::nullopt;
  if (value > kMaxTerrainTriangles / scale) return std::nullopt;
  value *= scale;
  if (value < 2) return std::nullopt;
  return value;
}

Scene make_terrain_scene(uint64_t triangles, const CornellOptions& options) {
  Scene scene = make_cornell_box(options);
  // Keep the room (the first 10 triangles), drop the blocks: the terrain takes their place.
  TriangleMesh room;
  for (size_t i = 0; i < 10; ++i) {
    room.add(scene.mesh.vertex(i, 0), scene.mesh.vertex(i, 1), scene.mesh.vertex(i, 2),
             scene.mesh.material()[i]);
  }
  const uint32_t material = static_cast<uint32_t>(scene.materials.size());
  scene.materials.push_back({kTerrainAlbedo});

  // An n x n grid of quads, two triangles each.
  const int n = std::max(1, static_cast<int>(std::lround(std::sqrt(triangles / 2.0))));
  const float inset = 0.999f;  // keep the terrain's border off the walls
  std::vector<glm::vec3> row0(n + 1), row1(n + 1);
  auto fill = [&](std::vector<glm::vec3>& row, int j) {
    const float z = inset * (-1.0f + 2.0f * static_cast<float>(j) / static_cast<float>(n));
    for (int i = 0; i <= n; ++i) {
      const float x = inset * (-1.0f + 2.0f * static_cast<float>(i) / static_cast<float>(n));
      row[i] = glm::vec3(x, 1.0f - terrain_height(x, z), z);  // world y points down
    }
  };
  room.reserve(10 + 2 * static_cast<size_t>(n) * n);
  fill(row0, 0);
  for (int j = 0; j < n; ++j) {
    fill(row1, j + 1);
    for (int i = 0; i < n; ++i) {
      const glm::vec3 &a = row0[i], &b = row0[i + 1], &c = row1[i], &d = row1[i + 1];
      // Wound so that the lab's normal, cross(e2, e1), points up (-y), into the room.
      room.add(a, c, b, material);
      room.add(b, c, d, material);
    }
    std::swap(row0, row1);
  }
  scene.mesh = std::move(room);
  return scene;
}

bool is_builtin_scene(std::string_view name) {
  return name == "cornell" || name == "cornell-area" || parse_terrain_triangles(name).has_value();
}

Scene make_builtin_scene(std::string_view name, const CornellOptions& options) {
  if (name == "cornell") return make_cornell_box(options);
  if (name == "cornell-area") return make_cornell_area(options);
  if (const std::optional<uint64_t> triangles = parse_terrain_triangles(name)) {
    return make_terrain_scene(*triangles, options);
  }
  throw Error(std::string(name), "unknown scene (use " + std::string(kBuiltinSceneHelp) + ")",
              ExitCode::kUsage);
}

}  // namespace tritrace
