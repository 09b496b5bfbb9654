// Film: per pixel, the sums of weighted radiance and of weights over the samples taken, plus the
// light image of integrators that splat (bdpt's light tracing, SplatBuffer below), plus the
// same sums of the AOVs (albedo and normal of the first non-specular hit, depth of the first hit)
// and the half buffer of the variance AOV (the sums over even sample indices), the inputs of
// denoisers. The image is the film resolved (sum / weight), never the other way round. Sums are
// kept unnormalised and added in the fixed order of render/sample_blocks.h, so that films of
// sample ranges or tiles rendered apart combine into exactly the film of one render.
#pragma once

#include <atomic>
#include <cmath>
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

// The light image: contributions that land on other pixels than the sample's own (bdpt's light
// tracing to the camera, t = 1), summed per pixel and channel in 64-bit fixed point. Integer
// addition is associative, so the sums are the same bits whatever the order in which threads,
// tiles, passes, sample-range parts and MPI ranks add them: no ordering of the splats is needed,
// and concurrent adds are relaxed atomics. Each splat is rounded to a multiple of kSplatUnit
// stochastically (down or up with the probabilities that make the rounded value's expectation
// the splat itself), so the quantisation adds a little variance (at most kSplatUnit^2 / 4 per
// splat) and no bias. Sums wrap modulo 2^64 (well defined for unsigned integers), so even an
// intermediate overflow leaves the total right as long as the total fits.
class SplatBuffer {
 public:
  // 2^-28: the resolution (3.7e-9) is far below a float pixel value's rounding at the brightness
  // of anything visible, and a pixel's sum may reach 2^35 (3.4e10: a splat mean of 1e4 over 3e6
  // samples) before it wraps.
  static constexpr double kSplatUnit = 1.0 / 268435456.0;
  // A single splat is clamped to +-2^50 units (about 4e6) before it is rounded: larger values
  // would risk the total's range (none occurs in a converging estimate of a finite image).
  static constexpr double kMaxUnits = 1125899906842624.0;

  SplatBuffer() = default;
  SplatBuffer(int width, int height)
      : width_(width), height_(height), sums_(static_cast<size_t>(width) * height * 3, 0) {}

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return sums_.empty(); }

  // Adds `value` to pixel (x, y), rounded stochastically with u in [0, 1). Thread-safe; never
  // allocates. A non-finite channel adds nothing.
  void add(int x, int y, glm::vec3 value, float u) {
    uint64_t* p = sums_.data() + (static_cast<size_t>(y) * width_ + x) * 3;
    for (int c = 0; c < 3; ++c) {
      const double units = static_cast<double>(value[c]) / kSplatUnit;
      if (!(std::abs(units) < kMaxUnits)) continue;  // also NaN
      const double low = std::floor(units);
      const int64_t q = static_cast<int64_t>(low) + (units - low > static_cast<double>(u) ? 1 : 0);
      if (q != 0) {
        std::atomic_ref<uint64_t>(p[c]).fetch_add(static_cast<uint64_t>(q),
                                                  std::memory_order_relaxed);
      }
    }
  }
  // Adds another buffer of the same size (parts' light images).
  void add(const SplatBuffer& other) {
    for (size_t i = 0; i < sums_.size(); ++i) sums_[i] += other.sums_[i];
  }

  // Pixel (x, y)'s raw sums (3 channels, two's complement).
  const uint64_t* raw(int x, int y) const {
    return sums_.data() + (static_cast<size_t>(y) * width_ + x) * 3;
  }
  uint64_t* raw(int x, int y) { return sums_.data() + (static_cast<size_t>(y) * width_ + x) * 3; }
  std::vector<uint64_t>& data() { return sums_; }
  const std::vector<uint64_t>& data() const { return sums_; }

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<uint64_t> sums_;
};

// A pixel's resolved value with its light image: the mean of its own samples plus the light
// image's sum over the samples the pixel took, spp (every light subpath starts from one camera
// sample, so the light image's estimate divides by the light subpaths per pixel; with adaptive
// sampling each pass's splats are already scaled by its count ratio, so that the sum over the
// pixel's count is the sample-weighted mean of its passes' estimates; docs/BDPT.md). The one
// formula for Film::resolve and the renderer's direct-to-image path, so that both give the same
// bits.
inline glm::vec3 add_splats(glm::vec3 mean, const uint64_t* sums, uint32_t spp) {
  if (spp == 0) return mean;
  const double scale = SplatBuffer::kSplatUnit / static_cast<double>(spp);
  glm::vec3 out = mean;
  for (int c = 0; c < 3; ++c) {
    out[c] += static_cast<float>(static_cast<double>(static_cast<int64_t>(sums[c])) * scale);
  }
  return out;
}

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

  // The light image (SplatBuffer), kept only by films of integrators that splat: resolve() adds
  // it over the film's samples per pixel, end_sample() - first_sample().
  bool has_splats() const { return !splats_.empty(); }
  void enable_splats() {
    if (splats_.empty()) splats_ = SplatBuffer(width_, height_);
  }
  SplatBuffer& splats() { return splats_; }
  const SplatBuffer& splats() const { return splats_; }
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
  SplatBuffer splats_;
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
