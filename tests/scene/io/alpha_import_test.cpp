// glTF's alphaMode, alphaCutoff, base colour alpha and texture alpha, read from a hand-written file
// (tests/data/gltf/alpha_modes.gltf: a wall at z = -1 and three unit quads at z = 0 with an
// eight-column alpha texture, alpha 255 255 0 0 0 255 255 255, clamped), and the rays that pass
// them once loaded.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "tritrace/accel/alpha_tested_accel.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/scene/io/mesh_import.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

const std::string kFile = std::string(TRITRACE_SOURCE_DIR) + "/tests/data/gltf/alpha_modes.gltf";

TEST(AlphaImport, ReadsModesCutoffFactorAndTextureAlpha) {
  const ImportedMesh mesh = import_mesh_file(kFile);
  ASSERT_GE(mesh.materials.size(), 4u);
  ASSERT_EQ(mesh.material_names[1], "mask");
  const Material& wall = mesh.materials[0];
  const Material& mask = mesh.materials[1];
  const Material& blend = mesh.materials[2];
  const Material& opaque = mesh.materials[3];
  EXPECT_EQ(wall.alpha_mode, AlphaMode::kOpaque);
  EXPECT_EQ(mask.alpha_mode, AlphaMode::kMask);
  EXPECT_FLOAT_EQ(mask.alpha_cutoff, 0.4f);
  EXPECT_FLOAT_EQ(mask.alpha, 1.0f);
  ASSERT_TRUE(mask.albedo_texture.present());
  const TextureImage& t = mesh.textures[static_cast<size_t>(mask.albedo_texture.index)];
  EXPECT_EQ(t.alpha, (std::vector<uint8_t>{255, 255, 0, 0, 0, 255, 255, 255}));
  EXPECT_EQ(mask.albedo_texture.wrap_s, WrapMode::kClamp);
  EXPECT_EQ(blend.alpha_mode, AlphaMode::kBlend);
  EXPECT_FLOAT_EQ(blend.alpha, 0.3f);
  // alphaMode absent: OPAQUE, whatever the factor and texture say.
  EXPECT_EQ(opaque.alpha_mode, AlphaMode::kOpaque);
}

// Rays along -z through an 80 x 8 grid over quad [x0, x0 + 1] x [0, 1]: how many reach the wall.
int passing(const Accel& accel, float x0, int columns = 80, int rows = 8) {
  std::vector<Ray> rays;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < columns; ++i) {
      rays.push_back({{x0 + (i + 0.5f) / columns, (j + 0.5f) / rows, 1.0f}, {0, 0, -1}});
    }
  }
  std::vector<Hit> hits(rays.size());
  accel.intersect(rays, hits);
  int n = 0;
  for (const Hit& h : hits) n += h.found() && std::abs(h.t - 2.0f) < 1e-5f;
  return n;
}

// The mask's cutoff 0.4 moves the borders off the texel edges: between texel centres 1 and 2
// (alpha 1 to 0) alpha = 1 - f drops below 0.4 at f = 0.6, texel coordinate 1.6, u = 2.1 / 8;
// between 4 and 5 (0 to 1) alpha = f stays below 0.4 up to u = 4.9 / 8. Transparent: 2.8 / 8 of
// u, which is 28 of 80 columns (u = (i + 0.5) / 80 in (21/80, 49/80): i = 21 ... 48).
TEST(AlphaImport, LoadedMaskPassesRaysWhereAlphaIsBelowTheCutoff) {
  const LoadedScene loaded = load_scene(kFile);
  const auto accel = make_accel(AccelKind::kBvh, loaded.scene, kDefaultKernel);
  ASSERT_NE(dynamic_cast<const AlphaTestedAccel*>(accel.get()), nullptr);
  EXPECT_EQ(passing(*accel, 0.0f), 28 * 8);
  EXPECT_EQ(passing(*accel, 3.5f), 0);  // the opaque quad with the same texture
  // The blended quad (alpha 0.3) passes 70% within 4 binomial standard deviations.
  const double n = 80.0 * 80.0;
  EXPECT_NEAR(passing(*accel, 2.0f, 80, 80) / n, 0.7, 4.0 * std::sqrt(0.21 / n));
}

}  // namespace
}  // namespace tritrace
