// Piecewise-constant densities on [0, 1) and [0, 1)^2, sampled by inverting their CDFs: the
// environment map's importance sampling (a marginal density over rows, a conditional one per row,
// as in Pharr, Jakob and Humphreys, "Physically Based Rendering", 4th ed., section A.5).
#pragma once

#include <cstddef>
#include <glm/vec2.hpp>
#include <span>
#include <vector>

namespace tritrace {

// A density on [0, 1) proportional to n non-negative weights, each constant over its 1/n.
class PiecewiseConstant1D {
 public:
  PiecewiseConstant1D() = default;
  explicit PiecewiseConstant1D(std::span<const float> weights);

  size_t size() const { return weights_.size(); }
  // The sum of the weights, divided by n: the integral of the unnormalised function.
  double integral() const { return integral_; }
  bool zero() const { return !(integral_ > 0.0); }
  // The density of cell i (n w_i / sum w); 0 when every weight is 0.
  float pdf(size_t i) const;

  struct Sample {
    float x = 0.0f;    // in [0, 1)
    size_t cell = 0;   // the cell x lies in
    float pdf = 0.0f;  // the density at x
  };
  // x with the density above: the cell from the CDF, then u's remainder spread over the cell. Never
  // returns a cell of weight 0.
  Sample sample(float u) const;

 private:
  std::vector<float> weights_;
  std::vector<double> cdf_;  // n + 1 entries, cdf_[0] = 0, cdf_[n] = 1
  double integral_ = 0.0;
};

// A density on [0, 1)^2 over a width x height grid of cells (row-major, row y covering
// [y / height, (y + 1) / height) of the second coordinate): the rows by their sums, then the cell
// within the row.
class PiecewiseConstant2D {
 public:
  PiecewiseConstant2D() = default;
  PiecewiseConstant2D(std::span<const float> weights, int width, int height);

  bool zero() const { return marginal_.zero(); }
  // The density of cell (x, y): width height w / sum w.
  float pdf(int x, int y) const;

  struct Sample {
    glm::vec2 uv{0.0f};
    int x = 0, y = 0;
    float pdf = 0.0f;
  };
  Sample sample(glm::vec2 u) const;

 private:
  std::vector<PiecewiseConstant1D> rows_;
  PiecewiseConstant1D marginal_;
};

}  // namespace tritrace
