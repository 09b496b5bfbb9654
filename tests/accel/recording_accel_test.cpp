// RecordingAccel and the replay behind `tritrace bench --secondary-rays`: it must record every ray
// of a path-traced frame (counted independently by the renderer, and by the camera's samples),
// hand the queries on unchanged, put the batches in an order that does not depend on the threads,
// and the replay must give each ray the answer a brute-force search gives.
#include "tritrace/accel/recording_accel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <functional>
#include <latch>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/job/render_job.h"

namespace tritrace {
namespace {

constexpr int kWidth = 24, kHeight = 16, kSpp = 2;

struct Frame {
  RecordedRays recorded;
  RenderStats stats;
  RenderedImage image;
};

// A small path-traced frame of `scene` through a RecordingAccel over `accel`.
Frame record_frame(const LoadedScene& loaded, const Accel& accel, int threads) {
  JobSettings s;
  s.width = std::to_string(kWidth);
  s.height = std::to_string(kHeight);
  s.spp = std::to_string(kSpp);
  s.threads = std::to_string(threads);
  s.integrator = "path";
  RecordingAccel recording(accel);
  RenderJob job(s, loaded.scene, loaded.integrator);
  job.prepare(nullptr, &recording);
  Frame f;
  f.image = job.render(&f.stats);
  f.recorded = recording.take();
  return f;
}

size_t sum(const std::vector<uint32_t>& sizes) {
  size_t n = 0;
  for (const uint32_t s : sizes) n += s;
  return n;
}

LoadedScene load(const std::string& name) {
  JobSettings s;
  s.scene = name;
  s.width = std::to_string(kWidth);
  s.height = std::to_string(kHeight);
  s.integrator = "path";
  return load_job_scene(s);
}

class RecordingAccelFrame : public ::testing::TestWithParam<const char*> {};

TEST_P(RecordingAccelFrame, RecordsEveryRayAndReplaysToTheSameAnswers) {
  const LoadedScene loaded = load(GetParam());
  const auto bvh = make_accel(AccelKind::kBvh, loaded.scene, Kernel::kWatertight);
  const Frame f = record_frame(loaded, *bvh, 2);
  const RecordedRays& r = f.recorded;

  // Every ray the renderer counted went through the recorder: one camera ray per sample through
  // the coherent query, the rest through the incoherent ones.
  EXPECT_EQ(r.coherent_rays, static_cast<uint64_t>(kWidth) * kHeight * kSpp);
  EXPECT_EQ(r.coherent_rays + r.closest.rays.size() + r.any.rays.size(), f.stats.rays);
  EXPECT_GT(r.closest.rays.size(), 0u);
  EXPECT_GT(r.any.rays.size(), 0u);
  EXPECT_EQ(sum(r.closest.sizes), r.closest.rays.size());
  EXPECT_EQ(sum(r.any.sizes), r.any.rays.size());
  EXPECT_EQ(r.hits.size(), r.closest.rays.size());
  EXPECT_EQ(r.occluded.size(), r.any.rays.size());
  // Groups: one per coherent query, each starting where the one before ended.
  EXPECT_EQ(r.closest.groups.size(), r.any.groups.size());
  EXPECT_TRUE(std::is_sorted(r.closest.groups.begin(), r.closest.groups.end()));
  EXPECT_TRUE(std::is_sorted(r.any.groups.begin(), r.any.groups.end()));
  ASSERT_FALSE(r.closest.groups.empty());
  EXPECT_EQ(r.closest.groups.front(), 0u);
  EXPECT_LE(r.closest.groups.back(), r.closest.sizes.size());

  // The recorder only watches: the frame is the one the bvh renders without it.
  {
    JobSettings s;
    s.width = std::to_string(kWidth);
    s.height = std::to_string(kHeight);
    s.spp = std::to_string(kSpp);
    s.threads = "2";
    s.integrator = "path";
    RenderJob plain(s, loaded.scene, loaded.integrator);
    plain.prepare(nullptr, bvh.get());
    const RenderedImage want = plain.render();
    ASSERT_EQ(want.image.pixels().size(), f.image.image.pixels().size());
    EXPECT_EQ(0, std::memcmp(want.image.pixels().data(), f.image.image.pixels().data(),
                             want.image.pixels().size() * sizeof(glm::vec3)));
  }

  // Replayed through the same bvh on one and on three threads: bit for bit the recorded answers.
  for (const int threads : {1, 3}) {
    std::vector<Hit> hits(r.hits.size());
    std::vector<uint8_t> occluded(r.occluded.size());
    replay_closest(*bvh, r.closest, hits, threads);
    replay_any(*bvh, r.any, occluded, threads);
    EXPECT_EQ(0, std::memcmp(hits.data(), r.hits.data(), hits.size() * sizeof(Hit)));
    EXPECT_EQ(occluded, r.occluded);
  }

  // The oracle: brute force with the same watertight kernel tests every triangle of every ray.
  const BruteForceAccel brute(loaded.scene.mesh, Kernel::kWatertight);
  std::vector<Hit> hits(r.hits.size());
  std::vector<uint8_t> occluded(r.occluded.size());
  replay_closest(brute, r.closest, hits, 2);
  replay_any(brute, r.any, occluded, 2);
  size_t found = 0;
  for (size_t i = 0; i < hits.size(); ++i) {
    ASSERT_EQ(hits[i].found(), r.hits[i].found()) << i;
    ASSERT_EQ(hits[i].prim, r.hits[i].prim) << i;
    ASSERT_EQ(hits[i].t, r.hits[i].t) << i;
    found += hits[i].found();
  }
  EXPECT_GT(found, 0u);
  EXPECT_EQ(occluded, r.occluded);
}

TEST_P(RecordingAccelFrame, OrderDoesNotDependOnTheThreads) {
  const LoadedScene loaded = load(GetParam());
  const auto bvh = make_accel(AccelKind::kBvh, loaded.scene, Kernel::kWatertight);
  // Several threads: the groups sorted, whichever thread took which tile.
  const RecordedRays one = record_frame(loaded, *bvh, 2).recorded;
  const RecordedRays three = record_frame(loaded, *bvh, 3).recorded;
  EXPECT_EQ(one.closest.sizes, three.closest.sizes);
  EXPECT_EQ(one.any.sizes, three.any.sizes);
  EXPECT_EQ(one.closest.groups, three.closest.groups);
  EXPECT_EQ(one.any.groups, three.any.groups);
  ASSERT_EQ(one.closest.rays.size(), three.closest.rays.size());
  ASSERT_EQ(one.any.rays.size(), three.any.rays.size());
  EXPECT_EQ(0, std::memcmp(one.closest.rays.data(), three.closest.rays.data(),
                           one.closest.rays.size() * sizeof(Ray)));
  EXPECT_EQ(0, std::memcmp(one.any.rays.data(), three.any.rays.data(),
                           one.any.rays.size() * sizeof(Ray)));
  EXPECT_EQ(0, std::memcmp(one.hits.data(), three.hits.data(), one.hits.size() * sizeof(Hit)));
  EXPECT_EQ(one.occluded, three.occluded);
}

INSTANTIATE_TEST_SUITE_P(Scenes, RecordingAccelFrame,
                         ::testing::Values("cornell-area", "terrain:3k"), [](const auto& info) {
                           std::string name = info.param;
                           for (char& c : name) {
                             if (c == '-' || c == ':') c = '_';
                           }
                           return name;
                         });

// Within a group (the calls after a coherent query, or before any) batches keep their call order;
// one thread's groups keep their call order too; each ray keeps its own answer; take() forgets.
TEST(RecordingAccel, OneThreadKeepsCallOrder) {
  TriangleMesh mesh;
  mesh.add({-1, -1, 0}, {1, -1, 0}, {0, 1, 0}, 0);
  const BruteForceAccel brute(mesh, Kernel::kWatertight);
  RecordingAccel recording(brute, GroupOrder::kCallOrder);
  const Ray hit_ray{{0, 0, -1}, {0, 0, 1}};   // hits at t = 1
  const Ray far_ray{{0, 0, -3}, {0, 0, 1}};   // hits at t = 3
  const Ray miss_ray{{5, 5, -1}, {0, 0, 1}};  // misses
  const std::vector<Ray> pair = {far_ray, miss_ray};
  const std::vector<Ray> single = {hit_ray};
  std::vector<Hit> hits(2);
  std::vector<uint8_t> occ(2);
  // Group 0 (no coherent query yet): closest pair, closest single, any pair.
  recording.intersect_incoherent(pair, hits);
  recording.intersect_incoherent(single, std::span(hits).first(1));
  recording.occluded_incoherent(pair, occ);
  // A group started by a coherent query of two rays: any single.
  recording.intersect(pair, hits);
  recording.occluded_incoherent(single, std::span(occ).first(1));
  // A group started by a coherent query of one ray: closest single.
  recording.occluded(single, std::span(occ).first(1));
  recording.intersect_incoherent(single, std::span(hits).first(1));

  const RecordedRays r = recording.take();
  EXPECT_EQ(r.coherent_rays, 3u);
  ASSERT_EQ(r.closest.sizes, (std::vector<uint32_t>{2, 1, 1}));   // call order, not size order
  EXPECT_EQ(r.closest.groups, (std::vector<uint32_t>{0, 2, 2}));  // the second group has none
  ASSERT_EQ(r.closest.rays.size(), 4u);
  EXPECT_EQ(r.closest.rays[0].origin.z, -3.0f);
  EXPECT_EQ(r.closest.rays[1].origin.x, 5.0f);
  EXPECT_EQ(r.closest.rays[2].origin.z, -1.0f);
  EXPECT_EQ(r.closest.rays[3].origin.z, -1.0f);
  ASSERT_EQ(r.hits.size(), 4u);
  EXPECT_EQ(r.hits[0].t, 3.0f);
  EXPECT_FALSE(r.hits[1].found());
  EXPECT_EQ(r.hits[2].t, 1.0f);
  EXPECT_EQ(r.hits[3].t, 1.0f);
  EXPECT_EQ(r.any.sizes, (std::vector<uint32_t>{2, 1}));
  EXPECT_EQ(r.any.groups, (std::vector<uint32_t>{0, 1, 2}));  // the third group has none
  EXPECT_EQ(r.occluded, (std::vector<uint8_t>{1, 0, 1}));

  const RecordedRays again = recording.take();
  EXPECT_TRUE(again.closest.rays.empty());
  EXPECT_TRUE(again.any.sizes.empty());
  EXPECT_TRUE(again.closest.groups.empty());
  EXPECT_EQ(again.coherent_rays, 0u);
}

// Two threads' groups come back ordered by the coherent query that started them (its size
// first), whichever thread recorded first.
TEST(RecordingAccel, SeveralThreadsGroupsAreSortedByTheirCoherentQuery) {
  TriangleMesh mesh;
  mesh.add({-1, -1, 0}, {1, -1, 0}, {0, 1, 0}, 0);
  const BruteForceAccel brute(mesh, Kernel::kWatertight);
  const Ray hit_ray{{0, 0, -1}, {0, 0, 1}};
  const Ray far_ray{{0, 0, -3}, {0, 0, 1}};
  const std::vector<Ray> pair = {far_ray, hit_ray};
  const std::vector<Ray> single = {hit_ray};
  for (const bool two_first : {true, false}) {
    RecordingAccel recording(brute);
    std::latch done(2);  // both threads alive until both recorded: distinct thread ids
    const auto two = [&] {
      std::vector<Hit> hits(2);
      recording.intersect(pair, hits);
      recording.intersect_incoherent(single, std::span(hits).first(1));
      done.arrive_and_wait();
    };
    const auto one = [&] {
      std::vector<Hit> hits(2);
      recording.intersect(single, std::span(hits).first(1));
      recording.intersect_incoherent(pair, hits);
      done.arrive_and_wait();
    };
    std::thread a(two_first ? std::function<void()>(two) : std::function<void()>(one));
    std::thread b(two_first ? std::function<void()>(one) : std::function<void()>(two));
    a.join();
    b.join();
    const RecordedRays r = recording.take();
    // The one-ray query's group (its closest batch: the pair) before the two-ray query's.
    EXPECT_EQ(r.closest.sizes, (std::vector<uint32_t>{2, 1})) << two_first;
    EXPECT_EQ(r.closest.groups, (std::vector<uint32_t>{0, 1})) << two_first;
    ASSERT_EQ(r.hits.size(), 3u);
    EXPECT_EQ(r.hits[0].t, 3.0f);
    EXPECT_EQ(r.hits[1].t, 1.0f);
    EXPECT_EQ(r.hits[2].t, 1.0f);
    EXPECT_EQ(r.coherent_rays, 3u);
  }
  // Call order is one thread's: two threads' recordings have none.
  RecordingAccel call_order(brute, GroupOrder::kCallOrder);
  std::latch done(2);
  const auto record = [&] {
    std::vector<Hit> hits(2);
    call_order.intersect(pair, hits);
    done.arrive_and_wait();
  };
  std::thread a(record), b(record);
  a.join();
  b.join();
  EXPECT_THROW(call_order.take(), std::logic_error);
}

}  // namespace
}  // namespace tritrace
