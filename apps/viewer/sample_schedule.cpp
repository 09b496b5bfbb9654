// Frame sizes for progressive rendering, from the cost per sample of the frame before.
#include "sample_schedule.h"

#include <algorithm>
#include <cmath>

namespace tritrace::view {

uint32_t SampleSchedule::next_frame(bool restart) {
  if (restart) {
    taken_ = 0;
    return std::min<uint32_t>(1, target_);
  }
  if (done()) return 0;
  const uint32_t remaining = target_ - taken_;
  if (last_spp_ == 0) return 1;
  // The cost of a frame grows with its samples (each is a full pass over the image), so the last
  // frame's time per sample predicts the next one's; its fixed costs (threads starting) make the
  // estimate err on the short side.
  const double fit = ms_per_sample_ > 0.0 ? std::floor(budget_ms_ / ms_per_sample_)
                                          : static_cast<double>(remaining);
  const double most = std::min<double>(remaining, static_cast<double>(last_spp_) * kMaxGrowth);
  return static_cast<uint32_t>(std::clamp(fit, 1.0, most));
}

void SampleSchedule::frame_rendered(uint32_t spp, double render_ms) {
  if (spp == 0) return;
  taken_ += spp;
  last_spp_ = spp;
  ms_per_sample_ = render_ms / spp;
}

}  // namespace tritrace::view
