// render_identity: every setting that changes a render's pixels changes its identity, so that parts
// of different renders never merge (the material and environment fields of issue 12 included).
#include <gtest/gtest.h>

#include <functional>
#include <memory>

#include "tritrace/distributed/render_identity.h"
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

}  // namespace
}  // namespace tritrace
