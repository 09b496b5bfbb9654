// CausticGuide: the directions along which light reaches surface points through specular surfaces
// (smooth glass, mirrors), learnt from a pre-pass of light paths ("photons"), as a density over
// directions at a point that bdpt's caustic strategy samples (docs/BDPT.md). Guiding camera paths
// by photons is Jensen's idea ("Importance driven path tracing using the photon map", EGWR 1995);
// here a point's density is a mixture of uniform cones, one about each photon direction stored in
// the point's cell of a uniform grid. It is an importance function only: what the strategy adds is
// weighted against the Bsdf's own sampling of the same paths, so any guide (even a poor one) leaves
// the image unbiased.
#pragma once

#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>

namespace tritrace {

// A light path's first non-specular vertex after one or more specular ones: where it is, the
// direction back towards the specular vertex it came from (unit) and that vertex's distance.
struct CausticPhoton {
  glm::vec3 p{0.0f};
  glm::vec3 w{0.0f, 0.0f, 1.0f};
  float distance = 0.0f;
};

class CausticGuide {
 public:
  // The photons a cell keeps: its first ones in the given order (the density needs a bounded
  // number of cones to evaluate; which ones it keeps does not change the image's expectation).
  static constexpr uint32_t kMaxPerCell = 64;

  // The photons a cell needs to guide (fewer: the cell has no guide). Caustics are dense where they
  // are bright; scattered photons (light reflected off glass, spread over a room) would send the
  // guide's rays into a weak caustic at every vertex near them.
  static constexpr uint32_t kMinPerCell = 8;

  CausticGuide() = default;
  // Bins `photons` into cubic cells of edge `cell` (> 0, finite), keeping the cells with at least
  // `min_per_cell` photons. Deterministic: a function of the photons' order and values.
  CausticGuide(std::span<const CausticPhoton> photons, float cell,
               uint32_t min_per_cell = kMinPerCell);

  // A cell's cones: `count` unit axes (0: no guide at this point) of half-angle theta, given as
  // one_minus_cos = 1 - cos(theta) (> 0), each cone sampled uniformly.
  struct Cell {
    const glm::vec3* axes = nullptr;
    uint32_t count = 0;
    float one_minus_cos = 0.0f;
  };
  // The cell holding point p (count 0 where it has no photon, or p is not finite).
  Cell cell(glm::vec3 p) const;

  // The mixture's solid-angle density at unit direction w: (1 / count) times the sum over the
  // cones holding w of 1 / (2 pi (1 - cos theta)).
  static float pdf(const Cell& c, glm::vec3 w);
  // A direction from the mixture: cone floor(u_pick * count), then uniform in it (u in [0, 1)^2).
  static glm::vec3 sample(const Cell& c, float u_pick, glm::vec2 u);

  bool empty() const { return cells_.empty(); }
  size_t cell_count() const { return cells_.size(); }
  size_t photon_count() const { return axes_.size(); }
  float cell_size() const { return cell_; }

 private:
  struct CellData {
    uint32_t first = 0, count = 0;
    float one_minus_cos = 0.0f;
  };
  uint64_t key(glm::vec3 p, bool& ok) const;

  float cell_ = 1.0f;
  float inverse_cell_ = 1.0f;
  // The kept photons' bounding box: a point outside it has no cell (no hash lookup).
  glm::vec3 lo_{0.0f}, hi_{-1.0f};
  std::unordered_map<uint64_t, uint32_t> index_;  // a cell's key -> cells_
  std::vector<CellData> cells_;
  std::vector<glm::vec3> axes_;
};

}  // namespace tritrace
