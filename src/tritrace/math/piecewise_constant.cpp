// The CDFs in double, so that a map of a million texels keeps every cell's share exact enough for
// the chi-square tests, and the inversion by binary search.
#include "tritrace/math/piecewise_constant.h"

#include <algorithm>

namespace tritrace {

PiecewiseConstant1D::PiecewiseConstant1D(std::span<const float> weights)
    : weights_(weights.begin(), weights.end()), cdf_(weights.size() + 1, 0.0) {
  double sum = 0.0;
  for (size_t i = 0; i < weights_.size(); ++i) {
    sum += static_cast<double>(weights_[i]);
    cdf_[i + 1] = sum;
  }
  integral_ = weights_.empty() ? 0.0 : sum / static_cast<double>(weights_.size());
  if (sum > 0.0) {
    for (double& c : cdf_) c /= sum;
    cdf_.back() = 1.0;
  }
}

float PiecewiseConstant1D::pdf(size_t i) const {
  if (zero() || i >= weights_.size()) return 0.0f;
  return static_cast<float>(static_cast<double>(weights_[i]) / integral_);
}

PiecewiseConstant1D::Sample PiecewiseConstant1D::sample(float u) const {
  Sample s;
  if (zero()) return s;
  const double ud = static_cast<double>(u);
  // The first cell whose CDF end exceeds u: a cell of weight 0 has an empty CDF interval and is
  // never found.
  const auto it = std::upper_bound(cdf_.begin() + 1, cdf_.end(), ud);
  size_t i = static_cast<size_t>(it - cdf_.begin()) - 1;
  i = std::min(i, weights_.size() - 1);
  while (weights_[i] <= 0.0f && i > 0) --i;  // u == 1 rounded up past the last non-zero cell
  const double width = cdf_[i + 1] - cdf_[i];
  const double t = width > 0.0 ? std::clamp((ud - cdf_[i]) / width, 0.0, 1.0) : 0.5;
  const double n = static_cast<double>(weights_.size());
  s.x = std::min(static_cast<float>((static_cast<double>(i) + t) / n), 0x1.fffffep-1f);
  s.cell = i;
  s.pdf = pdf(i);
  return s;
}

PiecewiseConstant2D::PiecewiseConstant2D(std::span<const float> weights, int width, int height) {
  std::vector<float> row_sums(static_cast<size_t>(height));
  rows_.reserve(static_cast<size_t>(height));
  for (int y = 0; y < height; ++y) {
    rows_.emplace_back(weights.subspan(static_cast<size_t>(y) * static_cast<size_t>(width),
                                       static_cast<size_t>(width)));
    row_sums[static_cast<size_t>(y)] = static_cast<float>(rows_.back().integral());
  }
  marginal_ = PiecewiseConstant1D(row_sums);
}

float PiecewiseConstant2D::pdf(int x, int y) const {
  if (zero()) return 0.0f;
  return marginal_.pdf(static_cast<size_t>(y)) *
         rows_[static_cast<size_t>(y)].pdf(static_cast<size_t>(x));
}

PiecewiseConstant2D::Sample PiecewiseConstant2D::sample(glm::vec2 u) const {
  Sample s;
  if (zero()) return s;
  const PiecewiseConstant1D::Sample row = marginal_.sample(u.y);
  const PiecewiseConstant1D::Sample column = rows_[row.cell].sample(u.x);
  s.uv = glm::vec2(column.x, row.x);
  s.x = static_cast<int>(column.cell);
  s.y = static_cast<int>(row.cell);
  s.pdf = row.pdf * column.pdf;
  return s;
}

}  // namespace tritrace
