// The joint non-local-means denoiser (denoiser.h): the inputs are copied into padded planar float
// arrays, the image is cut into fixed tiles, and each tile loops over the neighbour offsets with
// contiguous per-row inner loops that the compiler vectorises.
#include "tritrace/denoise/denoiser.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/parallel.h"

namespace tritrace {
namespace {

// The colour term's epsilon of Rousselle et al. 2012: keeps the distance finite where both
// variances are 0 (then any difference makes the neighbour's weight vanish).
constexpr float kColourEpsilon = 1e-10f;
// Tiles are fixed by the image size alone; each pixel's result does not depend on them either.
constexpr int kTileSize = 64;
constexpr int kMaxTileSize = 256;  // the per-row feature distances live on the stack
static_assert(kTileSize <= kMaxTileSize);

// e^-x for x >= 0 (larger than 80 and NaN count as 80, e^-80 ~ 1.8e-35), to a relative error
// below 4e-6: 2^k times the Taylor polynomial of e^f, where k is log2(e^-x) rounded to the nearest
// integer (by adding 1.5 * 2^23, whose float has no bits below 1) and f the rest times ln 2.
// Written without branches, conversions or library calls so that the loops over a row
// vectorise (a float-to-int conversion keeps GCC 12 from vectorising them); every pixel computes
// it the same way, so the results stay the same for any thread count.
inline float exp_neg(float x) {
  x = x < 80.0f ? x : 80.0f;
  const float t = x * -1.44269504f;  // log2(e^-x), in [-115.5, 0]
  const float shifted = t + 12582912.0f;
  const float f = (t - (shifted - 12582912.0f)) * 0.693147181f;  // in [-0.35, 0.35]
  const int32_t k = std::bit_cast<int32_t>(shifted) - 0x4B400000;
  float p = 1.0f / 5040.0f;
  p = p * f + 1.0f / 720.0f;
  p = p * f + 1.0f / 120.0f;
  p = p * f + 1.0f / 24.0f;
  p = p * f + 1.0f / 6.0f;
  p = p * f + 0.5f;
  p = p * f + 1.0f;
  p = p * f + 1.0f;
  return p * std::bit_cast<float>(static_cast<uint32_t>(k + 127) << 23);
}

// distance[i] becomes the weight e^-max(distance[i], feature[i]).
void weights(float* __restrict distance, const float* __restrict feature, int n) {
  for (int i = 0; i < n; ++i) {
    const float d = distance[i] > feature[i] ? distance[i] : feature[i];
    distance[i] = exp_neg(d);
  }
}

// The weighted sum of the neighbours' differences from the pixel's own value: equal neighbours
// add exactly nothing (a constant image keeps its bits) and large values lose no precision.
void accumulate(const float* __restrict weight, const float* __restrict neighbour,
                const float* __restrict own, float* __restrict sum, int n) {
  for (int i = 0; i < n; ++i) sum[i] += weight[i] * (neighbour[i] - own[i]);
}

// One float channel of the image with a border of `margin` pixels on each side holding the
// nearest edge pixel's value (clamp to edge).
class Plane {
 public:
  Plane(int width, int height, int margin)
      : width_(width),
        height_(height),
        margin_(margin),
        stride_(width + 2 * margin),
        values_(static_cast<size_t>(stride_) * (height + 2 * margin)) {}

  float& at(int x, int y) { return values_[index(x, y)]; }
  float at(int x, int y) const { return values_[index(x, y)]; }
  const float* row(int x, int y) const { return values_.data() + index(x, y); }
  int stride() const { return stride_; }

  // Copies the edge pixels outwards into the border.
  void fill_border() {
    for (int y = 0; y < height_; ++y) {
      for (int x = -margin_; x < 0; ++x) at(x, y) = at(0, y);
      for (int x = width_; x < width_ + margin_; ++x) at(x, y) = at(width_ - 1, y);
    }
    for (int y = -margin_; y < 0; ++y) {
      std::copy_n(row(-margin_, 0), stride_, &at(-margin_, y));
    }
    for (int y = height_; y < height_ + margin_; ++y) {
      std::copy_n(row(-margin_, height_ - 1), stride_, &at(-margin_, y));
    }
  }

 private:
  size_t index(int x, int y) const {
    return static_cast<size_t>(y + margin_) * stride_ + static_cast<size_t>(x + margin_);
  }
  int width_, height_, margin_, stride_;
  std::vector<float> values_;
};

void check_size(const Image& image, const Image& colour, const char* name) {
  if (image.width() != colour.width() || image.height() != colour.height()) {
    throw Error("denoise", std::string(name) + " is " + std::to_string(image.width()) + " x " +
                               std::to_string(image.height()) + ", the colour " +
                               std::to_string(colour.width()) + " x " +
                               std::to_string(colour.height()));
  }
}

void check_image_finite(const Image& image, const char* name) {
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const glm::vec3& v = image.at(x, y);
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) {
        throw Error("denoise", std::string(name) + " is not finite at pixel (" + std::to_string(x) +
                                   ", " + std::to_string(y) + ")");
      }
    }
  }
}

// The slope of the two one-sided differences that agree in sign, the smaller one (0 when they
// disagree): at a pixel beside a depth edge it is the slope of the pixel's own surface.
float minmod(float backward, float forward) {
  if (backward * forward <= 0.0f) return 0.0f;
  return std::abs(backward) < std::abs(forward) ? backward : forward;
}

// The filter's inputs, planar and padded: the demodulated colour and its variance, the
// features, and the per-pixel gradient of inverse depth.
struct Planes {
  std::array<Plane, 3> colour, variance, albedo, normal;
  Plane inverse_depth, depth_dx, depth_dy;
  std::vector<glm::vec3> modulation;  // what the filtered colour is multiplied by (unpadded)
};

// What the colour distance compares: the noisy colour and its variance in the first pass, the
// first pass's result and its variance in the second.
struct Guide {
  const std::array<Plane, 3>& colour;
  const std::array<Plane, 3>& variance;
  float strength;  // k of the colour distance
};

// A pass's result, demodulated and unpadded: the filtered colour per channel, and per pixel the
// factor sum(w^2) / (sum w)^2 by which averaging reduced the variance of independent neighbours.
struct PassResult {
  std::array<std::vector<float>, 3> colour;
  std::vector<float> variance_factor;
  std::vector<float> inverse_weight;  // 1 / sum w: the derivative of the result by its own input
};

Image box_mean(const Image& image, int radius);

// Raises the demodulated variance to at least `floor` times the variance estimated from the
// demodulated colour's neighbourhood, as estimate_variance_spatially() estimates it: (9/8) times
// the mean over 5 x 5 pixels of the squared residual from the 3 x 3 mean, but to at most `limit`
// times itself. The half-buffer variance of a pixel that a light's edge crosses is 0 (no sample
// of either half hit the light) or smoothed away among its neighbours (one half's single light
// sample among pixels whose variance is 0), so the filter took such a pixel's 16-sample coverage
// of the light as exact; the residual sees it.
void floor_variance(Planes& p, int w, int h, float floor, float limit) {
  Image u(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      u.at(x, y) = glm::vec3(p.colour[0].at(x, y), p.colour[1].at(x, y), p.colour[2].at(x, y));
    }
  }
  const Image mean = box_mean(u, 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const glm::vec3 d = u.at(x, y) - mean.at(x, y);
      u.at(x, y) = d * d;
    }
  }
  const Image spatial = box_mean(u, 2);
  const float scale = floor * (9.0f / 8.0f);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int k = 0; k < 3; ++k) {
        float& v = p.variance[k].at(x, y);
        v = std::max(v, std::min(scale * spatial.at(x, y)[k], limit * v));
      }
    }
  }
}

Planes make_planes(const Image& colour, const Image& variance, const DenoiseFeatures& features,
                   const DenoiseOptions& options, int margin) {
  const int w = colour.width(), h = colour.height();
  auto planes3 = [&] {
    return std::array<Plane, 3>{Plane(w, h, margin), Plane(w, h, margin), Plane(w, h, margin)};
  };
  Planes p{planes3(),           planes3(),
           planes3(),           planes3(),
           Plane(w, h, margin), Plane(w, h, margin),
           Plane(w, h, margin), std::vector<glm::vec3>(static_cast<size_t>(w) * h)};
  parallel::for_range(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        const glm::vec3 a = features.albedo.at(x, y);
        const glm::vec3 m = options.demodulate_albedo ? a + kAlbedoEpsilon : glm::vec3(1.0f);
        p.modulation[static_cast<size_t>(y) * w + x] = m;
        const float z = features.depth.at(x, y).x;
        p.inverse_depth.at(x, y) = z > 0.0f ? 1.0f / z : 0.0f;
        for (int k = 0; k < 3; ++k) {
          p.colour[k].at(x, y) = colour.at(x, y)[k] / m[k];
          p.variance[k].at(x, y) = std::max(variance.at(x, y)[k], 0.0f) / (m[k] * m[k]);
          p.albedo[k].at(x, y) = a[k] + kAlbedoEpsilon;
          p.normal[k].at(x, y) = features.normal.at(x, y)[k];
        }
      }
    }
  });
  if (options.spatial_variance_floor > 0.0f && options.spatial_variance_floor_limit > 1.0f) {
    floor_variance(p, w, h, options.spatial_variance_floor, options.spatial_variance_floor_limit);
  }
  // The gradient needs the whole inverse-depth plane, so it is a second pass.
  parallel::for_range(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& rows) {
    const Plane& z = p.inverse_depth;
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        const float c = z.at(x, y);
        const float left = x > 0 ? c - z.at(x - 1, y) : z.at(x + 1 < w ? x + 1 : x, y) - c;
        const float right = x + 1 < w ? z.at(x + 1, y) - c : left;
        const float up = y > 0 ? c - z.at(x, y - 1) : z.at(x, y + 1 < h ? y + 1 : y) - c;
        const float down = y + 1 < h ? z.at(x, y + 1) - c : up;
        p.depth_dx.at(x, y) = minmod(left, right);
        p.depth_dy.at(x, y) = minmod(up, down);
      }
    }
  });
  for (auto* group : {&p.colour, &p.variance, &p.albedo, &p.normal}) {
    for (Plane& plane : *group) plane.fill_border();
  }
  p.inverse_depth.fill_border();
  p.depth_dx.fill_border();
  p.depth_dy.fill_border();
  return p;
}

// Filters the pixels [x0, x1) x [y0, y1) into `out`: the demodulated colour's weighted means,
// with weights from the distances between `guide`'s patches and the features, and per pixel
// sum(w^2) / (sum w)^2 and 1 / sum w.
void filter_tile(const Planes& p, const Guide& guide, const DenoiseOptions& options, int width,
                 int height, int x0, int x1, int y0, int y1, PassResult& out) {
  const int r = options.search_radius;
  const int f = options.patch_radius;
  const int tw = x1 - x0, th = y1 - y0;
  const int ew = tw + 2 * f, eh = th + 2 * f;  // the patch-distance region
  const bool use_colour = guide.strength > 0.0f;
  const float k2 = guide.strength * guide.strength;
  const float patch_norm = 1.0f / (3.0f * static_cast<float>((2 * f + 1) * (2 * f + 1)));
  const bool use_albedo = options.albedo_scale > 0.0f;
  const bool use_normal = options.normal_scale > 0.0f;
  const bool use_depth = options.depth_scale > 0.0f;
  const float inv_a2 = use_albedo ? 1.0f / (options.albedo_scale * options.albedo_scale) : 0.0f;
  const bool use_relative_albedo = options.albedo_relative_scale > 0.0f;
  const float inv_r2 = use_relative_albedo
                           ? 1.0f / (options.albedo_relative_scale * options.albedo_relative_scale)
                           : 0.0f;
  const float inv_n2 = use_normal ? 1.0f / (options.normal_scale * options.normal_scale) : 0.0f;
  const float z2 = options.depth_scale * options.depth_scale;

  std::vector<float> e(static_cast<size_t>(ew) * eh);     // per-pixel colour distance
  std::vector<float> hsum(static_cast<size_t>(tw) * eh);  // summed along rows of the patch
  std::vector<float> dist(static_cast<size_t>(tw));       // one row's patch distance
  std::array<std::vector<float>, 3> acc;
  for (auto& a : acc) a.assign(static_cast<size_t>(tw) * th, 0.0f);
  std::vector<float> acc_w(static_cast<size_t>(tw) * th, 0.0f);
  std::vector<float> acc_w2(static_cast<size_t>(tw) * th, 0.0f);
  std::array<float, kMaxTileSize> feature{};  // one row's feature distances

  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      // The rows and columns of the tile whose neighbour at (dx, dy) is inside the image.
      const int qx0 = std::max(x0, -dx), qx1 = std::min(x1, width - dx);
      const int qy0 = std::max(y0, -dy), qy1 = std::min(y1, height - dy);
      if (qx0 >= qx1 || qy0 >= qy1) continue;
      if (use_colour) {
        // Rousselle et al. 2012, eq. 4: ((u_p - u_q)^2 - (var_p + min(var_p, var_q))) /
        // (eps + k^2 (var_p + var_q)), summed over the channels; the subtraction cancels the
        // expected squared difference that noise alone makes.
        for (int j = 0; j < eh; ++j) {
          float* row = e.data() + static_cast<size_t>(j) * ew;
          const int y = y0 - f + j;
          for (int i = 0; i < ew; ++i) row[i] = 0.0f;
          for (int k = 0; k < 3; ++k) {
            const float* up = guide.colour[k].row(x0 - f, y);
            const float* uq = guide.colour[k].row(x0 - f + dx, y + dy);
            const float* vp = guide.variance[k].row(x0 - f, y);
            const float* vq = guide.variance[k].row(x0 - f + dx, y + dy);
            for (int i = 0; i < ew; ++i) {
              const float d = up[i] - uq[i];
              const float vmin = vp[i] < vq[i] ? vp[i] : vq[i];
              row[i] += (d * d - (vp[i] + vmin)) / (kColourEpsilon + k2 * (vp[i] + vq[i]));
            }
          }
        }
        for (int j = 0; j < eh; ++j) {
          const float* erow = e.data() + static_cast<size_t>(j) * ew;
          float* hrow = hsum.data() + static_cast<size_t>(j) * tw;
          for (int i = 0; i < tw; ++i) hrow[i] = erow[i];
          for (int t = 1; t <= 2 * f; ++t) {
            for (int i = 0; i < tw; ++i) hrow[i] += erow[i + t];
          }
        }
      }
      for (int y = qy0; y < qy1; ++y) {
        const int j = y - y0;
        if (use_colour) {
          for (int i = 0; i < tw; ++i) dist[i] = 0.0f;
          for (int t = 0; t <= 2 * f; ++t) {
            const float* hrow = hsum.data() + static_cast<size_t>(j + t) * tw;
            for (int i = 0; i < tw; ++i) dist[i] += hrow[i];
          }
        }
        const int n = qx1 - qx0;
        const int i0 = qx0 - x0;
        float* dst = dist.data() + i0;
        // The feature distances of Rousselle et al. 2013, without their variance terms (the
        // features are taken as exact).
        for (int i = 0; i < n; ++i) {
          const float colour_d = use_colour ? dst[i] * patch_norm : 0.0f;
          dst[i] = colour_d > 0.0f ? colour_d : 0.0f;
        }
        for (int i = 0; i < n; ++i) feature[i] = 0.0f;
        if (use_albedo || use_relative_albedo) {
          for (int k = 0; k < 3; ++k) {
            const float* ap = p.albedo[k].row(qx0, y);
            const float* aq = p.albedo[k].row(qx0 + dx, y + dy);
            for (int i = 0; i < n; ++i) {
              const float d = ap[i] - aq[i];
              const float larger = ap[i] > aq[i] ? ap[i] : aq[i];
              feature[i] += d * d * (inv_a2 + inv_r2 / (larger * larger));
            }
          }
        }
        if (use_normal) {
          for (int k = 0; k < 3; ++k) {
            const float* np = p.normal[k].row(qx0, y);
            const float* nq = p.normal[k].row(qx0 + dx, y + dy);
            for (int i = 0; i < n; ++i) {
              const float d = np[i] - nq[i];
              feature[i] += d * d * inv_n2;
            }
          }
        }
        if (use_depth) {
          const float* zp = p.inverse_depth.row(qx0, y);
          const float* zq = p.inverse_depth.row(qx0 + dx, y + dy);
          const float* gx = p.depth_dx.row(qx0, y);
          const float* gy = p.depth_dy.row(qx0, y);
          const float fdx = static_cast<float>(dx), fdy = static_cast<float>(dy);
          for (int i = 0; i < n; ++i) {
            // The planar prediction of the neighbour's inverse depth (exact for a plane seen in
            // perspective), its error relative to the nearer of the two.
            const float residual = zq[i] - (zp[i] + (gx[i] * fdx + gy[i] * fdy));
            const float scale = zp[i] > zq[i] ? zp[i] : zq[i];
            const float ratio = residual * residual / (z2 * scale * scale + 1e-30f);
            feature[i] += residual == 0.0f ? 0.0f : ratio;
          }
        }
        float* ar = acc[0].data() + static_cast<size_t>(j) * tw + i0;
        float* ag = acc[1].data() + static_cast<size_t>(j) * tw + i0;
        float* ab = acc[2].data() + static_cast<size_t>(j) * tw + i0;
        float* aw = acc_w.data() + static_cast<size_t>(j) * tw + i0;
        float* aw2 = acc_w2.data() + static_cast<size_t>(j) * tw + i0;
        const float* ur = p.colour[0].row(qx0 + dx, y + dy);
        const float* ug = p.colour[1].row(qx0 + dx, y + dy);
        const float* ub = p.colour[2].row(qx0 + dx, y + dy);
        const float* pr = p.colour[0].row(qx0, y);
        const float* pg = p.colour[1].row(qx0, y);
        const float* pb = p.colour[2].row(qx0, y);
        // min(w_colour, w_features) of Rousselle et al. 2013.
        weights(dst, feature.data(), n);
        accumulate(dst, ur, pr, ar, n);
        accumulate(dst, ug, pg, ag, n);
        accumulate(dst, ub, pb, ab, n);
        for (int i = 0; i < n; ++i) aw[i] += dst[i];
        for (int i = 0; i < n; ++i) aw2[i] += dst[i] * dst[i];
      }
    }
  }
  for (int j = 0; j < th; ++j) {
    for (int i = 0; i < tw; ++i) {
      const size_t t = static_cast<size_t>(j) * tw + i;
      const size_t o = static_cast<size_t>(y0 + j) * width + (x0 + i);
      // The pixel's own weight is 1, so the sum of weights is at least 1.
      const float inv = 1.0f / acc_w[t];
      const int x = x0 + i, y = y0 + j;
      for (int k = 0; k < 3; ++k) out.colour[k][o] = p.colour[k].at(x, y) + acc[k][t] * inv;
      out.variance_factor[o] = acc_w2[t] * inv * inv;
      out.inverse_weight[o] = inv;
    }
  }
}

// Per pixel, blends the two passes by their estimated errors: Stein's unbiased risk estimate of
// a weighted mean whose weights are taken as fixed, (out - u)^2 + 2 var / sum(w) - var per
// channel (Van De Ville and Kocher, "SURE-Based Non-Local Means", IEEE SPL 2009; Rousselle,
// Knaus and Zwicker 2012 and Li, Wu and Chuang, "SURE-based Optimization for Adaptive Sampling
// and Reconstruction", SIGGRAPH Asia 2012, choose between filters with it), averaged over the
// (2 radius + 1)^2 pixels around (one pixel's estimate is as noisy as its colour), each pass
// weighted by the other's risk. The guided pass smooths more; where the image has detail that no
// feature explains (a glossy reflection, a caustic) its residuals grow and the first pass gets
// the weight. Blending measured better than picking the lower one on three of the four scenes of
// docs/DENOISING.md and within 2% on the fourth.
void blend_by_sure(const Planes& p, int width, int height, int radius, const PassResult& second,
                   PassResult& first) {
  Image risk(width, height);  // x: the first pass's, y: the second's
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t o = static_cast<size_t>(y) * width + x;
      float r1 = 0.0f, r2 = 0.0f;
      for (int k = 0; k < 3; ++k) {
        const float u = p.colour[k].at(x, y), v = p.variance[k].at(x, y);
        const float d1 = first.colour[k][o] - u, d2 = second.colour[k][o] - u;
        r1 += d1 * d1 + v * (2.0f * first.inverse_weight[o] - 1.0f);
        r2 += d2 * d2 + v * (2.0f * second.inverse_weight[o] - 1.0f);
      }
      risk.at(x, y) = glm::vec3(r1, r2, 0.0f);
    }
  }
  if (radius > 0) risk = box_mean(risk, radius);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      // A risk estimate can come out negative (it subtracts the variance); a floor keeps the
      // weights in [0, 1], and equal floors give the two passes half each.
      const float r1 = std::max(risk.at(x, y).x, 1e-12f), r2 = std::max(risk.at(x, y).y, 1e-12f);
      const float t = r1 / (r1 + r2);  // the second pass's weight
      const size_t o = static_cast<size_t>(y) * width + x;
      for (int k = 0; k < 3; ++k) {
        first.colour[k][o] += t * (second.colour[k][o] - first.colour[k][o]);
      }
    }
  }
}

// Scales each channel of `out` so that its sum is the input's. Each output pixel is a weighted
// mean of its neighbours (a gather), which keeps the total only where the weights are
// symmetric; around fireflies they are not (a firefly's large variance lets its neighbours take
// it in, each with its own normalisation): on scenes/mirror_glass.json at 64 spp the guided pass
// alone added 0.57% to the image, the blended passes take away 0.15% (docs/DENOISING.md). Sums
// run serially in double, in pixel order, so the result stays the same for any thread count;
// where the sums agree the pixels keep their bits.
void restore_mean(const Image& colour, Image& out) {
  for (int k = 0; k < 3; ++k) {
    double in_sum = 0.0, out_sum = 0.0;
    for (int y = 0; y < colour.height(); ++y) {
      for (int x = 0; x < colour.width(); ++x) {
        in_sum += colour.at(x, y)[k];
        out_sum += out.at(x, y)[k];
      }
    }
    if (!(in_sum > 0.0) || !(out_sum > 0.0) || in_sum == out_sum) continue;
    const float scale = static_cast<float>(in_sum / out_sum);
    for (int y = 0; y < out.height(); ++y) {
      for (int x = 0; x < out.width(); ++x) out.at(x, y)[k] *= scale;
    }
  }
}

void check_options(const DenoiseOptions& options) {
  if (options.search_radius < 0 || options.search_radius > 32) {
    throw Error("denoise",
                "search radius " + std::to_string(options.search_radius) + " is outside 0..32");
  }
  if (options.patch_radius < 0 || options.patch_radius > 8) {
    throw Error("denoise",
                "patch radius " + std::to_string(options.patch_radius) + " is outside 0..8");
  }
  if (options.sure_radius > 32) {
    throw Error("denoise", "SURE radius " + std::to_string(options.sure_radius) + " is above 32");
  }
  for (float v : {options.spatial_variance_floor, options.spatial_variance_floor_limit}) {
    if (!(v >= 0.0f) || !std::isfinite(v)) {
      throw Error("denoise", "spatial variance floor or its limit " + std::to_string(v) +
                                 " is not a finite number >= 0");
    }
  }
  if (options.bright_edges.radius < 1 || options.bright_edges.radius > 4) {
    throw Error("denoise", "bright-edge window radius " +
                               std::to_string(options.bright_edges.radius) + " is outside 1..4");
  }
  for (float v : {options.bright_edges.contrast, options.bright_edges.max_chi2,
                  options.bright_edges.uniformity}) {
    if (!(v >= 0.0f) || !std::isfinite(v)) {
      throw Error("denoise",
                  "a bright-edge setting (" + std::to_string(v) + ") is not a finite number >= 0");
    }
  }
  for (float v : {options.colour_strength, options.guided_colour_strength, options.albedo_scale,
                  options.albedo_relative_scale, options.normal_scale, options.depth_scale}) {
    if (!std::isfinite(v)) throw Error("denoise", "a strength or scale is not finite");
  }
}

}  // namespace

Image denoise(const Image& colour, const Image& variance, const DenoiseFeatures& features,
              const DenoiseOptions& options) {
  check_options(options);
  check_size(variance, colour, "the variance");
  check_size(features.albedo, colour, "the albedo");
  check_size(features.normal, colour, "the normal");
  check_size(features.depth, colour, "the depth");
  check_image_finite(colour, "the colour");
  check_image_finite(variance, "the variance");
  check_image_finite(features.albedo, "the albedo");
  check_image_finite(features.normal, "the normal");
  check_image_finite(features.depth, "the depth");
  const int w = colour.width(), h = colour.height();
  Image out(w, h);
  if (w == 0 || h == 0) return out;

  const int margin = options.search_radius + options.patch_radius;
  const Planes planes = make_planes(colour, variance, features, options, margin);
  const int tiles_x = (w + kTileSize - 1) / kTileSize;
  const int tiles_y = (h + kTileSize - 1) / kTileSize;
  auto run_pass = [&](const Guide& guide) {
    PassResult result;
    for (auto& c : result.colour) c.resize(static_cast<size_t>(w) * h);
    result.variance_factor.resize(static_cast<size_t>(w) * h);
    result.inverse_weight.resize(static_cast<size_t>(w) * h);
    parallel::for_range(tbb::blocked_range<int>(0, tiles_x * tiles_y, 1),
                        [&](const tbb::blocked_range<int>& tiles) {
                          for (int t = tiles.begin(); t < tiles.end(); ++t) {
                            const int x0 = (t % tiles_x) * kTileSize;
                            const int y0 = (t / tiles_x) * kTileSize;
                            filter_tile(planes, guide, options, w, h, x0,
                                        std::min(x0 + kTileSize, w), y0,
                                        std::min(y0 + kTileSize, h), result);
                          }
                        });
    return result;
  };
  PassResult result = run_pass({planes.colour, planes.variance, options.colour_strength});
  if (options.guided_pass) {
    // The second pass compares patches of the first pass's result, whose noise is smaller by
    // the factor sum(w^2) / (sum w)^2 (exact for independent neighbours), so its weights follow
    // the image rather than the noise; it averages the noisy colour again, so each pixel's
    // value is still a weighted mean of the input (the pilot estimate of Dabov et al.'s
    // two-step BM3D, "Image denoising by sparse 3D transform-domain collaborative filtering",
    // IEEE TIP 2007, with non-local means in both steps).
    std::array<Plane, 3> guide_colour{Plane(w, h, margin), Plane(w, h, margin),
                                      Plane(w, h, margin)};
    std::array<Plane, 3> guide_variance{Plane(w, h, margin), Plane(w, h, margin),
                                        Plane(w, h, margin)};
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t o = static_cast<size_t>(y) * w + x;
        for (int k = 0; k < 3; ++k) {
          guide_colour[k].at(x, y) = result.colour[k][o];
          guide_variance[k].at(x, y) = planes.variance[k].at(x, y) * result.variance_factor[o];
        }
      }
    }
    for (auto* group : {&guide_colour, &guide_variance}) {
      for (Plane& plane : *group) plane.fill_border();
    }
    PassResult second = run_pass({guide_colour, guide_variance, options.guided_colour_strength});
    if (options.sure_radius < 0) {
      result = std::move(second);
    } else {
      blend_by_sure(planes, w, h, options.sure_radius, second, result);
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t o = static_cast<size_t>(y) * w + x;
      const glm::vec3& m = planes.modulation[o];
      out.at(x, y) = glm::vec3(result.colour[0][o] * m.x, result.colour[1][o] * m.y,
                               result.colour[2][o] * m.z);
    }
  }
  refine_bright_edges(colour, variance, out, options.bright_edges);
  if (options.keep_mean) restore_mean(colour, out);
  return out;
}

Image average_halves(const Image& half_a, const Image& half_b) {
  check_size(half_b, half_a, "the second half buffer");
  Image out(half_a.width(), half_a.height());
  for (int y = 0; y < half_a.height(); ++y) {
    for (int x = 0; x < half_a.width(); ++x) {
      out.at(x, y) = 0.5f * (half_a.at(x, y) + half_b.at(x, y));
    }
  }
  return out;
}

namespace {

// The mean over the (2 radius + 1)^2 pixels around each pixel (clamped at the border, so border
// pixels count their edge neighbours more than once), in a fixed order.
Image box_mean(const Image& image, int radius) {
  const int w = image.width(), h = image.height();
  Image rows(w, h), out(w, h);
  const float norm = 1.0f / static_cast<float>(2 * radius + 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      glm::vec3 s(0.0f);
      for (int t = -radius; t <= radius; ++t) s += image.at(std::clamp(x + t, 0, w - 1), y);
      rows.at(x, y) = s * norm;
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      glm::vec3 s(0.0f);
      for (int t = -radius; t <= radius; ++t) s += rows.at(x, std::clamp(y + t, 0, h - 1));
      out.at(x, y) = s * norm;
    }
  }
  return out;
}

}  // namespace

Image variance_from_halves(const Image& half_a, const Image& half_b, int radius) {
  check_size(half_b, half_a, "the second half buffer");
  if (radius < 0) throw Error("denoise", "variance radius " + std::to_string(radius) + " < 0");
  Image raw(half_a.width(), half_a.height());
  for (int y = 0; y < half_a.height(); ++y) {
    for (int x = 0; x < half_a.width(); ++x) {
      const glm::vec3 d = half_a.at(x, y) - half_b.at(x, y);
      raw.at(x, y) = 0.25f * d * d;
    }
  }
  return radius == 0 ? raw : box_mean(raw, radius);
}

Image smooth_variance(const Image& variance, int radius, float overestimate) {
  if (radius < 0) throw Error("denoise", "variance radius " + std::to_string(radius) + " < 0");
  if (!(overestimate > 0.0f) || !std::isfinite(overestimate)) {
    throw Error("denoise", "variance overestimate " + std::to_string(overestimate) + " is not > 0");
  }
  Image out = radius == 0 ? variance : box_mean(variance, radius);
  const float scale = 1.0f / overestimate;
  for (int y = 0; y < out.height(); ++y) {
    for (int x = 0; x < out.width(); ++x) out.at(x, y) *= scale;
  }
  return out;
}

Image denoise_halves(const Image& half_a, const Image& half_b, const DenoiseFeatures& features,
                     const DenoiseOptions& options) {
  return denoise(average_halves(half_a, half_b), variance_from_halves(half_a, half_b), features,
                 options);
}

Image estimate_variance_spatially(const Image& colour, const Image& albedo) {
  check_size(albedo, colour, "the albedo");
  const int w = colour.width(), h = colour.height();
  Image u(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) u.at(x, y) = colour.at(x, y) / (albedo.at(x, y) + kAlbedoEpsilon);
  }
  const Image mean = box_mean(u, 1);
  Image squared(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const glm::vec3 d = u.at(x, y) - mean.at(x, y);
      squared.at(x, y) = d * d;
    }
  }
  // A pixel's residual from the 3 x 3 mean that includes it has (8/9) of its variance (white
  // noise); the demodulated variance is multiplied back by the albedo's square.
  Image out = box_mean(squared, 2);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const glm::vec3 m = albedo.at(x, y) + kAlbedoEpsilon;
      out.at(x, y) = out.at(x, y) * (9.0f / 8.0f) * m * m;
    }
  }
  return out;
}

}  // namespace tritrace
