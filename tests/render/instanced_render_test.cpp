// Instanced scenes render like the same scene flattened into one mesh: the lab and path
// integrators, bit for bit, where the transforms make the arithmetic exact.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <vector>

#include "tritrace/accel/make_accel.h"
#include "tritrace/distributed/render_identity.h"
#include "tritrace/render/film.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

bool same_bits(const Image& a, const Image& b) {
  return a.pixels().size() == b.pixels().size() &&
         std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)) ==
             0;
}

Affine diagonal(glm::vec3 s) {
  Affine a;
  a.linear = glm::mat3(glm::vec3(s.x, 0, 0), glm::vec3(0, s.y, 0), glm::vec3(0, 0, s.z));
  return a;
}

// The lab box with its two blocks (triangles 10 to 19 and 20 to 29) made prototypes, each placed
// as it was and again mirrored or at half size: one power of two on every axis, each axis's sign
// free, about the box's centre (the origin). Such a scale moves every coordinate by an exact
// factor (the same on every axis, so the watertight kernel picks the same axes), so
// flattening and the rays' move into object space round nothing, and each kernel operation on the
// scaled values gives the scaled result: the hits, shading points and shadow rays are those of
// the flattened scene bit for bit. (A translation would not do: o - t rounds for the arbitrary
// origin of a shadow ray.)
Scene instanced_lab_box(const Scene& box) {
  Scene s = box;
  s.mesh = TriangleMesh();
  TriangleMesh blocks[2];
  for (uint32_t i = 0; i < box.mesh.size(); ++i) {
    TriangleMesh& to = i < 10 || i >= 30 ? s.mesh : blocks[i < 20 ? 0 : 1];
    to.add(box.mesh.vertex(i, 0), box.mesh.vertex(i, 1), box.mesh.vertex(i, 2),
           box.mesh.material()[i]);
  }
  s.prototypes = {blocks[0], blocks[1]};
  add_instance(s, 0, diagonal({1, 1, 1}));
  add_instance(s, 1, diagonal({1, 1, 1}));
  add_instance(s, 0, diagonal({-1, 1, 1}));           // mirrored across x = 0
  add_instance(s, 1, diagonal({0.5f, 0.5f, -0.5f}));  // half size, mirrored in z, floating
  add_instance(s, 0, diagonal({0.5f, -0.5f, 0.5f}));  // half size, upside down
  return s;
}

TEST(InstancedRender, LabImageIsTheFlattenedScenesBitForBit) {
  const Scene s = instanced_lab_box(make_cornell_box({.width = 96, .height = 72, .yaw = 0.3}));
  ASSERT_EQ(s.mesh.size(), 10u) << "the room stays in the scene's own mesh";
  const Scene flat = flattened(s);
  ASSERT_EQ(s.drawn_triangles(), flat.mesh.size());
  const LabIntegrator lab;
  const auto flat_accel = make_accel(AccelKind::kBvh, flat, kDefaultKernel);
  const Image want = render(flat, *flat_accel, lab);
  for (AccelKind kind : {AccelKind::kBvh, AccelKind::kBvhSingle, AccelKind::kBrute}) {
    const auto accel = make_accel(kind, s, kDefaultKernel);
    EXPECT_TRUE(same_bits(want, render(s, *accel, lab))) << accel_name(kind);
  }
  // The instances are in the picture: without them it differs.
  Scene bare = s;
  bare.instances.clear();
  const auto bare_accel = make_accel(AccelKind::kBvh, bare, kDefaultKernel);
  EXPECT_FALSE(same_bits(want, render(bare, *bare_accel, lab)));
}

TEST(InstancedRender, PathImageIsTheFlattenedScenesBitForBit) {
  const Scene s = instanced_lab_box(make_cornell_area({.width = 40, .height = 30}));
  ASSERT_EQ(s.mesh.size(), 12u) << "the room and the area light stay in the scene's own mesh";
  const Scene flat = flattened(s);
  const PathIntegrator pt_flat(flat), pt(s);
  const auto flat_accel = make_accel(AccelKind::kBvh, flat, kDefaultKernel);
  const RenderOptions options{.spp = 8, .seed = 3};
  const Image want = render(flat, *flat_accel, pt_flat, options);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  EXPECT_TRUE(same_bits(want, render(s, *accel, pt, options)));
}

// The same scene with vertex normals bent away from the face normals and texture coordinates on
// every mesh (the scene's own and the prototypes), the blocks' materials textured: instances
// shade smooth and textured as their flattened copies do, the normals moved by the inverse
// transpose of each transform (mirrored and scaled here).
Scene smooth_textured(Scene s) {
  auto bend = [](TriangleMesh& m) {
    TriangleMesh out;
    for (uint32_t i = 0; i < m.size(); ++i) {
      std::array<glm::vec3, 3> normals;
      std::array<glm::vec2, 3> uvs;
      for (int k = 0; k < 3; ++k) {
        const glm::vec3 p = m.vertex(i, k);
        normals[static_cast<size_t>(k)] = glm::normalize(m.normal()[i] + 0.4f * glm::sin(3.0f * p));
        uvs[static_cast<size_t>(k)] = glm::vec2(p.x + 0.3f * p.z, p.y - 0.2f * p.z);
      }
      out.add(m.vertex(i, 0), m.vertex(i, 1), m.vertex(i, 2), m.material()[i], &normals, &uvs);
    }
    m = out;
  };
  bend(s.mesh);
  for (TriangleMesh& p : s.prototypes) bend(p);
  TextureImage image{.width = 4, .height = 3, .rgb = {}, .alpha = {}};
  for (int k = 0; k < 36; ++k) image.rgb.push_back(static_cast<uint8_t>(40 + 37 * k % 200));
  s.textures = {Texture::from_srgb8(image)};
  for (const TriangleMesh& p : s.prototypes) {
    for (uint32_t m : p.material()) s.materials[m].albedo_texture.index = 0;
  }
  return s;
}

TEST(InstancedRender, SmoothTexturedPathImageIsTheFlattenedScenesBitForBit) {
  const Scene s =
      smooth_textured(instanced_lab_box(make_cornell_area({.width = 40, .height = 30})));
  ASSERT_TRUE(s.smooth(s.instances.back().first_prim));
  const Scene flat = flattened(s);
  ASSERT_TRUE(flat.mesh.has_shading_normals() && flat.mesh.has_uvs());
  const PathIntegrator pt_flat(flat), pt(s);
  const auto flat_accel = make_accel(AccelKind::kBvh, flat, kDefaultKernel);
  const RenderOptions options{.spp = 8, .seed = 5};
  Film want(40, 30, AovSet{.albedo = true}), got(40, 30, AovSet{.albedo = true});
  render_to_film(flat, *flat_accel, pt_flat, want, options);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  render_to_film(s, *accel, pt, got, options);
  EXPECT_TRUE(same_bits(want.resolve(), got.resolve()));
  EXPECT_TRUE(same_bits(want.resolve_albedo(), got.resolve_albedo()));
  // The normals and the texture show: the instanced scene without them renders otherwise.
  Scene plain = s;
  for (TriangleMesh& p : plain.prototypes) {
    TriangleMesh bare;
    for (uint32_t i = 0; i < p.size(); ++i) {
      bare.add(p.vertex(i, 0), p.vertex(i, 1), p.vertex(i, 2), p.material()[i]);
    }
    p = bare;
  }
  const auto plain_accel = make_accel(AccelKind::kBvh, plain, kDefaultKernel);
  EXPECT_FALSE(
      same_bits(got.resolve(), render(plain, *plain_accel, PathIntegrator(plain), options)));
}

// glTF's corner attributes on prototypes: tangents (w = +1 and -1 alternating) under a normal map,
// and vertex colours. An instance moves its tangents with its transform and turns w where the
// transform mirrors (two of the placements do), as flattened() stores them. Interpolating before or
// after the transform rounds differently, so the images agree to rounding (mean absolute pixel
// difference below 1e-4 of the mean pixel), not bit for bit; the normal map shows (without it the
// mean difference is above 1e-3 of the mean pixel: measured 2.7e-3, the blocks being a small part
// of the image).
TEST(InstancedRender, NormalMappedColouredInstancesRenderAsTheFlattenedScene) {
  Scene s = smooth_textured(instanced_lab_box(make_cornell_area({.width = 40, .height = 30})));
  for (TriangleMesh& p : s.prototypes) {
    for (uint32_t i = 0; i < p.size(); ++i) {
      glm::vec4 tangents[3], colours[3];
      for (int k = 0; k < 3; ++k) {
        const glm::vec3 v = p.vertex(i, k);
        tangents[k] = glm::vec4(1.0f, 0.3f * v.y, -0.2f, i % 2 == 0 ? 1.0f : -1.0f);
        colours[k] = glm::vec4(0.5f + 0.5f * glm::abs(glm::sin(3.0f * v)), 1.0f);
      }
      p.set_extras(i, tangents, colours, nullptr);
    }
  }
  TextureImage normals{.width = 2, .height = 2, .rgb = {}, .alpha = {}, .srgb = false};
  normals.rgb = {170, 128, 240, 100, 150, 245, 128, 90, 240, 150, 160, 240};
  s.textures.push_back(Texture::from_image(normals));
  for (const TriangleMesh& p : s.prototypes) {
    for (uint32_t m : p.material()) {
      s.materials[m].normal_texture.index = static_cast<int32_t>(s.textures.size() - 1);
    }
  }
  const Scene flat = flattened(s);
  ASSERT_TRUE(flat.mesh.has_tangents() && flat.mesh.has_colours());
  const RenderOptions options{.spp = 8, .seed = 5};
  const auto flat_accel = make_accel(AccelKind::kBvh, flat, kDefaultKernel);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  const Image want = render(flat, *flat_accel, PathIntegrator(flat), options);
  const Image got = render(s, *accel, PathIntegrator(s), options);
  // The mean over pixels and channels of |a - b|, and of a.
  const auto mean_difference = [](const Image& a, const Image& b) {
    double sum = 0.0;
    for (int y = 0; y < a.height(); ++y) {
      for (int x = 0; x < a.width(); ++x) {
        const glm::vec3 d = glm::abs(a.at(x, y) - b.at(x, y));
        sum += d.x + d.y + d.z;
      }
    }
    return sum / (3.0 * a.width() * a.height());
  };
  const Image black(want.width(), want.height());
  const double level = mean_difference(want, black);
  EXPECT_LT(mean_difference(got, want), 1e-4 * level);
  Scene plain = s;
  for (Material& m : plain.materials) m.normal_texture = TextureRef{};
  const auto plain_accel = make_accel(AccelKind::kBvh, plain, kDefaultKernel);
  EXPECT_GT(mean_difference(render(plain, *plain_accel, PathIntegrator(plain), options), got),
            1e-3 * level);
}

// Instances of a glowing prototype are lights the light sampler chooses, as the flattened copy's
// triangles are: the same lights in the same order, so the same image bit for bit (before, they
// were found by BSDF sampling only: unbiased, but another image).
TEST(InstancedRender, EmissiveInstancesAreSampledLikeTheFlattenedScenesLights) {
  Scene s = instanced_lab_box(make_cornell_area({.width = 40, .height = 30}));
  Material glow;
  glow.albedo = glm::vec3(0.5f);
  glow.emission = glm::vec3(2.0f, 1.0f, 0.5f);
  s.materials.push_back(glow);
  TriangleMesh& block = s.prototypes[1];
  TriangleMesh glowing;
  for (uint32_t i = 0; i < block.size(); ++i) {
    glowing.add(block.vertex(i, 0), block.vertex(i, 1), block.vertex(i, 2),
                static_cast<uint32_t>(s.materials.size() - 1));
  }
  block = glowing;
  const Scene flat = flattened(s);
  const PathIntegrator pt_flat(flat), pt(s);
  const auto flat_accel = make_accel(AccelKind::kBvh, flat, kDefaultKernel);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  const RenderOptions options{.spp = 8, .seed = 9};
  EXPECT_TRUE(
      same_bits(render(flat, *flat_accel, pt_flat, options), render(s, *accel, pt, options)));
}

// Parts of one render are merged only when their identities agree: an instance's transform or a
// prototype's vertex changes pixels, so each must change the identity.
TEST(InstancedRender, TransformsAndPrototypesAreInTheRenderIdentity) {
  const Scene s = instanced_lab_box(make_cornell_box({.width = 16, .height = 16}));
  auto identity = [](const Scene& scene) {
    return render_identity(scene, IntegratorSpec{}, RenderOptions{}, "bvh", "watertight", AovSet{})
        .hash;
  };
  const std::string base = identity(s);
  EXPECT_EQ(base, identity(instanced_lab_box(make_cornell_box({.width = 16, .height = 16}))));
  Scene moved = s;
  moved.instances[2].to_world.translation.x += 0x1p-20f;
  EXPECT_NE(base, identity(moved));
  Scene turned = s;
  turned.instances[1].to_world.linear[0][1] = 0x1p-20f;
  EXPECT_NE(base, identity(turned));
  Scene other = s;
  std::swap(other.instances[0].prototype, other.instances[1].prototype);
  EXPECT_NE(base, identity(other));
  Scene reshaped = s;
  TriangleMesh& proto = reshaped.prototypes[0];
  TriangleMesh changed;
  for (uint32_t i = 0; i < proto.size(); ++i) {
    glm::vec3 a = proto.vertex(i, 0);
    if (i == 0) a.y += 0x1p-16f;
    changed.add(a, proto.vertex(i, 1), proto.vertex(i, 2), proto.material()[i]);
  }
  proto = changed;
  EXPECT_NE(base, identity(reshaped));
}

}  // namespace
}  // namespace tritrace
