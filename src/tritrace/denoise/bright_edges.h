// The denoiser's model of a very bright, straight edge, such as the outline of a light seen
// directly: a pixel that the edge crosses holds the fraction of its area on the bright side (its
// coverage) times the bright side's radiance, plus the rest times the dark side's. At a few
// samples per pixel that coverage is measured very coarsely (16 samples on a pixel that a light
// covers by 5% meet the light once or not at all), and no colour or feature tells such a pixel
// from the dark surface beside it. Along a straight edge the coverages of the pixels around it
// are not independent: fitting one line to a window of them measures the edge with all of their
// samples at once, and each pixel's coverage then follows from the line (docs/DENOISING.md).
#pragma once

#include "tritrace/image/image.h"

namespace tritrace {

// The fraction of the unit pixel square centred at the origin on the side n . x <= s of a line
// whose unit normal is n = (nx, ny): the distribution function of nx U + ny V for independent U,
// V uniform on [-1/2, 1/2] (the box pixel filter), a piecewise quadratic in s.
[[nodiscard]] double pixel_coverage(double nx, double ny, double s);

// The bright-edge settings (DenoiseOptions holds them).
struct BrightEdgeOptions {
  // A window is considered when its brightest pixel (the sum of its channels) is at least this
  // many times the mean of its dark pixels (those below 5% of the brightest). 0 turns the model
  // off.
  float contrast = 20.0f;
  // The windows are (2 radius + 1)^2 pixels (radius 1 to 4); each pixel is fitted in the five
  // windows that contain it (centred, and shifted by `radius` pixels left, right, up, down: a
  // window beside a corner of the bright region then holds one of its edges only).
  int radius = 4;
  // A fit is kept when its squared residuals, each in units of the pixel's variance plus
  // (1% of the edge's contrast)^2, average below this.
  float max_chi2 = 1.0f;
  // The fully covered pixels must agree with their mean to this fraction.
  float uniformity = 0.02f;
};

// Replaces, in `denoised`, the value of each pixel that a well-fitted bright straight edge
// crosses (or that saw the bright side in `noisy` while its fit says the edge is beside it) by
// dark + coverage (bright - dark), where the bright value is the noisy mean of the window's
// fully covered pixels and the dark value the denoised mean of its uncovered ones. `variance` is
// the noisy colour's (of the pixel mean). The line is fitted with the window's total kept
// (area matching), so no light is invented or removed within a window. Deterministic and
// independent of the thread count.
void refine_bright_edges(const Image& noisy, const Image& variance, Image& denoised,
                         const BrightEdgeOptions& options = {});

}  // namespace tritrace
