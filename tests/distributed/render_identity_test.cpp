// render_identity: every setting that changes a render's pixels changes its identity, so that parts
// of different renders never merge (the material and environment fields of issue 12 included).
#include <gtest/gtest.h>

#include <array>
#include <functional>
#include <memory>
#include <utility>

#include "tritrace/build_info.h"
#include "tritrace/distributed/merge_plan.h"
#include "tritrace/distributed/render_identity.h"
#include "tritrace/error.h"
#include "tritrace/math/simd_lanes.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

std::string identity_of(const Scene& scene) {
  IntegratorSpec spec;
  spec.kind = IntegratorSpec::Kind::kPath;
  RenderOptions options;
  options.spp = 4;
  return render_identity(scene, spec, options, "bvh", "watertight", AovSet{}).hash;
}

// Applies `change` to a copy of the Cornell box and expects a different identity.
void expect_changes_identity(const std::function<void(Scene&)>& change) {
  const Scene base = make_cornell_area();
  Scene changed = base;
  change(changed);
  EXPECT_NE(identity_of(base), identity_of(changed));
}

TEST(RenderIdentity, SameSceneSameIdentity) {
  EXPECT_EQ(identity_of(make_cornell_area()), identity_of(make_cornell_area()));
}

TEST(RenderIdentity, MaterialFieldsChangeIt) {
  expect_changes_identity([](Scene& s) { s.materials[0].type = MaterialType::kConductor; });
  expect_changes_identity([](Scene& s) { s.materials[0].roughness = 0.3f; });
  expect_changes_identity([](Scene& s) { s.materials[0].ior = 1.33f; });
  expect_changes_identity([](Scene& s) { s.materials[0].metallic = 1.0f; });
  expect_changes_identity([](Scene& s) { s.materials[0].transmission = 0.5f; });
}

TEST(RenderIdentity, AlphaModesAndTextureAlphaChangeIt) {
  expect_changes_identity([](Scene& s) { s.materials[0].alpha_mode = AlphaMode::kMask; });
  auto blend = [](float alpha, float cutoff) {
    return [=](Scene& s) {
      s.materials[0].alpha_mode = AlphaMode::kBlend;
      s.materials[0].alpha = alpha;
      s.materials[0].alpha_cutoff = cutoff;
    };
  };
  Scene a = make_cornell_area(), b = a, c = a;
  blend(0.5f, 0.5f)(a);
  blend(0.25f, 0.5f)(b);
  blend(0.5f, 0.75f)(c);
  EXPECT_NE(identity_of(a), identity_of(b));
  EXPECT_NE(identity_of(a), identity_of(c));
  // A texture's alpha channel.
  Scene opaque = make_cornell_area();
  opaque.textures.emplace_back(1, 1, std::vector<glm::vec3>{glm::vec3(0.5f)});
  Scene cut = opaque;
  cut.textures[0].set_alpha({0.0f});
  EXPECT_NE(identity_of(opaque), identity_of(cut));
}

TEST(RenderIdentity, CheckerboardTexturesChangeIt) {
  // Two checkerboards of the same colours (so the same one texel, their mean) that differ only in
  // their scale, or only in which colour is even.
  Checkerboard board;
  board.even = glm::vec3(0.2f);
  board.odd = glm::vec3(0.8f);
  Scene a = make_cornell_area();
  a.textures.push_back(Texture::checkerboard(board));
  Scene b = make_cornell_area(), c = b;
  board.scale = {2.0f, 1.0f};
  b.textures.push_back(Texture::checkerboard(board));
  std::swap(board.even, board.odd);
  board.scale = glm::vec2(1.0f);
  c.textures.push_back(Texture::checkerboard(board));
  EXPECT_NE(identity_of(a), identity_of(b));
  EXPECT_NE(identity_of(a), identity_of(c));
}

TEST(RenderIdentity, SpotAndDirectionalLightsChangeIt) {
  const SpotLight spot{.position = {0.0f, -0.9f, 0.0f},
                       .direction = {0.0f, 1.0f, 0.0f},
                       .intensity = glm::vec3(2.0f),
                       .cos_inner = 0.95f,
                       .cos_outer = 0.9f};
  expect_changes_identity([&](Scene& s) { s.spot_lights.push_back(spot); });
  Scene with_spot = make_cornell_area();
  with_spot.spot_lights.push_back(spot);
  for (auto edit : std::initializer_list<std::function<void(SpotLight&)>>{
           [](SpotLight& l) { l.position.x = 0.1f; }, [](SpotLight& l) { l.direction.x = 0.1f; },
           [](SpotLight& l) { l.intensity.z = 3.0f; }, [](SpotLight& l) { l.cos_inner = 0.96f; },
           [](SpotLight& l) { l.cos_outer = 0.8f; },
           [](SpotLight& l) { l.falloff = SpotFalloff::kSmoothstep; }}) {
    Scene changed = with_spot;
    edit(changed.spot_lights[0]);
    EXPECT_NE(identity_of(with_spot), identity_of(changed));
  }
  const DirectionalLight sun{.direction = {0.0f, 1.0f, 0.0f}, .irradiance = glm::vec3(1.0f)};
  expect_changes_identity([&](Scene& s) { s.directional_lights.push_back(sun); });
  Scene with_sun = make_cornell_area();
  with_sun.directional_lights.push_back(sun);
  Scene brighter = with_sun, turned = with_sun;
  brighter.directional_lights[0].irradiance.y = 2.0f;
  turned.directional_lights[0].direction = {0.0f, 0.0f, 1.0f};
  EXPECT_NE(identity_of(with_sun), identity_of(brighter));
  EXPECT_NE(identity_of(with_sun), identity_of(turned));
}

TEST(RenderIdentity, EnvironmentChangesIt) {
  expect_changes_identity([](Scene& s) { s.environment = glm::vec3(0.5f); });
  auto map = std::make_shared<EnvironmentMap>();
  map->width = 2;
  map->height = 1;
  map->texels = {glm::vec3(1.0f), glm::vec3(2.0f)};
  expect_changes_identity([&](Scene& s) { s.environment_map = map; });
  Scene with_map = make_cornell_area();
  with_map.environment_map = map;
  for (auto edit : std::initializer_list<std::function<void(EnvironmentMap&)>>{
           [](EnvironmentMap& m) { m.scale = 2.0f; },
           [](EnvironmentMap& m) { m.rotate_degrees = 90.0f; },
           [](EnvironmentMap& m) { m.texels[1] = glm::vec3(3.0f); },
           [](EnvironmentMap& m) {
             m.width = 1;
             m.height = 2;
           }}) {
    Scene changed = with_map;
    auto edited = std::make_shared<EnvironmentMap>(*map);
    edit(*edited);
    changed.environment_map = edited;
    EXPECT_NE(identity_of(with_map), identity_of(changed));
  }
}

// A scene whose own mesh is empty and whose one prototype, placed twice, has corner normals and
// texture coordinates: what an instanced glTF model holds.
Scene instanced_smooth_scene() {
  Scene s = make_cornell_area();
  TriangleMesh proto;
  const std::array<glm::vec3, 3> normals = {glm::vec3(0, 0, -1), glm::vec3(0, 0.6f, -0.8f),
                                            glm::vec3(0.6f, 0, -0.8f)};
  const std::array<glm::vec2, 3> uvs = {glm::vec2(0, 0), glm::vec2(1, 0), glm::vec2(0, 1)};
  proto.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, &normals, &uvs);
  s.prototypes = {proto};
  for (float x : {-0.5f, 0.5f}) {
    Instance inst;
    inst.prototype = 0;
    inst.to_world.translation = {x, 0, 0};
    inst.to_object = inverse(inst.to_world);
    s.instances.push_back(inst);
  }
  return s;
}

// Rebuilds prototype 0 with corner `corner` of triangle 0's normal or uv replaced.
void edit_prototype(Scene& s, const glm::vec3* normal, const glm::vec2* uv) {
  const TriangleMesh& old = s.prototypes[0];
  std::array<glm::vec3, 3> normals;
  std::array<glm::vec2, 3> uvs;
  for (int k = 0; k < 3; ++k) {
    normals[k] = old.corner_normals()[static_cast<size_t>(k)];
    uvs[k] = old.corner_uvs()[static_cast<size_t>(k)];
  }
  if (normal) normals[1] = *normal;
  if (uv) uvs[2] = *uv;
  TriangleMesh changed;
  changed.add(old.vertex(0, 0), old.vertex(0, 1), old.vertex(0, 2), old.material()[0], &normals,
              &uvs);
  s.prototypes[0] = changed;
}

TEST(RenderIdentity, InstancedPrototypesNormalsAndUvsChangeIt) {
  const Scene base = instanced_smooth_scene();
  ASSERT_EQ(base.prototypes[0].corner_normals().size(), 3u);
  ASSERT_EQ(base.prototypes[0].corner_uvs().size(), 3u);
  Scene same = base;
  edit_prototype(same, nullptr, nullptr);
  EXPECT_EQ(identity_of(base), identity_of(same)) << "rebuilding the same prototype";
  Scene normal = base;
  const glm::vec3 n(0.0f, 0.8f, -0.6f);
  edit_prototype(normal, &n, nullptr);
  EXPECT_NE(identity_of(base), identity_of(normal));
  Scene uv = base;
  const glm::vec2 t(0.0f, 0.5f);
  edit_prototype(uv, nullptr, &t);
  EXPECT_NE(identity_of(base), identity_of(uv));
}

RenderIdentity identity_with(std::string_view accel, std::string_view kernel) {
  IntegratorSpec spec;
  spec.kind = IntegratorSpec::Kind::kPath;
  RenderOptions options;
  options.spp = 4;
  return render_identity(make_cornell_area(), spec, options, accel, kernel, AovSet{});
}

// brute, bvh and bvh-single report the same hits with one kernel (tests/accel/bvh_test.cpp:
// BvhVsBrute for every kernel), so their parts must merge; another kernel or Embree must not.
TEST(RenderIdentity, HoldsTheKernelNotTheAccel) {
  const RenderIdentity bvh = identity_with("bvh", "watertight");
  EXPECT_EQ(bvh, identity_with("brute", "watertight"));
  EXPECT_EQ(bvh, identity_with("bvh-single", "watertight"));
  EXPECT_EQ(identity_with("brute", "moller-trumbore"), identity_with("bvh", "moller-trumbore"));
  EXPECT_NE(bvh.hash, identity_with("bvh", "moller-trumbore").hash);
  EXPECT_NE(bvh.hash, identity_with("embree", "watertight").hash);
  EXPECT_NE(identity_with("embree", "watertight").hash,
            identity_with("embree-robust", "watertight").hash);
  EXPECT_EQ(bvh.settings.find("accel"), std::string::npos) << bvh.settings;
  EXPECT_NE(bvh.settings.find("kernel=watertight"), std::string::npos) << bvh.settings;
}

TEST(RenderIdentity, NamesTheBuild) {
  const RenderIdentity id = identity_with("bvh", "watertight");
  EXPECT_EQ(id.build, build_text());
  EXPECT_NE(id.build.find("simd=" + std::to_string(simd::kLanes)), std::string::npos) << id.build;
  EXPECT_NE(id.build.find("version=" + std::string(build_version())), std::string::npos);
  EXPECT_NE(id.build.find("commit="), std::string::npos) << id.build;
  EXPECT_FALSE(build_commit().empty());
}

PartInfo part(const RenderIdentity& r, uint32_t first, uint32_t end) {
  return PartInfo{r, PartRange{first, end, 0, 1}};
}

TEST(PlanMerge, RefusesPartsOfAnotherBuildNamingBoth) {
  RenderIdentity ours = identity_with("bvh", "watertight");
  ours.spp = 16;
  RenderIdentity theirs = ours;
  theirs.build = "version=0.1.0 commit=0123456789ab simd=8";
  try {
    plan_merge({"a.exr", "b.exr"}, {part(ours, 0, 8), part(theirs, 8, 16)});
    FAIL() << "parts of two builds were accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("b.exr"), std::string::npos) << m;
    EXPECT_NE(m.find("foreign part"), std::string::npos) << m;
    EXPECT_NE(m.find(theirs.build), std::string::npos) << m;
    EXPECT_NE(m.find(ours.build), std::string::npos) << m;
  }
  EXPECT_EQ(plan_merge({"a.exr", "b.exr"}, {part(ours, 8, 16), part(ours, 0, 8)}),
            (std::vector<size_t>{1, 0}));
}

TEST(RenderIdentity, DifferenceSaysWhatDiffers) {
  const RenderIdentity a = identity_with("bvh", "watertight");
  EXPECT_EQ(identity_difference(a, a), "");
  RenderIdentity b = a;
  b.build = "version=0.1.0 commit=0123456789ab simd=8";
  const std::string build = identity_difference(b, a);
  EXPECT_EQ(build.rfind("another build (", 0), 0u) << build;
  EXPECT_NE(build.find("commit=0123456789ab"), std::string::npos) << build;
  EXPECT_NE(build.find("commit=" + std::string(build_commit())), std::string::npos) << build;
  const RenderIdentity c = identity_with("bvh", "cramer");
  const std::string settings = identity_difference(c, a);
  EXPECT_NE(settings.find("kernel=cramer, not kernel=watertight"), std::string::npos) << settings;
  RenderIdentity d = a;
  d.hash = "0000000000000000";
  EXPECT_EQ(identity_difference(d, a),
            "another scene (render 0000000000000000, not " + a.hash + ")");
}

}  // namespace
}  // namespace tritrace
