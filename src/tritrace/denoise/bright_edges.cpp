// The bright-edge model (bright_edges.h): per pixel near a strong contrast, a straight line fitted
// to the coverages of a small window of pixels, the window's total kept.
#include "tritrace/denoise/bright_edges.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "tritrace/parallel.h"

namespace tritrace {

double pixel_coverage(double nx, double ny, double s) {
  double a = std::abs(nx), b = std::abs(ny);
  if (a < b) std::swap(a, b);
  // The density of a U + b V is a trapezoid on [-(a + b) / 2, (a + b) / 2]; t is s from its
  // left end.
  const double t = s + 0.5 * (a + b);
  if (t <= 0.0) return 0.0;
  if (t >= a + b) return 1.0;
  if (b < 1e-9) return t / a;
  if (t < b) return t * t / (2.0 * a * b);
  if (t <= a) return (t - 0.5 * b) / a;
  const double u = a + b - t;
  return 1.0 - u * u / (2.0 * a * b);
}

namespace {

constexpr int kMaxEdgeWindow = 9;  // 2 * radius + 1 for radius up to 4
constexpr int kMaxEdgeWindowPixels = kMaxEdgeWindow * kMaxEdgeWindow;

// One window's pixels: positions relative to the window's centre, the noisy channel sums
// brought to coverages, and the weight of each squared coverage residual.
struct EdgeWindow {
  int count = 0;
  std::array<double, kMaxEdgeWindowPixels> x{}, y{}, measured{}, weight{};
  std::array<int, kMaxEdgeWindowPixels> px{}, py{};
};

struct EdgeLineFit {
  double nx = 1.0, ny = 0.0, d = 0.0;
  double chi2 = 0.0;
};

// The line n . x = d with n at angle theta whose coverages sum to the measured total (area
// matching: the total is decreasing in d, found by bisection), and its weighted squared
// residuals.
EdgeLineFit fit_offset(const EdgeWindow& w, double theta, double total) {
  EdgeLineFit fit;
  fit.nx = std::cos(theta);
  fit.ny = std::sin(theta);
  double lo = 1e30, hi = -1e30;
  for (int i = 0; i < w.count; ++i) {
    const double s = fit.nx * w.x[i] + fit.ny * w.y[i];
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  lo -= 1.0;
  hi += 1.0;  // d = lo: every pixel fully on the bright side; d = hi: none
  for (int iteration = 0; iteration < 24; ++iteration) {
    const double mid = 0.5 * (lo + hi);
    double sum = 0.0;
    for (int i = 0; i < w.count; ++i) {
      sum += pixel_coverage(fit.nx, fit.ny, fit.nx * w.x[i] + fit.ny * w.y[i] - mid);
    }
    (sum > total ? lo : hi) = mid;
  }
  fit.d = 0.5 * (lo + hi);
  for (int i = 0; i < w.count; ++i) {
    const double c = pixel_coverage(fit.nx, fit.ny, fit.nx * w.x[i] + fit.ny * w.y[i] - fit.d);
    const double r = w.measured[i] - c;
    fit.chi2 += r * r * w.weight[i];
  }
  return fit;
}

// The best line for a window: the normal's angle starts at the direction of the coverages' first
// moment (for a half-plane it points to the bright side), is scanned over +-0.6 radians and
// refined by golden-section search.
EdgeLineFit fit_line(const EdgeWindow& w, double total) {
  double gx = 0.0, gy = 0.0;
  for (int i = 0; i < w.count; ++i) {
    gx += w.measured[i] * w.x[i];
    gy += w.measured[i] * w.y[i];
  }
  const double theta0 = std::atan2(gy, gx);
  constexpr double kStep = 0.15;
  EdgeLineFit best = fit_offset(w, theta0, total);
  double best_theta = theta0;
  for (int j = -3; j <= 3; ++j) {
    if (j == 0) continue;
    const double theta = theta0 + j * kStep;
    const EdgeLineFit fit = fit_offset(w, theta, total);
    if (fit.chi2 < best.chi2) {
      best = fit;
      best_theta = theta;
    }
  }
  constexpr double kGolden = 0.6180339887498949;
  double a = best_theta - kStep, b = best_theta + kStep;
  double c = b - kGolden * (b - a), e = a + kGolden * (b - a);
  EdgeLineFit fc = fit_offset(w, c, total), fe = fit_offset(w, e, total);
  for (int iteration = 0; iteration < 10; ++iteration) {
    if (fc.chi2 < fe.chi2) {
      b = e;
      e = c;
      fe = fc;
      c = b - kGolden * (b - a);
      fc = fit_offset(w, c, total);
    } else {
      a = c;
      c = e;
      fc = fe;
      e = a + kGolden * (b - a);
      fe = fit_offset(w, e, total);
    }
  }
  for (const EdgeLineFit* f : {&fc, &fe}) {
    if (f->chi2 < best.chi2) best = *f;
  }
  return best;
}

float sum_of_channels(const glm::vec3& v) {
  return v.x + v.y + v.z;
}

struct EdgePixelModel {
  bool ok = false;
  double chi2_per_pixel = 0.0;
  double coverage = 0.0;   // the pixel's, from the fitted line
  double measured = 0.0;   // the pixel's own measured coverage
  glm::vec3 bright{0.0f};  // noisy mean of the fully covered pixels
  glm::vec3 dark{0.0f};    // denoised mean of the uncovered pixels
};

// Fits the window whose top-left pixel is (wx, wy) and returns the model at pixel (x, y).
EdgePixelModel model_in_window(const Image& noisy, const Image& variance, const Image& denoised,
                               const BrightEdgeOptions& options, int wx, int wy, int x, int y) {
  EdgePixelModel model;
  const int size = 2 * options.radius + 1;
  float brightest = 0.0f;
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i)
      brightest = std::max(brightest, sum_of_channels(noisy.at(wx + i, wy + j)));
  }
  if (!(brightest > 0.0f)) return model;
  double dark_sum = 0.0;
  int dark_count = 0;
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const float s = sum_of_channels(noisy.at(wx + i, wy + j));
      if (s < 0.05f * brightest) {
        dark_sum += s;
        ++dark_count;
      }
    }
  }
  if (dark_count == 0) return model;
  // A uniform bright side shows as two pixels within `uniformity` of the brightest at least.
  int near_brightest = 0;
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      near_brightest += sum_of_channels(noisy.at(wx + i, wy + j)) >=
                        (1.0f - 2.0f * options.uniformity) * brightest;
    }
  }
  if (near_brightest < 2) return model;
  const double dark = dark_sum / dark_count;
  if (!(brightest >= options.contrast * dark)) return model;
  const double span = brightest - dark;
  const double tolerance = 0.01 * span;
  EdgeWindow w;
  double total = 0.0;
  const double centre = options.radius;
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const int qx = wx + i, qy = wy + j;
      const int n = w.count++;
      w.px[n] = qx;
      w.py[n] = qy;
      w.x[n] = i - centre;
      w.y[n] = j - centre;
      w.measured[n] = std::clamp((sum_of_channels(noisy.at(qx, qy)) - dark) / span, 0.0, 1.0);
      const double v = std::max(0.0f, sum_of_channels(variance.at(qx, qy)));
      w.weight[n] = span * span / (v + tolerance * tolerance);
      total += w.measured[n];
    }
  }
  if (total < 0.5 || total > w.count - 0.5) return model;
  const EdgeLineFit fit = fit_line(w, total);
  model.chi2_per_pixel = fit.chi2 / w.count;
  if (!(model.chi2_per_pixel <= options.max_chi2)) return model;
  glm::dvec3 bright_sum(0.0), dark_colour(0.0);
  int bright_count = 0, dark_pixels = 0;
  for (int n = 0; n < w.count; ++n) {
    const double c = pixel_coverage(fit.nx, fit.ny, fit.nx * w.x[n] + fit.ny * w.y[n] - fit.d);
    if (c >= 0.999) {
      bright_sum += glm::dvec3(noisy.at(w.px[n], w.py[n]));
      ++bright_count;
    } else if (c <= 0.001) {
      dark_colour += glm::dvec3(denoised.at(w.px[n], w.py[n]));
      ++dark_pixels;
    }
    if (w.px[n] == x && w.py[n] == y) {
      model.coverage = c;
      model.measured = w.measured[n];
    }
  }
  // Two fully covered pixels at least: a lone bright pixel (a firefly) is no edge.
  if (bright_count < 2 || dark_pixels == 0) return model;
  model.bright = glm::vec3(bright_sum / static_cast<double>(bright_count));
  // The bright side must be uniform (a light seen directly, whose samples all return its
  // radiance): the model's bright value is then exact. A lit surface's edge is the features'.
  const double bright_mean = sum_of_channels(model.bright);
  for (int n = 0; n < w.count; ++n) {
    const double c = pixel_coverage(fit.nx, fit.ny, fit.nx * w.x[n] + fit.ny * w.y[n] - fit.d);
    if (c >= 0.999 && std::abs(sum_of_channels(noisy.at(w.px[n], w.py[n])) - bright_mean) >
                          options.uniformity * bright_mean) {
      return model;
    }
  }
  model.dark = glm::vec3(dark_colour / static_cast<double>(dark_pixels));
  model.ok = true;
  return model;
}

}  // namespace

void refine_bright_edges(const Image& noisy, const Image& variance, Image& denoised,
                         const BrightEdgeOptions& options) {
  const int w = noisy.width(), h = noisy.height();
  const int r = options.radius;
  const int size = 2 * r + 1;
  if (!(options.contrast > 0.0f) || r < 1 || size > kMaxEdgeWindow || w < size || h < size) return;
  // Candidates: pixels with a pixel at least `contrast` times brighter within one pixel.
  Image result = denoised;
  parallel::for_range(tbb::blocked_range<int>(0, h, 4), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        float lo = 1e30f, hi = 0.0f;
        for (int j = std::max(0, y - 1); j <= std::min(h - 1, y + 1); ++j) {
          for (int i = std::max(0, x - 1); i <= std::min(w - 1, x + 1); ++i) {
            lo = std::min(lo, sum_of_channels(denoised.at(i, j)));
            hi = std::max(hi, sum_of_channels(noisy.at(i, j)));
          }
        }
        if (!(hi > 0.0f) || hi < options.contrast * lo) continue;
        std::array<EdgePixelModel, 5> models;
        const std::array<std::array<int, 2>, 5> shifts{{{0, 0}, {-r, 0}, {r, 0}, {0, -r}, {0, r}}};
        int best = -1;
        for (int k = 0; k < 5; ++k) {
          const int wx = std::clamp(x - r + shifts[k][0], 0, w - size);
          const int wy = std::clamp(y - r + shifts[k][1], 0, h - size);
          models[k] = model_in_window(noisy, variance, denoised, options, wx, wy, x, y);
          if (models[k].ok &&
              (best < 0 || models[k].chi2_per_pixel < models[best].chi2_per_pixel)) {
            best = k;
          }
        }
        if (best < 0) continue;
        const EdgePixelModel& model = models[best];
        // Left as the filter made them: pixels that saw no light where the line says none
        // reaches, and pixels whose every sample saw the light where the line says nearly all of
        // it is covered (a fully covered pixel is exact; the line's own error would only darken
        // it).
        if (model.coverage <= 0.0 && model.measured <= 0.0) continue;
        if (model.coverage >= 0.95 && model.measured >= 1.0 - options.uniformity) continue;
        const float c = static_cast<float>(model.coverage);
        result.at(x, y) = model.dark + c * (model.bright - model.dark);
      }
    }
  });
  denoised = std::move(result);
}

}  // namespace tritrace
