// Title text, the throttled frame-time line and medians.
#include "frame_report.h"

#include <algorithm>
#include <cstddef>
#include <cstdio>

namespace tritrace::view {

std::string window_title(double frame_ms, int width, int height) {
  char text[128];
  const double fps = frame_ms > 0.0 ? 1000.0 / frame_ms : 0.0;
  std::snprintf(text, sizeof text, "tritrace \u2014 %.1f ms/frame (%.0f fps), %dx%d", frame_ms, fps,
                width, height);
  return text;
}

std::string window_title(double frame_ms, int width, int height, uint32_t spp,
                         uint32_t target_spp) {
  char text[160];
  std::snprintf(text, sizeof text, "tritrace \u2014 %.1f ms/frame, %u/%u spp, %dx%d", frame_ms, spp,
                target_spp, width, height);
  return text;
}

std::string window_title(double frame_ms, int width, int height, uint32_t spp, uint32_t target_spp,
                         uint32_t denoised_spp) {
  return window_title(frame_ms, width, height,
                      PathTitle{.spp = spp,
                                .target_spp = target_spp,
                                .denoise = true,
                                .denoised_spp = denoised_spp,
                                .stopped = {},
                                .refining = {}});
}

std::string window_title(double frame_ms, int width, int height, const PathTitle& path) {
  std::string title = window_title(frame_ms, width, height, path.spp, path.target_spp);
  if (path.noise_threshold > 0.0f) {
    char threshold[48];
    std::snprintf(threshold, sizeof threshold, ", noise threshold %g", path.noise_threshold);
    title += threshold;
  }
  if (path.denoise) {
    title += path.denoised_spp > 0 ? ", denoised at " + std::to_string(path.denoised_spp) + " spp"
                                   : std::string(", denoise on");
  }
  if (!path.stopped.empty()) title += ", stopped: " + path.stopped;
  if (!path.refining.empty()) title += ", " + path.refining;
  return title;
}

double RenderTimeReport::seconds_until_due(double now) const {
  if (!printed_) return 0.0;
  return std::max(0.0, last_print_ + 1.0 - now);
}

std::string RenderTimeReport::take_line(double now) {
  char text[64];
  std::snprintf(text, sizeof text, "Render time: %.1f ms", frames_ > 0 ? sum_ms_ / frames_ : 0.0);
  sum_ms_ = 0.0;
  frames_ = 0;
  printed_ = true;
  last_print_ = now;
  return text;
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto mid = static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  const double upper = values[values.size() / 2];
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + mid);
  return 0.5 * (lower + upper);
}

}  // namespace tritrace::view
