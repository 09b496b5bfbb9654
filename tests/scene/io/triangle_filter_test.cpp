// add_all_checked, the parallel way loaders add a whole mesh, against add_checked called triangle
// by triangle (the oracle): the same arrays to the bit and the same counts, on meshes with
// degenerate and non-finite triangles, broken corner normals and texture coordinates.
#include "tritrace/scene/io/triangle_filter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "tritrace/scene/io/load_progress.h"

namespace tritrace {
namespace {

struct Loaded {
  std::vector<glm::vec3> corners, normals;
  std::vector<glm::vec2> uvs;
  std::vector<uint32_t> material;
};

// n random triangles; about one in twenty degenerate (a repeated corner) and one in forty with a
// NaN or infinite corner; normals sometimes zero, NaN or huge; uvs sometimes NaN.
Loaded random_mesh(size_t n, bool normals, bool uvs, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> coord(-10.0f, 10.0f);
  std::uniform_int_distribution<int> pick(0, 79);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  Loaded m;
  for (size_t k = 0; k < n; ++k) {
    glm::vec3 v[3];
    for (glm::vec3& p : v) p = {coord(rng), coord(rng), coord(rng)};
    const int r = pick(rng);
    if (r < 4) v[2] = v[0];
    if (r == 4) v[1].y = nan;
    if (r == 5) v[2].x = inf;
    for (const glm::vec3& p : v) m.corners.push_back(p);
    m.material.push_back(static_cast<uint32_t>(k % 7));
    for (int c = 0; c < 3; ++c) {
      const int s = pick(rng);
      if (normals) {
        glm::vec3 nrm(coord(rng), coord(rng), coord(rng));
        if (s == 0) nrm = glm::vec3(0.0f);
        if (s == 1) nrm.z = nan;
        if (s == 2) nrm = glm::vec3(3e38f);
        m.normals.push_back(nrm);
      }
      if (uvs) m.uvs.push_back(s == 3 ? glm::vec2(nan, 0.5f) : glm::vec2(coord(rng), coord(rng)));
    }
  }
  return m;
}

template <typename T>
bool same_bits(const HugePageVector<T>& a, const HugePageVector<T>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

TEST(AddAllChecked, GivesTheMeshAndCountsOfAddingOneByOne) {
  for (const bool normals : {false, true}) {
    for (const bool uvs : {false, true}) {
      // More than one chunk of 65536, and a last one partly filled.
      const Loaded m = random_mesh(150'001, normals, uvs, 7u + normals + 2u * uvs);
      TriangleMesh want;
      LoadStats want_stats;
      for (size_t k = 0; k < m.material.size(); ++k) {
        add_checked(want, m.corners[3 * k], m.corners[3 * k + 1], m.corners[3 * k + 2],
                    m.material[k], normals ? &m.normals[3 * k] : nullptr,
                    uvs ? &m.uvs[3 * k] : nullptr, want_stats);
      }
      TriangleMesh got;
      LoadStats got_stats;
      add_all_checked(got, m.corners, m.material, m.normals, m.uvs, got_stats);
      SCOPED_TRACE(testing::Message() << "normals " << normals << ", uvs " << uvs);
      ASSERT_GT(want_stats.dropped_degenerate, 1000u);
      ASSERT_GT(want_stats.dropped_non_finite, 1000u);
      EXPECT_EQ(got_stats.dropped_degenerate, want_stats.dropped_degenerate);
      EXPECT_EQ(got_stats.dropped_non_finite, want_stats.dropped_non_finite);
      ASSERT_EQ(got.size(), want.size());
      EXPECT_TRUE(same_bits(got.v0(), want.v0()));
      EXPECT_TRUE(same_bits(got.v1(), want.v1()));
      EXPECT_TRUE(same_bits(got.v2(), want.v2()));
      EXPECT_TRUE(same_bits(got.normal(), want.normal()));
      EXPECT_TRUE(same_bits(got.material(), want.material()));
      EXPECT_TRUE(same_bits(got.corner_normals(), want.corner_normals()));
      EXPECT_TRUE(same_bits(got.corner_uvs(), want.corner_uvs()));
      EXPECT_EQ(got.has_shading_normals(), normals);
      EXPECT_EQ(got.has_uvs(), uvs);
    }
  }
}

TEST(AddAllChecked, ReportsItsStepToTheThreadsProgress) {
  const Loaded m = random_mesh(100'000, false, false, 3u);
  LoadProgress progress;
  EXPECT_EQ(progress.describe(), "");
  {
    const LoadProgressScope report(&progress);
    TriangleMesh mesh;
    LoadStats stats;
    add_all_checked(mesh, m.corners, m.material, {}, {}, stats);
  }
  EXPECT_EQ(progress.describe(), "adding triangles 100%");
  // Outside the scope the thread reports nowhere.
  TriangleMesh mesh;
  LoadStats stats;
  LoadProgress other;
  add_all_checked(mesh, m.corners, m.material, {}, {}, stats);
  EXPECT_EQ(other.describe(), "");
}

TEST(LoadProgress, DescribesTheStepAndItsPercentage) {
  LoadProgress p;
  p.begin("reading", 200);
  EXPECT_EQ(p.describe(), "reading 0%");
  p.advance(87);
  EXPECT_EQ(p.describe(), "reading 43%");
  p.advance(113);
  EXPECT_EQ(p.describe(), "reading 100%");
  p.begin("importing", 0);
  EXPECT_EQ(p.describe(), "importing");
  LoadProgress child;
  child.begin("parsing", 4);
  child.set(1);
  p.follow(&child);
  EXPECT_EQ(p.describe(), "parsing 25%");
  p.follow(nullptr);
  EXPECT_EQ(p.describe(), "importing");
}

}  // namespace
}  // namespace tritrace
