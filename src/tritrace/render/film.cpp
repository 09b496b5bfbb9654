// Film layouts, resolution (the block tree's layers added from the right) and the pixel filters
// (box, Gaussian, Blackman-Harris) with their sampling.
#include "tritrace/render/film.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "tritrace/error.h"

namespace tritrace {

Film::Film(int width, int height, AovSet aovs) : width_(width), height_(height), aovs_(aovs) {}

void Film::reserve_layers(size_t count) {
  const size_t n = static_cast<size_t>(width_) * static_cast<size_t>(height_);
  while (layers_.size() < count) {
    layers_.emplace_back(n, glm::vec4(0.0f));
    if (aovs_.any()) aov_layers_.emplace_back(n);
  }
}

void Film::set_layout(uint32_t first, uint32_t end, std::vector<BlockNode> nodes) {
  if (first % kSampleBlock != 0 || end < first) {
    throw Error("film", "samples [" + std::to_string(first) + ", " + std::to_string(end) +
                            ") do not start at a multiple of " + std::to_string(kSampleBlock));
  }
  BlockCounter counter;
  counter.push_blocks(first / kSampleBlock, end / kSampleBlock);
  if (!std::equal(nodes.begin(), nodes.end(), counter.nodes().begin(), counter.nodes().end())) {
    throw Error("film", "the block sums do not match samples [" + std::to_string(first) + ", " +
                            std::to_string(end) + ")");
  }
  first_ = first;
  end_ = end;
  nodes_ = std::move(nodes);
  const size_t count = layer_count();
  reserve_layers(count);
  layers_.resize(count);
  if (aovs_.any()) aov_layers_.resize(count);
}

glm::vec4 Film::pixel_sums(int x, int y) const {
  const size_t n = layers_.size();
  if (n == 0) return glm::vec4(0.0f);
  const size_t i = index(x, y);
  glm::vec4 sum = layers_[n - 1][i];
  for (size_t k = n - 1; k-- > 0;) sum = layers_[k][i] + sum;
  return sum;
}

AovSums Film::pixel_aov_sums(int x, int y) const {
  const size_t n = aov_layers_.size();
  if (n == 0) return {};
  const size_t i = index(x, y);
  AovSums sum = aov_layers_[n - 1][i];
  for (size_t k = n - 1; k-- > 0;) sum = aov_layers_[k][i] + sum;
  return sum;
}

Image Film::resolve() const {
  Image image(width_, height_);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) image.at(x, y) = resolve_pixel(pixel_sums(x, y));
  }
  if (has_splats()) {
    // The pixel's own sample count: its weight, as splatting needs the box filter (weight 1 per
    // sample). That is end - first for every pixel unless adaptive sampling stopped it early.
    for (int y = 0; y < height_; ++y) {
      for (int x = 0; x < width_; ++x) {
        const auto samples = static_cast<uint32_t>(pixel_sums(x, y).w);
        image.at(x, y) = add_splats(image.at(x, y), splats_.raw(x, y), samples);
      }
    }
  }
  return image;
}

template <typename Pick>
Image Film::resolve_aov(bool kept, Pick&& pick) const {
  if (!kept) return {};
  Image image(width_, height_);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const float w = pixel_sums(x, y).w;
      image.at(x, y) = w != 0.0f ? pick(pixel_aov_sums(x, y)) / w : glm::vec3(0.0f);
    }
  }
  return image;
}

Image Film::resolve_albedo() const {
  return resolve_aov(aovs_.albedo, [](const AovSums& s) { return s.albedo; });
}
Image Film::resolve_normal() const {
  return resolve_aov(aovs_.normal, [](const AovSums& s) { return s.normal; });
}
Image Film::resolve_depth() const {
  return resolve_aov(aovs_.depth, [](const AovSums& s) { return glm::vec3(s.depth); });
}

Image Film::resolve_variance() const {
  if (!aovs_.variance) return {};
  Image image(width_, height_);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      image.at(x, y) = half_buffer_variance(pixel_sums(x, y), pixel_aov_sums(x, y).even);
    }
  }
  return image;
}

Image Film::resolve_spp() const {
  if (!aovs_.spp) return {};
  Image image(width_, height_);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) image.at(x, y) = glm::vec3(pixel_aov_sums(x, y).samples);
  }
  return image;
}

AovImages Film::resolve_aovs() const {
  return {resolve_albedo(), resolve_normal(), resolve_depth(), resolve_variance(), resolve_spp()};
}

glm::vec3 half_buffer_variance(glm::vec4 total, glm::vec4 even) {
  // In double: the odd half is a difference, and so is m_e - m_o.
  const double w = total.w, w_even = even.w, w_odd = w - w_even;
  if (!(w_even > 0.0 && w_odd > 0.0)) return glm::vec3(0.0f);
  const double scale = w_even * w_odd / (w * w);
  glm::vec3 v;
  for (int c = 0; c < 3; ++c) {
    const double m_even = even[c] / w_even;
    const double m_odd = (static_cast<double>(total[c]) - even[c]) / w_odd;
    const double d = m_even - m_odd;
    v[c] = static_cast<float>(d * d * scale);
  }
  return v;
}

std::string_view filter_name(FilterKind kind) {
  switch (kind) {
    case FilterKind::kBox:
      return "box";
    case FilterKind::kGaussian:
      return "gaussian";
    case FilterKind::kBlackmanHarris:
      return "blackman-harris";
  }
  return "box";
}

std::optional<FilterKind> parse_filter(std::string_view name) {
  for (FilterKind k : {FilterKind::kBox, FilterKind::kGaussian, FilterKind::kBlackmanHarris}) {
    if (filter_name(k) == name) return k;
  }
  return std::nullopt;
}

namespace {
// Radii in pixels: the Gaussian's and Blackman-Harris's as pbrt-v4's defaults (1.5 pixels).
constexpr float kGaussianRadius = 1.5f;
constexpr float kGaussianSigma = 0.5f;
constexpr float kBlackmanHarrisRadius = 1.5f;

float gaussian(float x) {
  return std::exp(-x * x / (2.0f * kGaussianSigma * kGaussianSigma));
}
}  // namespace

PixelFilter::PixelFilter(FilterKind kind) : kind_(kind) {
  if (kind == FilterKind::kBox) return;
  radius_ = kind == FilterKind::kGaussian ? kGaussianRadius : kBlackmanHarrisRadius;
  // Cell masses by the midpoint rule on a fine grid inside each cell.
  std::vector<double> mass(kBins);
  const double cell = 2.0 * radius_ / kBins;
  for (int i = 0; i < kBins; ++i) {
    double sum = 0.0;
    constexpr int kSteps = 32;
    for (int k = 0; k < kSteps; ++k) {
      const double x = -radius_ + (i + (k + 0.5) / kSteps) * cell;
      sum += std::abs(evaluate_1d(static_cast<float>(x)));
    }
    mass[static_cast<size_t>(i)] = sum / kSteps * cell;
  }
  double total = 0.0;
  for (double m : mass) total += m;
  cdf_.assign(kBins + 1, 0.0f);
  pdf_.assign(kBins, 0.0f);
  double running = 0.0;
  for (int i = 0; i < kBins; ++i) {
    running += mass[static_cast<size_t>(i)];
    cdf_[static_cast<size_t>(i) + 1] = static_cast<float>(running / total);
    pdf_[static_cast<size_t>(i)] = static_cast<float>(mass[static_cast<size_t>(i)] / total / cell);
  }
  cdf_[kBins] = 1.0f;
}

float PixelFilter::evaluate_1d(float offset) const {
  const float x = std::abs(offset);
  if (x > radius_) return 0.0f;
  switch (kind_) {
    case FilterKind::kBox:
      return 1.0f;
    case FilterKind::kGaussian:
      // Shifted to reach 0 at the radius, as pbrt does, so the filter has no step there.
      return std::max(0.0f, gaussian(x) - gaussian(radius_));
    case FilterKind::kBlackmanHarris: {
      // Harris, "On the use of windows for harmonic analysis with the discrete Fourier
      // transform", Proc. IEEE 66(1), 1978: the 4-term window over [-radius, radius].
      const double t = (static_cast<double>(offset) + radius_) / (2.0 * radius_);
      constexpr double a0 = 0.35875, a1 = 0.48829, a2 = 0.14128, a3 = 0.01168;
      const double w = 2.0 * std::numbers::pi * t;
      return static_cast<float>(a0 - a1 * std::cos(w) + a2 * std::cos(2.0 * w) -
                                a3 * std::cos(3.0 * w));
    }
  }
  return 0.0f;
}

float PixelFilter::sample_1d(float u, float& pdf) const {
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);
  const int i = std::clamp(static_cast<int>(it - cdf_.begin()) - 1, 0, kBins - 1);
  const float lo = cdf_[static_cast<size_t>(i)], hi = cdf_[static_cast<size_t>(i) + 1];
  const float within = hi > lo ? std::clamp((u - lo) / (hi - lo), 0.0f, 1.0f) : 0.5f;
  const float cell = 2.0f * radius_ / kBins;
  pdf = pdf_[static_cast<size_t>(i)];
  return -radius_ + (static_cast<float>(i) + within) * cell;
}

PixelFilter::Sample PixelFilter::sample(float ux, float uy) const {
  if (kind_ == FilterKind::kBox) return {ux, uy, 1.0f};
  float px = 0.0f, py = 0.0f;
  const float dx = sample_1d(ux, px), dy = sample_1d(uy, py);
  const float weight =
      px > 0.0f && py > 0.0f ? evaluate_1d(dx) * evaluate_1d(dy) / (px * py) : 0.0f;
  return {0.5f + dx, 0.5f + dy, weight};
}

}  // namespace tritrace
