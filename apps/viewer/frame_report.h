// What the viewer tells about its speed: the window title (with the samples so far for the path
// tracer), the lab's "Render time" line at most once a second, and medians for --benchmark-frames.
// Clock values come in as arguments, so the once-a-second rule is unit-tested without waiting.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace tritrace::view {

// "tritrace — 3.1 ms/frame (320 fps), 500x500": the lab integrator's frames.
std::string window_title(double frame_ms, int width, int height);
// "tritrace — 52.3 ms/frame, 37/64 spp, 500x500": the path tracer's, with the samples per pixel
// the window shows the mean of and the scene's target, where accumulation stops.
std::string window_title(double frame_ms, int width, int height, uint32_t spp, uint32_t target_spp);
// The same with the denoiser on (N): "..., 500x500, denoised at 32 spp" when the window shows the
// film denoised at 32 spp, "..., 500x500, denoise on" while it waits for the view to rest.
std::string window_title(double frame_ms, int width, int height, uint32_t spp, uint32_t target_spp,
                         uint32_t denoised_spp);

// Everything the path tracer's title tells besides the frame time and size.
struct PathTitle {
  uint32_t spp = 0;              // the samples per pixel the window shows
  uint32_t target_spp = 1;       // --spp: the most at rest
  float noise_threshold = 0.0f;  // adaptive sampling's threshold; 0: off
  bool denoise = false;          // N is on
  uint32_t denoised_spp = 0;     // the spp of the denoised image shown; 0: none shown yet
  std::string stopped{};         // why refinement at rest stopped ("time limit"); empty: it goes on
  std::string refining{};  // what is being rendered meanwhile ("refining to 256 spp, part 3/8")
};
// "tritrace — 52.3 ms/frame, 128/1024 spp, 500x500, noise threshold 0.05, denoised at 128 spp,
// stopped: converged": the overloads above, with the threshold when adaptive sampling is on, the
// reason when refinement at rest has stopped, and what is being refined while a level renders.
std::string window_title(double frame_ms, int width, int height, const PathTitle& path);

// Collects frame times and says when the next "Render time: N ms" line is due: at once for the
// first frame, then at most once a second, giving the mean of the frames since the last line.
class RenderTimeReport {
 public:
  void add_frame(double frame_ms) {
    sum_ms_ += frame_ms;
    ++frames_;
  }
  bool pending() const { return frames_ > 0; }
  // Seconds from `now` until a pending line may be printed (0 when due, negative never).
  double seconds_until_due(double now) const;
  // The line for the frames since the last one (call when seconds_until_due(now) is 0).
  std::string take_line(double now);

 private:
  double sum_ms_ = 0.0;
  int frames_ = 0;
  bool printed_ = false;
  double last_print_ = 0.0;
};

double median(std::vector<double> values);  // 0 for none

}  // namespace tritrace::view
