// add_all_checked, the parallel way loaders add a whole mesh, against add_checked called triangle
// by triangle (the oracle): the same arrays to the bit and the same counts, on meshes with
// degenerate and non-finite triangles, broken corner normals and texture coordinates.
#include "tritrace/scene/io/triangle_filter.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <utility>
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

// Every array of the two meshes, bit for bit.
void expect_same_triangles(const TriangleMesh& got, const TriangleMesh& want) {
  EXPECT_TRUE(same_bits(got.v0(), want.v0()));
  EXPECT_TRUE(same_bits(got.v1(), want.v1()));
  EXPECT_TRUE(same_bits(got.v2(), want.v2()));
  EXPECT_TRUE(same_bits(got.normal(), want.normal()));
  EXPECT_TRUE(same_bits(got.material(), want.material()));
  EXPECT_TRUE(same_bits(got.corner_normals(), want.corner_normals()));
  EXPECT_TRUE(same_bits(got.corner_uvs(), want.corner_uvs()));
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
      expect_same_triangles(got, want);
      EXPECT_EQ(got.has_shading_normals(), normals);
      EXPECT_EQ(got.has_uvs(), uvs);
    }
  }
}

// The indexed form (the native PLY reader's: shared vertices, three indices per triangle) adds
// what the corner form with the same corners adds, one by one.
TEST(AddAllChecked, IndexedCornersGiveTheMeshOfTheirCorners) {
  const Loaded m = random_mesh(70'000, true, false, 21u);
  // Every corner a vertex of its own, in a shuffled order, plus vertices no triangle uses.
  std::vector<glm::vec3> positions(m.corners.size() + 100, glm::vec3(7.0f));
  std::vector<uint32_t> indices(m.corners.size());
  std::vector<uint32_t> slot(positions.size());
  std::iota(slot.begin(), slot.end(), 0u);
  std::shuffle(slot.begin(), slot.end(), std::mt19937(5));
  for (size_t k = 0; k < m.corners.size(); ++k) {
    indices[k] = slot[k];
    positions[slot[k]] = m.corners[k];
  }
  TriangleMesh want;
  LoadStats want_stats;
  for (size_t k = 0; k < m.material.size(); ++k) {
    add_checked(want, m.corners[3 * k], m.corners[3 * k + 1], m.corners[3 * k + 2], m.material[k],
                &m.normals[3 * k], nullptr, want_stats);
  }
  TriangleMesh got;
  LoadStats got_stats;
  add_all_checked(got, CornerView(positions, indices), m.material, m.normals, m.uvs, got_stats);
  ASSERT_GT(want_stats.dropped_degenerate, 100u);
  EXPECT_EQ(got_stats.dropped_degenerate, want_stats.dropped_degenerate);
  EXPECT_EQ(got_stats.dropped_non_finite, want_stats.dropped_non_finite);
  ASSERT_EQ(got.size(), want.size());
  expect_same_triangles(got, want);
}

// The scene file's way of adding a mesh file before add_all_checked (the oracle): triangle by
// triangle, the material id checked, then the scene's limit, then the transform applied to corners
// and normals and add_checked called. Returns the error met, adding nothing when there is one.
AddResult add_one_by_one(TriangleMesh& mesh, const Loaded& m, const AddOptions& o, LoadStats& stats,
                         size_t* stopped_at = nullptr) {
  TriangleMesh copy = mesh;
  LoadStats counted = stats;
  size_t stored = o.stored;
  for (size_t k = 0; k < m.material.size(); ++k) {
    if (stopped_at != nullptr) *stopped_at = k;
    if (!o.material && m.material[k] >= o.materials) return AddResult::kMaterialOutOfRange;
    if (stored >= o.max_triangles) return AddResult::kTooManyTriangles;
    glm::vec3 v[3], n[3];
    for (size_t i = 0; i < 3; ++i) {
      v[i] = o.transform ? o.transform->apply(m.corners[3 * k + i]) : m.corners[3 * k + i];
      if (!m.normals.empty()) {
        n[i] = o.transform ? o.transform->apply_normal(m.normals[3 * k + i]) : m.normals[3 * k + i];
      }
    }
    const uint32_t id = o.material ? *o.material : o.material_offset + m.material[k];
    stored += add_checked(copy, v[0], v[1], v[2], id, m.normals.empty() ? nullptr : n,
                          m.uvs.empty() ? nullptr : &m.uvs[3 * k], counted)
                  ? 1
                  : 0;
  }
  mesh = std::move(copy);
  stats = counted;
  return AddResult::kOk;
}

void expect_same_mesh(const TriangleMesh& got, const TriangleMesh& want) {
  ASSERT_EQ(got.size(), want.size());
  expect_same_triangles(got, want);
}

// A mesh already holding a few triangles (with corner normals and uvs or not), as a scene's mesh
// holds a generator's triangles before a file's.
TriangleMesh held_mesh(bool normals, bool uvs) {
  TriangleMesh mesh;
  const std::array<glm::vec3, 3> n = {glm::vec3(0, 0, 1), glm::vec3(0, 1, 0), glm::vec3(1, 0, 0)};
  const std::array<glm::vec2, 3> t = {glm::vec2(0.25f), glm::vec2(0.5f), glm::vec2(0.75f)};
  for (int k = 0; k < 5; ++k) {
    const float x = static_cast<float>(k);
    mesh.add({x, 0, 0}, {x, 1, 0}, {x, 0, 1}, 2, normals ? &n : nullptr, uvs ? &t : nullptr);
  }
  return mesh;
}

TEST(AddAllChecked, AppendsMovedAndRenumberedTrianglesAsAddingOneByOne) {
  Transform turn;
  turn.translate = glm::vec3(0.5f, -2.0f, 3.0f);
  const float c = std::cos(0.7f), s = std::sin(0.7f);
  turn.rotate = glm::mat3(c, 0, -s, 0, 1, 0, s, 0, c);
  turn.scale = glm::vec3(1.5f, -0.25f, 3.0f);
  for (const bool normals : {false, true}) {
    for (const bool uvs : {false, true}) {
      const Loaded m = random_mesh(70'001, normals, uvs, 11u + normals + 2u * uvs);
      for (const bool held_normals : {false, true}) {
        for (const bool held_uvs : {false, true}) {
          for (const int variant : {0, 1, 2}) {
            AddOptions o;
            if (variant >= 1) o.transform = turn;
            if (variant == 2) {
              o.material = 9;
            } else {
              o.material_offset = 3;
              o.materials = 7;
            }
            o.stored = 12;
            o.max_triangles = kMaxSceneTriangles;
            TriangleMesh want = held_mesh(held_normals, held_uvs), got = want;
            LoadStats want_stats{.meshes = 1, .dropped_degenerate = 4}, got_stats = want_stats;
            SCOPED_TRACE(testing::Message()
                         << "normals " << normals << ", uvs " << uvs << ", held normals "
                         << held_normals << ", held uvs " << held_uvs << ", variant " << variant);
            ASSERT_EQ(add_one_by_one(want, m, o, want_stats), AddResult::kOk);
            ASSERT_EQ(add_all_checked(got, m.corners, m.material, m.normals, m.uvs, o, got_stats),
                      AddResult::kOk);
            ASSERT_GT(want_stats.dropped_non_finite, 1000u);
            EXPECT_EQ(got_stats.dropped_degenerate, want_stats.dropped_degenerate);
            EXPECT_EQ(got_stats.dropped_non_finite, want_stats.dropped_non_finite);
            expect_same_mesh(got, want);
          }
        }
      }
    }
  }
}

TEST(AddAllChecked, MeetsTheFirstErrorAddingOneByOneWouldAndAddsNothing) {
  const Loaded m = random_mesh(140'000, true, false, 5u);
  const size_t n = m.material.size();
  bool met[3] = {};  // each AddResult at least once
  AddOptions o;
  o.materials = 7;
  o.stored = 3;
  // Limits met inside the first chunk, near the end of the first (the next chunk's first triangle
  // or the last one's), near the last triangle, and not met; each with a bad material id at fixed
  // places and just before, at and after the triangle where the limit stops the oracle.
  for (const size_t limit : {size_t{1000}, size_t{60'000}, size_t{61'000}, size_t{62'000},
                             size_t{129'000}, size_t{133'000}, size_t{200'000}}) {
    o.max_triangles = limit;
    size_t stop = n;
    {
      TriangleMesh scratch;
      LoadStats ignored;
      if (add_one_by_one(scratch, m, o, ignored, &stop) == AddResult::kOk) stop = n;
    }
    for (const size_t bad :
         {size_t{0}, size_t{40'000}, size_t{65'535}, size_t{65'536}, stop - 1, stop, stop + 1, n}) {
      if (bad > n) continue;
      Loaded broken = m;
      if (bad < n) broken.material[bad] = 7;
      TriangleMesh want = held_mesh(false, true), got = want;
      LoadStats want_stats, got_stats;
      const AddResult expected = add_one_by_one(want, broken, o, want_stats);
      met[static_cast<int>(expected)] = true;
      SCOPED_TRACE(testing::Message()
                   << "limit " << limit << " (stops at " << stop << "), bad id at " << bad);
      EXPECT_EQ(add_all_checked(got, broken.corners, broken.material, broken.normals, broken.uvs, o,
                                got_stats),
                expected);
      EXPECT_EQ(got_stats.dropped_degenerate, want_stats.dropped_degenerate);
      EXPECT_EQ(got_stats.dropped_non_finite, want_stats.dropped_non_finite);
      expect_same_mesh(got, want);
    }
  }
  EXPECT_TRUE(met[0] && met[1] && met[2]);
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
