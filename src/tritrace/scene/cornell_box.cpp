// The lab scene's numbers, transcribed from the fact sheet: room corners, block corners, the
// triangle order and colours, and the scaling to [-1, 1]^3 with x and y negated.
#include "tritrace/scene/cornell_box.h"

#include <array>
#include <cstdint>

namespace tritrace {
namespace {

constexpr float kL = 555.0f;

enum Colour : uint32_t { kRed, kYellow, kGreen, kCyan, kBlue, kPurple, kWhite, kColourCount };

constexpr std::array<glm::vec3, kColourCount> kAlbedo = {
    glm::vec3(0.75f, 0.15f, 0.15f), glm::vec3(0.75f, 0.75f, 0.15f), glm::vec3(0.15f, 0.75f, 0.15f),
    glm::vec3(0.15f, 0.75f, 0.75f), glm::vec3(0.15f, 0.15f, 0.75f), glm::vec3(0.75f, 0.15f, 0.75f),
    glm::vec3(0.75f, 0.75f, 0.75f)};

// v = v * 2/L; v = v - (1,1,1); v.x = -v.x; v.y = -v.y, in that order.
glm::vec3 scale_to_unit_box(glm::vec3 v) {
  v *= 2.0f / kL;
  v -= glm::vec3(1.0f);
  v.x = -v.x;
  v.y = -v.y;
  return v;
}

void add(TriangleMesh& mesh, glm::vec3 a, glm::vec3 b, glm::vec3 c, uint32_t colour) {
  mesh.add(scale_to_unit_box(a), scale_to_unit_box(b), scale_to_unit_box(c), colour);
}

// Corners A..H of a block, in the fact sheet's order.
void add_block(TriangleMesh& mesh, const std::array<glm::vec3, 8>& p, Colour colour) {
  const auto& [A, B, C, D, E, F, G, H] = p;
  add(mesh, E, B, A, colour);
  add(mesh, E, F, B, colour);
  add(mesh, F, D, B, colour);
  add(mesh, F, H, D, colour);
  add(mesh, H, C, D, colour);
  add(mesh, H, G, C, colour);
  add(mesh, G, E, C, colour);
  add(mesh, E, A, C, colour);
  add(mesh, G, F, E, colour);
  add(mesh, G, H, F, colour);
}

}  // namespace

Scene make_cornell_box(const CornellOptions& options) {
  Scene scene;
  for (const glm::vec3& albedo : kAlbedo) scene.materials.push_back({albedo});

  const glm::vec3 A(kL, 0, 0), B(0, 0, 0), C(kL, 0, kL), D(0, 0, kL);
  const glm::vec3 E(kL, kL, 0), F(0, kL, 0), G(kL, kL, kL), H(0, kL, kL);
  TriangleMesh& m = scene.mesh;
  add(m, C, B, A, kGreen);  // floor
  add(m, C, D, B, kGreen);
  add(m, A, E, C, kPurple);  // left wall
  add(m, C, E, G, kPurple);
  add(m, F, B, D, kYellow);  // right wall
  add(m, H, F, D, kYellow);
  add(m, E, F, G, kCyan);  // ceiling
  add(m, F, H, G, kCyan);
  add(m, G, D, C, kWhite);  // back wall
  add(m, G, H, D, kWhite);

  add_block(m,
            {glm::vec3(290, 0, 114), glm::vec3(130, 0, 65), glm::vec3(240, 0, 272),
             glm::vec3(82, 0, 225), glm::vec3(290, 165, 114), glm::vec3(130, 165, 65),
             glm::vec3(240, 165, 272), glm::vec3(82, 165, 225)},
            kRed);
  add_block(m,
            {glm::vec3(423, 0, 247), glm::vec3(265, 0, 296), glm::vec3(472, 0, 406),
             glm::vec3(314, 0, 456), glm::vec3(423, 330, 247), glm::vec3(265, 330, 296),
             glm::vec3(472, 330, 406), glm::vec3(314, 330, 456)},
            kBlue);

  scene.lights.push_back({options.light_position, kLabLightPower});
  scene.ambient = kLabAmbient;
  scene.camera = Camera(options.width, options.height, options.yaw, kLabCameraDistance);
  return scene;
}

Scene make_cornell_area(const CornellOptions& options) {
  Scene scene = make_cornell_box(options);
  scene.lights.clear();
  const uint32_t light = static_cast<uint32_t>(scene.materials.size());
  scene.materials.push_back({.albedo = glm::vec3(0.0f), .emission = kAreaLightRadiance});
  const glm::vec3 a(343, 554, 227), b(343, 554, 332), c(213, 554, 332), d(213, 554, 227);
  // Wound so that the lab normal, normalize(cross(e2, e1)), points down to the floor (+y in the
  // world): the emitting side.
  add(scene.mesh, a, c, b, light);
  add(scene.mesh, a, d, c, light);
  return scene;
}

}  // namespace tritrace
