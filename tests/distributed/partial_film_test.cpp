// Partial films: packed tile parts, the EXR codec (round trip, headers checked before allocation)
// and FilmMerger (any arrival order gives the one-process film bit for bit).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "tritrace/accel/make_accel.h"
#include "tritrace/distributed/film_merger.h"
#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/error.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

constexpr uint32_t kSpp = 20;  // two whole blocks of 8 and a partial one
const AovSet kAllAovs{true, true, true, true, true};

class PartialFilmTest : public ::testing::Test {
 protected:
  // 40 x 30: 3 x 2 tiles of 16, the right and bottom ones clipped.
  PartialFilmTest()
      : scene_(make_cornell_area({.width = 40, .height = 30})),
        accel_(make_accel(AccelKind::kBvh, scene_, kDefaultKernel)),
        integrator_(scene_) {
    IntegratorSpec spec;
    spec.kind = IntegratorSpec::Kind::kPath;
    RenderOptions whole;
    whole.spp = kSpp;
    identity_ = render_identity(scene_, spec, whole, "bvh", "watertight", kAllAovs);
  }

  // The image-sized film of samples [first, end) of tile part tile / tiles.
  Film render_range(uint32_t first, uint32_t end, int tile = 0, int tiles = 1,
                    float noise_threshold = 0.0f) const {
    RenderOptions options;
    options.noise_threshold = noise_threshold;
    options.threads = 1;
    options.first_sample = first;
    options.spp = end - first;
    options.tile_part = tile;
    options.tile_parts = tiles;
    Film film(scene_.camera.width(), scene_.camera.height(), kAllAovs);
    render_to_film(scene_, *accel_, integrator_, film, options);
    return film;
  }

  Scene scene_;
  std::unique_ptr<Accel> accel_;
  PathIntegrator integrator_;
  RenderIdentity identity_;
};

// Every layer's sums and AOV sums, as bytes.
bool same_sums(const Film& a, const Film& b, size_t pixels) {
  if (a.layer_count() != b.layer_count() || a.nodes() != b.nodes()) return false;
  for (size_t k = 0; k < a.layer_count(); ++k) {
    if (std::memcmp(a.sums(k), b.sums(k), pixels * sizeof(glm::vec4)) != 0) return false;
    if (std::memcmp(a.aov_sums(k), b.aov_sums(k), pixels * sizeof(AovSums)) != 0) return false;
  }
  return true;
}

TEST(PackedShape, TilePartsTogetherHoldEachPixelOnce) {
  for (auto [w, h] : {std::pair{40, 30}, std::pair{16, 16}, std::pair{1, 1}, std::pair{257, 33}}) {
    const int tile_count = ((w + 15) / 16) * ((h + 15) / 16);
    for (int tiles : {1, 2, 3, tile_count}) {
      if (tiles > tile_count) continue;
      std::vector<int> seen(static_cast<size_t>(w) * static_cast<size_t>(h), 0);
      for (int t = 0; t < tiles; ++t) {
        const PackedShape shape = packed_shape(w, h, t, tiles);
        const std::vector<size_t> pixels = tile_group_pixels(w, h, t, tiles);
        EXPECT_EQ(shape.pixels, pixels.size());
        const size_t cells = static_cast<size_t>(shape.width) * static_cast<size_t>(shape.height);
        EXPECT_GE(cells, shape.pixels);
        EXPECT_LT(cells - shape.pixels, static_cast<size_t>(shape.width)) << "one padded row";
        for (size_t p : pixels) ++seen[p];
      }
      EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int n) { return n == 1; }))
          << w << "x" << h << " in " << tiles;
    }
  }
}

TEST_F(PartialFilmTest, EncodeDecodeKeepsEveryBit) {
  const PartRange range{8, kSpp, 1, 3};
  const Film packed = pack_part(render_range(range.first, range.end, 1, 3), 1, 3);
  const PackedShape shape = packed_shape(40, 30, 1, 3);
  // Tiles 1 and 4 of 3 x 2: 16 x 16 and 16 x 14 pixels, 480 in two rows of 256.
  EXPECT_EQ(shape.pixels, 480u);
  EXPECT_EQ(packed.width(), 256);
  EXPECT_EQ(packed.height(), 2);
  const std::vector<uint8_t> bytes = encode_partial_film(packed, {identity_, range});
  const PartialFilm back = decode_partial_film(bytes, "p.exr");
  EXPECT_EQ(back.info.render, identity_);
  EXPECT_EQ(back.info.range.first, range.first);
  EXPECT_EQ(back.info.range.end, range.end);
  EXPECT_EQ(back.info.range.tile, 1);
  EXPECT_EQ(back.info.range.tiles, 3);
  EXPECT_TRUE(same_sums(packed, back.film, shape.pixels));
}

TEST_F(PartialFilmTest, MergerGivesTheOneProcessFilmInAnyArrivalOrder) {
  const Film whole = render_range(0, kSpp);
  struct Unit {
    PartRange range;
    Film packed;
  };
  std::vector<Unit> units;
  for (int tile = 0; tile < 3; ++tile) {
    for (auto [a, b] : {std::pair{0u, 8u}, std::pair{8u, 16u}, std::pair{16u, kSpp}}) {
      units.push_back({{a, b, tile, 3}, pack_part(render_range(a, b, tile, 3), tile, 3)});
    }
  }
  // In order, reversed, and interleaved across tile parts.
  const std::vector<std::vector<size_t>> orders = {
      {0, 1, 2, 3, 4, 5, 6, 7, 8}, {8, 7, 6, 5, 4, 3, 2, 1, 0}, {2, 5, 8, 1, 4, 7, 0, 3, 6}};
  const std::vector<size_t> most_held = {0, 2, 6};
  for (size_t o = 0; o < orders.size(); ++o) {
    FilmMerger merger(identity_, 3);
    for (size_t i : orders[o]) merger.add(units[i].range, units[i].packed);
    EXPECT_TRUE(merger.complete());
    EXPECT_EQ(merger.held(), 0u);
    EXPECT_EQ(merger.most_held(), most_held[o]) << "order " << o;
    const Film merged = std::move(merger).finish();
    EXPECT_TRUE(same_sums(whole, merged, 40 * 30)) << "order " << o;
  }
}

// Adaptive sampling decides per pixel, so tile parts of [0, spp) (through the codec) merge into the
// one-process film, spp AOV included.
TEST_F(PartialFilmTest, AdaptiveTilePartsMergeIntoTheOneProcessFilm) {
  constexpr uint32_t kMost = 128;
  const Film whole = render_range(0, kMost, 0, 1, 0.05f);
  RenderIdentity identity = identity_;
  identity.spp = kMost;
  FilmMerger merger(identity, 3);
  for (int tile : {2, 0, 1}) {
    const PartRange range{0, kMost, tile, 3};
    const Film packed = pack_part(render_range(0, kMost, tile, 3, 0.05f), tile, 3);
    const PartialFilm back =
        decode_partial_film(encode_partial_film(packed, {identity, range}), "part.exr");
    merger.add(range, back.film);
  }
  ASSERT_TRUE(merger.complete());
  const Film merged = std::move(merger).finish();
  EXPECT_TRUE(same_sums(whole, merged, 40 * 30));
  // Some pixels stopped early, so the counts are not all the same.
  const Image spp = merged.resolve_spp();
  float lo = kMost, hi = 0.0f;
  for (const glm::vec3& p : spp.pixels()) lo = std::min(lo, p.x), hi = std::max(hi, p.x);
  EXPECT_EQ(lo, 64.0f);
  EXPECT_EQ(hi, static_cast<float>(kMost));
}

TEST_F(PartialFilmTest, MergerNamesMissingAndOverlappingRanges) {
  FilmMerger merger(identity_, 1);
  merger.add({0, 8, 0, 1}, pack_part(render_range(0, 8), 0, 1));
  try {
    merger.add({0, 16, 0, 1}, pack_part(render_range(0, 16), 0, 1));
    FAIL() << "an overlapping range was added";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("overlaps"), std::string::npos) << e.what();
  }
  merger.add({16, kSpp, 0, 1}, pack_part(render_range(16, kSpp), 0, 1));
  EXPECT_EQ(merger.held(), 1u);
  try {
    (void)std::move(merger).finish();
    FAIL() << "an incomplete merge finished";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing: samples [8, 20)"), std::string::npos)
        << e.what();
  }
}

// An OpenEXR header written by hand (the format's attribute list), independent of OpenEXR and of
// the codec: a forged partial film whose size and data window claim `side` x `side` pixels.
std::vector<uint8_t> forged_header(int side, size_t file_size) {
  std::vector<uint8_t> b;
  auto i32 = [&](int32_t v) {
    for (int k = 0; k < 4; ++k)
      b.push_back(static_cast<uint8_t>(static_cast<uint32_t>(v) >> (8 * k)));
  };
  auto text = [&](const std::string& s) {
    b.insert(b.end(), s.begin(), s.end());
    b.push_back(0);
  };
  auto attr = [&](const std::string& name, const std::string& type, const std::vector<uint8_t>& v) {
    text(name);
    text(type);
    i32(static_cast<int32_t>(v.size()));
    b.insert(b.end(), v.begin(), v.end());
  };
  auto box = [&](int32_t w, int32_t h) {
    std::vector<uint8_t> v;
    for (int32_t x : {0, 0, w - 1, h - 1}) {
      for (int k = 0; k < 4; ++k)
        v.push_back(static_cast<uint8_t>(static_cast<uint32_t>(x) >> (8 * k)));
    }
    return v;
  };
  auto str = [](const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); };
  i32(20000630);
  i32(2);
  std::vector<uint8_t> channels;
  for (const char* c : {"layer0.B", "layer0.G", "layer0.R", "layer0.W"}) {
    channels.insert(channels.end(), c, c + std::strlen(c) + 1);
    for (int32_t v : {2, 0, 1, 1}) {
      for (int k = 0; k < 4; ++k) channels.push_back(static_cast<uint8_t>(v >> (8 * k)));
    }
  }
  channels.push_back(0);
  attr("channels", "chlist", channels);
  attr("compression", "compression", {3});
  attr("dataWindow", "box2i", box(side, side));
  attr("displayWindow", "box2i", box(side, side));
  attr("lineOrder", "lineOrder", {0});
  const std::string size = std::to_string(side) + "x" + std::to_string(side);
  for (auto [k, v] :
       std::vector<std::pair<std::string, std::string>>{{"format", "tritrace partial film 2"},
                                                        {"render", "0123456789abcdef"},
                                                        {"settings", "integrator=path spp=8"},
                                                        {"build", "version=0 commit=x simd=0"},
                                                        {"integrator", "path"},
                                                        {"seed", "0"},
                                                        {"spp", "8"},
                                                        {"aovs", ""},
                                                        {"size", size},
                                                        {"samples", "0:8"},
                                                        {"tile", "0/1"},
                                                        {"nodes", "0:0"}}) {
    attr("tritrace." + k, "string", str(v));
  }
  b.push_back(0);
  b.resize(std::max(b.size(), file_size), 0);
  return b;
}

void expect_refused(const std::vector<uint8_t>& bytes, const std::string& words) {
  const auto start = std::chrono::steady_clock::now();
  try {
    (void)decode_partial_film(bytes, "forged.exr");
    FAIL() << "a forged header was accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("forged.exr: ", 0), 0u) << m;
    EXPECT_NE(m.find(words), std::string::npos) << m;
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0)
      << "refused at once";
}

TEST(PartialFilmHeader, ImpossibleSizesAreRefusedBeforeAllocation) {
  expect_refused(forged_header(100000, 1024), "100000x100000 image");
  // Within the size limit, but a 16384 x 16384 film of 4 channels in 1 KB cannot be.
  expect_refused(forged_header(16384, 1024), "truncated partial film: 1024 bytes");
  // The forger itself is right: at 16 x 16 the header passes, and the zeros after it are no table
  // of chunks (which OpenEXR would read as a film of zeros).
  expect_refused(forged_header(16, 1024), "corrupt partial film: chunk 0 of 1");
}

TEST_F(PartialFilmTest, TruncatedAndAlteredFilesAreErrorsNamingThem) {
  const PartRange range{0, kSpp, 0, 1};
  std::vector<uint8_t> bytes =
      encode_partial_film(pack_part(render_range(0, kSpp), 0, 1), {identity_, range});
  ASSERT_GT(bytes.size(), 2000u);
  for (size_t keep : {size_t{0}, size_t{7}, size_t{300}, bytes.size() / 2, bytes.size() - 1}) {
    const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<ptrdiff_t>(keep));
    try {
      (void)decode_partial_film(cut, "cut.exr");
      FAIL() << "a file cut to " << keep << " bytes was read";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("cut.exr: ", 0), 0u) << e.what();
    }
  }
}

}  // namespace
}  // namespace tritrace
