// Film: per pixel, the sums of weighted radiance and of weights over the samples taken, plus the
// same sums of the first hit's albedo, normal and depth (AOVs, the inputs of denoisers). The image
// is the film resolved (sum / weight), never the other way round. Sums are kept unnormalised and
// added in sample order, so films of sample ranges or tiles rendered apart can be combined later.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <optional>
#include <string_view>
#include <vector>

#include "tritrace/image/image.h"

namespace tritrace {

// The arbitrary output variables a film can keep besides radiance.
struct AovSet {
  bool albedo = false;
  bool normal = false;
  bool depth = false;
  bool any() const { return albedo || normal || depth; }
};

// One sample's contribution to its pixel.
struct FilmSample {
  glm::vec3 radiance{0.0f};
  glm::vec3 albedo{0.0f};
  glm::vec3 normal{0.0f};
  float depth = 0.0f;
};

class Film {
 public:
  Film() = default;
  Film(int width, int height, AovSet aovs = {});

  int width() const { return width_; }
  int height() const { return height_; }
  const AovSet& aovs() const { return aovs_; }

  // Adds weight * sample to pixel (x, y)'s sums and weight to its weight. One thread per pixel at a
  // time (the renderer's tiles are disjoint).
  void add(int x, int y, const FilmSample& sample, float weight) {
    const size_t i = index(x, y);
    radiance_[i] += weight * sample.radiance;
    weight_[i] += weight;
    if (aovs_.albedo) albedo_[i] += weight * sample.albedo;
    if (aovs_.normal) normal_[i] += weight * sample.normal;
    if (aovs_.depth) depth_[i] += weight * sample.depth;
  }

  glm::vec3 radiance_sum(int x, int y) const { return radiance_[index(x, y)]; }
  float weight_sum(int x, int y) const { return weight_[index(x, y)]; }

  // The mean radiance per pixel (sum / weight; black where no sample landed).
  Image resolve() const;
  // The mean of an AOV per pixel, as an RGB image (depth in all three channels); empty when the
  // film does not keep it.
  Image resolve_albedo() const { return resolve_sums(albedo_); }
  Image resolve_normal() const { return resolve_sums(normal_); }
  Image resolve_depth() const;

 private:
  size_t index(int x, int y) const { return static_cast<size_t>(y) * width_ + x; }
  Image resolve_sums(const std::vector<glm::vec3>& sums) const;

  int width_ = 0;
  int height_ = 0;
  AovSet aovs_;
  std::vector<glm::vec3> radiance_;
  std::vector<float> weight_;
  std::vector<glm::vec3> albedo_, normal_;
  std::vector<float> depth_;
};

// The pixel filter, sampled rather than splatted (as pbrt-v4's film does): each sample lands in its
// own pixel at an offset drawn from the filter's distribution, weighted by filter / pdf. Tiles then
// never touch each other's pixels, and the image is the same for any tiling and thread count.
enum class FilterKind { kBox, kGaussian, kBlackmanHarris };

std::string_view filter_name(FilterKind kind);  // "box", "gaussian", "blackman-harris"
std::optional<FilterKind> parse_filter(std::string_view name);

class PixelFilter {
 public:
  explicit PixelFilter(FilterKind kind = FilterKind::kBox);

  struct Sample {
    float x, y;    // the sample's position relative to the pixel's top-left corner, in pixels
    float weight;  // filter value / pdf at that position
  };
  // u in [0, 1)^2. The box filter (one pixel wide) returns (u.x, u.y) with weight 1: the
  // position (x + u, y + v) of the camera sample.
  Sample sample(float ux, float uy) const;

  FilterKind kind() const { return kind_; }
  float radius() const { return radius_; }
  // The filter's value at an offset from the pixel centre, per axis (the filters are separable).
  float evaluate_1d(float offset) const;

 private:
  // Samples [-radius, radius] in proportion to |f| tabulated over kBins cells (piecewise
  // constant), returning the offset and pdf.
  float sample_1d(float u, float& pdf) const;

  static constexpr int kBins = 64;
  FilterKind kind_;
  float radius_ = 0.5f;
  std::vector<float> cdf_;  // kBins + 1 entries, cdf_[0] = 0, cdf_[kBins] = 1
  std::vector<float> pdf_;  // per cell, over the offset
};

}  // namespace tritrace
