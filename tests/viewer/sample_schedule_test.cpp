// The viewer's progressive sample schedule: one sample while the view moves, frames sized to the
// budget from the last frame's cost while it rests, never past the target, and every frame
// starting where the last one ended.
#include "sample_schedule.h"

#include <gtest/gtest.h>

#include <vector>

namespace tritrace::view {
namespace {

TEST(SampleSchedule, ARestartTakesOneSample) {
  SampleSchedule s(64, 50.0);
  EXPECT_EQ(s.next_frame(true), 1u);
  s.frame_rendered(1, 2.0);
  EXPECT_EQ(s.samples_taken(), 1u);
  // Moving: every frame restarts, whatever the last one cost.
  EXPECT_EQ(s.next_frame(true), 1u);
  EXPECT_EQ(s.samples_taken(), 0u);
}

TEST(SampleSchedule, RestingFramesFitTheBudget) {
  SampleSchedule s(1000, 50.0);
  ASSERT_EQ(s.next_frame(true), 1u);
  s.frame_rendered(1, 10.0);  // 10 ms a sample: 5 fit 50 ms
  EXPECT_EQ(s.next_frame(false), 4u) << "at most 4 times the last frame's";
  s.frame_rendered(4, 40.0);
  EXPECT_EQ(s.next_frame(false), 5u);  // floor(50 / 10)
  s.frame_rendered(5, 55.0);           // 11 ms a sample: 4.5 fit
  EXPECT_EQ(s.next_frame(false), 4u);
  s.frame_rendered(4, 400.0);  // a slow frame (the machine busy): one sample at a time
  EXPECT_EQ(s.next_frame(false), 1u);
  EXPECT_EQ(s.samples_taken(), 14u);
}

TEST(SampleSchedule, StopsExactlyAtTheTarget) {
  SampleSchedule s(10, 50.0);
  uint32_t total = 0;
  std::vector<uint32_t> frames;
  for (bool first = true;; first = false) {
    const uint32_t k = s.next_frame(first);
    if (k == 0) break;
    frames.push_back(k);
    total += k;
    s.frame_rendered(k, 0.5 * k);  // cheap samples: only the growth limit and the target bind
  }
  EXPECT_EQ(total, 10u);
  EXPECT_EQ(frames, (std::vector<uint32_t>{1, 4, 5}));
  EXPECT_TRUE(s.done());
  EXPECT_EQ(s.next_frame(false), 0u);
  EXPECT_EQ(s.samples_taken(), 10u);
}

TEST(SampleSchedule, ATargetOfOneIsDoneAfterTheFirstFrame) {
  SampleSchedule s(1, 50.0);
  EXPECT_EQ(s.next_frame(true), 1u);
  s.frame_rendered(1, 1.0);
  EXPECT_TRUE(s.done());
  EXPECT_EQ(s.next_frame(false), 0u);
}

TEST(SampleSchedule, AFrameThatTookNoMeasurableTimeGrowsByTheLimit) {
  SampleSchedule s(100, 50.0);
  s.next_frame(true);
  s.frame_rendered(1, 0.0);
  EXPECT_EQ(s.next_frame(false), SampleSchedule::kMaxGrowth);
}

}  // namespace
}  // namespace tritrace::view
