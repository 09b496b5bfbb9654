// How many samples per pixel each frame of the viewer's progressive path tracing adds: one while
// the view moves, so that it follows the keys; while it rests, as many as fit a frame budget,
// until the scene's target. Plain arithmetic on measured times, so it is unit-tested without SDL.
#pragma once

#include <cstdint>

namespace tritrace::view {

class SampleSchedule {
 public:
  // `target_spp` >= 1: where accumulation stops. `frame_budget_ms`: the render time a resting
  // frame aims at; a key press waits for at most about that long.
  SampleSchedule(uint32_t target_spp, double frame_budget_ms)
      : target_(target_spp), budget_ms_(frame_budget_ms) {}

  // Samples the next frame renders, from sample index samples_taken(). `restart`: the view (or the
  // window's size) changed, so the film starts over with one sample. 0 once the target is reached.
  uint32_t next_frame(bool restart);
  // Reports the frame's render time for the `spp` samples it added.
  void frame_rendered(uint32_t spp, double render_ms);

  uint32_t samples_taken() const { return taken_; }
  uint32_t target() const { return target_; }
  bool done() const { return taken_ >= target_; }
  // The last frame's render time per sample (0 before any): what one sample of the whole image
  // costs.
  double ms_per_sample() const { return ms_per_sample_; }

  // A resting frame grows at most this many times over the one before: a single fast frame (the
  // machine briefly idle) must not commit the next to far more than the budget.
  static constexpr uint32_t kMaxGrowth = 4;

 private:
  uint32_t target_;
  double budget_ms_;
  uint32_t taken_ = 0;
  uint32_t last_spp_ = 0;
  double ms_per_sample_ = 0.0;  // of the last frame; 0 before any
};

}  // namespace tritrace::view
