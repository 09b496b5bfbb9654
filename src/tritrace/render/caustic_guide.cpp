#include "tritrace/render/caustic_guide.h"

#include <algorithm>
#include <cmath>

#include "tritrace/math/random.h"
#include "tritrace/math/sampling.h"

namespace tritrace {
namespace {

// The cones' half-angle bounds: wide enough to matter in floats, narrow enough to stay a guide.
constexpr double kMinAngle = 1e-3;
constexpr double kMaxAngle = 0.5;

}  // namespace

uint64_t CausticGuide::key(glm::vec3 p, bool& ok) const {
  ok = std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
  if (!ok) return 0;
  // Cells far outside any scene's range share keys through the clamp; a shared key only merges
  // two cells' cones (the density stays one density: the image's expectation does not change).
  const auto coordinate = [this](float x) {
    const double c = std::floor(static_cast<double>(x) * static_cast<double>(inverse_cell_));
    return static_cast<int64_t>(std::clamp(c, -0x1p60, 0x1p60));
  };
  return hash_words(coordinate(p.x), coordinate(p.y), coordinate(p.z));
}

CausticGuide::CausticGuide(std::span<const CausticPhoton> photons, float cell,
                           uint32_t min_per_cell)
    : cell_(cell), inverse_cell_(1.0f / cell) {
  // The photons of each cell, in the given order, at most kMaxPerCell.
  std::vector<std::vector<const CausticPhoton*>> members;
  for (const CausticPhoton& photon : photons) {
    bool ok = false;
    const uint64_t k = key(photon.p, ok);
    if (!ok) continue;
    const auto [it, added] = index_.try_emplace(k, static_cast<uint32_t>(members.size()));
    if (added) members.emplace_back();
    std::vector<const CausticPhoton*>& list = members[it->second];
    if (list.size() < kMaxPerCell) list.push_back(&photon);
  }
  // The cells kept, renumbered in their order.
  std::vector<uint32_t> renumbered(members.size(), UINT32_MAX);
  for (size_t c = 0; c < members.size(); ++c) {
    if (members[c].size() >= std::max<uint32_t>(1, min_per_cell)) {
      renumbered[c] = static_cast<uint32_t>(cells_.size());
      cells_.emplace_back();
    }
  }
  for (auto it = index_.begin(); it != index_.end();) {
    const uint32_t c = renumbered[it->second];
    if (c == UINT32_MAX) {
      it = index_.erase(it);
    } else {
      (it++)->second = c;
    }
  }
  for (size_t c = 0; c < members.size(); ++c) {
    if (renumbered[c] == UINT32_MAX) continue;
    const std::vector<const CausticPhoton*>& list = members[c];
    CellData& data = cells_[renumbered[c]];
    for (const CausticPhoton* photon : list) {
      if (axes_.empty() && photon == list.front()) lo_ = hi_ = photon->p;
      lo_ = glm::min(lo_, photon->p);
      hi_ = glm::max(hi_, photon->p);
    }
    data.first = static_cast<uint32_t>(axes_.size());
    data.count = static_cast<uint32_t>(list.size());
    // The half-angle: half the photons' RMS angle about their mean direction (the cones then
    // overlap across the spread of directions the light arrives from), and at least the angle
    // a cell subtends from the median photon's specular vertex (a point elsewhere in the cell sees
    // that vertex that much off the photon's direction).
    glm::dvec3 sum(0.0);
    std::vector<double> distances;
    for (const CausticPhoton* photon : list) {
      sum += glm::dvec3(photon->w);
      distances.push_back(static_cast<double>(photon->distance));
      axes_.push_back(photon->w);
    }
    const double length = glm::length(sum);
    const glm::dvec3 mean = length > 0.0 ? sum / length : glm::dvec3(0.0, 0.0, 1.0);
    double square = 0.0;
    for (const CausticPhoton* photon : list) {
      const double a = std::acos(std::clamp(glm::dot(mean, glm::dvec3(photon->w)), -1.0, 1.0));
      square += a * a;
    }
    const double rms = std::sqrt(square / static_cast<double>(list.size()));
    std::nth_element(distances.begin(), distances.begin() + distances.size() / 2, distances.end());
    const double median = distances[distances.size() / 2];
    const double parallax = median > 0.0 ? static_cast<double>(cell) / median : kMaxAngle;
    const double theta = std::clamp(std::max(0.5 * rms, parallax), kMinAngle, kMaxAngle);
    // 1 - cos(theta) without cancellation.
    const double half = std::sin(0.5 * theta);
    data.one_minus_cos = static_cast<float>(2.0 * half * half);
  }
}

CausticGuide::Cell CausticGuide::cell(glm::vec3 p) const {
  if (cells_.empty()) return {};
  // Outside the photons' box by more than a cell (two, for rounding): no photon shares its cell.
  // (NaN passes to the key, which rejects it.)
  const float margin = 2.0f * cell_;
  if (p.x < lo_.x - margin || p.y < lo_.y - margin || p.z < lo_.z - margin ||
      p.x > hi_.x + margin || p.y > hi_.y + margin || p.z > hi_.z + margin) {
    return {};
  }
  bool ok = false;
  const uint64_t k = key(p, ok);
  if (!ok) return {};
  const auto it = index_.find(k);
  if (it == index_.end()) return {};
  const CellData& data = cells_[it->second];
  return {axes_.data() + data.first, data.count, data.one_minus_cos};
}

float CausticGuide::pdf(const Cell& c, glm::vec3 w) {
  if (c.count == 0) return 0.0f;
  // Inside a cone (half-angle at most 0.5): in front of the axis, and the squared sine of the angle
  // to it, |axis x w|^2 (accurate in floats for small angles, where 1 - cos is not), at most
  // sin^2(theta) = (1 - cos)(1 + cos). The sampled directions' construction agrees up to rounding
  // (a relative 1e-5 of slack at the rim, of measure ~0).
  const float sin2 = c.one_minus_cos * (2.0f - c.one_minus_cos) * (1.0f + 1e-5f);
  uint32_t inside = 0;
  for (uint32_t i = 0; i < c.count; ++i) {
    const glm::vec3 cr = glm::cross(c.axes[i], w);
    inside += glm::dot(c.axes[i], w) > 0.0f && glm::dot(cr, cr) <= sin2 ? 1 : 0;
  }
  if (inside == 0) return 0.0f;
  return static_cast<float>(inside) /
         (static_cast<float>(c.count) * (2.0f * kPi * c.one_minus_cos));
}

glm::vec3 CausticGuide::sample(const Cell& c, float u_pick, glm::vec2 u) {
  const auto i = std::min(c.count - 1, static_cast<uint32_t>(u_pick * static_cast<float>(c.count)));
  // Uniform in the cap: 1 - cos of the angle uniform in [0, 1 - cos(theta)).
  const float t = u.x * c.one_minus_cos;
  const float sin_angle = std::sqrt(std::max(0.0f, t * (2.0f - t)));
  const float phi = 2.0f * kPi * u.y;
  const glm::vec3 local(sin_angle * std::cos(phi), sin_angle * std::sin(phi), 1.0f - t);
  return glm::normalize(Frame::from_normal(c.axes[i]).to_world(local));
}

}  // namespace tritrace
