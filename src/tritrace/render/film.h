// Film: per pixel, the sums of weighted radiance and of weights over the samples taken, plus the
// same sums of the AOVs (albedo and normal of the first non-specular hit, depth of the first hit)
// and the half buffer of the variance AOV (the sums over even sample indices), the inputs of
// denoisers. The image is the film resolved (sum / weight), never the other way round. Sums are
// kept unnormalised and added in the fixed order of render/sample_blocks.h, so that films of
// sample ranges or tiles rendered apart combine into exactly the film of one render.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <optional>
#include <string_view>
#include <vector>

#include "tritrace/image/exr.h"
#include "tritrace/image/image.h"
#include "tritrace/render/sample_blocks.h"

namespace tritrace {

// The arbitrary output variables a film can keep besides radiance.
struct AovSet {
  bool albedo = false;
  bool normal = false;
  bool depth = false;
  // The estimated variance of each pixel's mean, from the halves of its samples split by the
  // parity of their global sample index (AovSums::even).
  bool variance = false;
  // How many samples each pixel took (AovSums::samples): where adaptive sampling spent them.
  bool spp = false;
  bool any() const { return albedo || normal || depth || variance || spp; }
  bool operator==(const AovSet&) const = default;
};

// One sample's contribution to its pixel.
struct FilmSample {
  glm::vec3 radiance{0.0f};
  glm::vec3 albedo{0.0f};
  glm::vec3 normal{0.0f};
  float depth = 0.0f;
};

// The samples [first_sample(), end_sample()) of every pixel it holds, as the sums of the block tree
// (render/sample_blocks.h): one layer per node that is not yet paired, in sample order, plus a last
// layer for a partial block when end_sample() is not a multiple of 8. Each layer holds per pixel
// (sum of weight x radiance, sum of weights) and, when kept, the AOV sums. A one-process render,
// a viewer's frames and a merge of parts all build films this way, so their resolves agree bit for
// bit. first_sample() is a multiple of 8; samples are only ever appended at end_sample().
class Film {
 public:
  Film() = default;
  Film(int width, int height, AovSet aovs = {});

  int width() const { return width_; }
  int height() const { return height_; }
  const AovSet& aovs() const { return aovs_; }

  uint32_t first_sample() const { return first_; }
  uint32_t end_sample() const { return end_; }
  const std::vector<BlockNode>& nodes() const { return nodes_; }
  bool has_partial_block() const { return end_ % kSampleBlock != 0; }
  size_t layer_count() const { return nodes_.size() + (has_partial_block() ? 1 : 0); }

  // Sets the samples held and the nodes left unpaired (which must be what a BlockCounter leaves
  // for [first, end), checked), keeping the values of the first min(old, new) layers and zeroing
  // the others. Throws Error("film", ...) when first is not a multiple of 8 or the nodes do not
  // match.
  void set_layout(uint32_t first, uint32_t end, std::vector<BlockNode> nodes);
  // Makes sure at least `count` layers are allocated (a renderer writes the new layout's layers
  // while reading the old one's); the layout itself is unchanged.
  void reserve_layers(size_t count);

  // Layer k's sums, width x height pixels row by row; aov_sums is null when no AOV is kept.
  glm::vec4* sums(size_t layer) { return layers_[layer].data(); }
  const glm::vec4* sums(size_t layer) const { return layers_[layer].data(); }
  AovSums* aov_sums(size_t layer) { return aovs_.any() ? aov_layers_[layer].data() : nullptr; }
  const AovSums* aov_sums(size_t layer) const {
    return aovs_.any() ? aov_layers_[layer].data() : nullptr;
  }

  // Pixel (x, y)'s total: its layers added from the right (zero when the film holds no sample).
  glm::vec4 pixel_sums(int x, int y) const;
  AovSums pixel_aov_sums(int x, int y) const;
  glm::vec3 radiance_sum(int x, int y) const { return glm::vec3(pixel_sums(x, y)); }
  float weight_sum(int x, int y) const { return pixel_sums(x, y).w; }

  // The mean radiance per pixel (sum / weight; black where no sample landed).
  Image resolve() const;
  // The mean of an AOV per pixel, as an RGB image (depth in all three channels); empty when the
  // film does not keep it.
  Image resolve_albedo() const;
  Image resolve_normal() const;
  Image resolve_depth() const;
  // Per channel, the estimated variance of the pixel's mean (resolve()'s value): with m_e and m_o
  // the weighted means of the even and odd halves and W_e, W_o their weights (W = W_e + W_o),
  // (m_e - m_o)^2 W_e W_o / W^2, which for equal halves is the (m_e - m_o)^2 / 4 of the half-buffer
  // estimators (Rousselle et al. 2012; Bitterli et al. 2016, NFOR). Zero where a half is empty.
  // Empty when the film does not keep it.
  Image resolve_variance() const;
  // The samples each pixel took, in all three channels; empty when the film does not keep them.
  Image resolve_spp() const;
  // All five, each empty where not kept.
  AovImages resolve_aovs() const;

 private:
  size_t index(int x, int y) const { return static_cast<size_t>(y) * width_ + x; }
  template <typename Pick>
  Image resolve_aov(bool kept, Pick&& pick) const;

  int width_ = 0;
  int height_ = 0;
  AovSet aovs_;
  uint32_t first_ = 0;
  uint32_t end_ = 0;
  std::vector<BlockNode> nodes_;
  std::vector<std::vector<glm::vec4>> layers_;
  std::vector<std::vector<AovSums>> aov_layers_;
};

// The resolved pixel of a (radiance sum, weight sum): sum / weight, black for no weight. A weight
// of exactly 1 (one unit sample: the lab) divides to the sum bit for bit.
inline glm::vec3 resolve_pixel(glm::vec4 sums) {
  return sums.w != 0.0f ? glm::vec3(sums) / sums.w : glm::vec3(0.0f);
}

// Film::resolve_variance's estimate for one pixel, from its total (weight x radiance, weight) and
// the same sums over its even samples.
glm::vec3 half_buffer_variance(glm::vec4 total, glm::vec4 even);

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
