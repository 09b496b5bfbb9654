// Smooth shading from vertex normals: the mesh's interpolation, normals turned to the geometric
// side, the terminator-safe ray origin, and renders of a low-poly sphere read from OBJ and
// PLY files with vertex normals (smooth across facet edges, no black terminator, the white
// furnace), and an open sheet with bent normals that lets no light through.
#include "tritrace/render/shading_normal.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/math/random.h"
#include "tritrace/math/sampling.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/scene_file.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;

TEST(ShadingNormals, InterpolateTheCornerNormals) {
  TriangleMesh mesh;
  const glm::vec3 n0 = glm::normalize(glm::vec3(0, 0, -1)),
                  n1 = glm::normalize(glm::vec3(1, 0, -1)),
                  n2 = glm::normalize(glm::vec3(0, 1, -1));
  mesh.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, {n0, n1, n2});
  EXPECT_TRUE(mesh.has_shading_normals());
  EXPECT_NEAR(glm::length(mesh.shading_normal(0, 0.0f, 0.0f) - n0), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::length(mesh.shading_normal(0, 1.0f, 0.0f) - n1), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::length(mesh.shading_normal(0, 0.0f, 1.0f) - n2), 0.0f, 1e-6f);
  // Half way along the edge from corner 1 to corner 2: the normalised mean of n1 and n2.
  const glm::vec3 mid = glm::normalize(n1 + n2);
  EXPECT_NEAR(glm::length(mesh.shading_normal(0, 0.5f, 0.5f) - mid), 0.0f, 1e-6f);
}

TEST(ShadingNormals, MeshesWithoutNormalsStoreNoneAndGiveTheGeometricNormal) {
  TriangleMesh mesh;
  mesh.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0);
  EXPECT_FALSE(mesh.has_shading_normals());
  EXPECT_EQ(mesh.shading_normal(0, 0.2f, 0.3f), mesh.normal()[0]);
  // A triangle with normals gives the earlier one its geometric normal at each corner.
  const glm::vec3 up(0, 0, 1);
  mesh.add({0, 0, 1}, {1, 0, 1}, {0, 1, 1}, 0, {up, up, up});
  ASSERT_EQ(mesh.corner_normals().size(), 6u);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(mesh.corner_normals()[k], mesh.normal()[0]);
  mesh.add({0, 0, 2}, {1, 0, 2}, {0, 1, 2}, 0);  // and later ones too
  ASSERT_EQ(mesh.corner_normals().size(), 9u);
  EXPECT_EQ(mesh.corner_normals()[8], mesh.normal()[2]);

  TriangleMesh flat;
  flat.add({5, 0, 0}, {6, 0, 0}, {5, 1, 0}, 1);
  flat.append(mesh, 0);
  ASSERT_EQ(flat.corner_normals().size(), 12u);
  EXPECT_EQ(flat.corner_normals()[0], flat.normal()[0]);
  EXPECT_EQ(flat.corner_normals()[6], up);
}

TEST(ShadingNormals, AreTurnedToTheGeometricSide) {
  TriangleMesh mesh;
  const glm::vec3 away(0.1f, 0.0f, 1.0f);  // the geometric normal is (0, 0, -1)
  mesh.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, {away, away, away});
  const glm::vec3 ng = mesh.normal()[0];
  ASSERT_EQ(ng, glm::vec3(0, 0, -1));
  const glm::vec3 ns = oriented_shading_normal(mesh, 0, 0.3f, 0.3f, ng);
  EXPECT_GT(glm::dot(ns, ng), 0.0f);
  EXPECT_NEAR(glm::length(ns + glm::normalize(away)), 0.0f, 1e-6f);
}

// Hanika's origin: unchanged on a flat patch and at the corners themselves, lifted off the facet
// where the corner normals lean outwards (convex), unchanged where they lean inwards (concave).
TEST(ShadingNormals, TerminatorSafePointLiesOnTheCurvedSurface) {
  const glm::vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  TriangleMesh flat, convex, concave;
  const glm::vec3 up(0, 0, -1);  // the geometric normal, normalize(cross(e2, e1))
  flat.add(a, b, c, 0, {up, up, up});
  ASSERT_EQ(flat.normal()[0], up);
  // Outward-leaning normals, as on a sphere seen from outside: away from the centroid.
  const glm::vec3 centroid = (a + b + c) / 3.0f;
  std::array<glm::vec3, 3> out, in;
  for (int k = 0; k < 3; ++k) {
    const glm::vec3 p = flat.vertex(0, k);
    out[static_cast<size_t>(k)] = glm::normalize(up + 0.5f * (p - centroid));
    in[static_cast<size_t>(k)] = glm::normalize(up - 0.5f * (p - centroid));
  }
  convex.add(a, b, c, 0, out);
  concave.add(a, b, c, 0, in);
  for (auto [u, v] : {std::pair{0.2f, 0.3f}, std::pair{0.5f, 0.5f}, std::pair{0.1f, 0.1f}}) {
    const glm::vec3 x = a + u * (b - a) + v * (c - a);
    EXPECT_EQ(terminator_safe_point(flat, 0, u, v, x, up), x);
    EXPECT_EQ(terminator_safe_point(concave, 0, u, v, x, up), x);
    const glm::vec3 lifted = terminator_safe_point(convex, 0, u, v, x, up);
    EXPECT_GT(glm::dot(lifted - x, up), 1e-3f) << u << " " << v;
    // By the formula: x plus the barycentric blend of its lifts onto each corner's tangent plane.
    glm::vec3 want = x;
    const float w[3] = {1 - u - v, u, v};
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 n = out[static_cast<size_t>(k)];
      const float d = glm::dot(x - convex.vertex(0, k), n);
      if (d < 0) want -= w[k] * d * n;
    }
    EXPECT_NEAR(glm::length(lifted - want), 0.0f, 1e-6f);
    // Asked for the other side, the outward normals lean inwards from there: nothing moves.
    EXPECT_EQ(terminator_safe_point(convex, 0, u, v, x, -up), x);
  }
  for (int k = 0; k < 3; ++k) {  // at a corner the corner's own plane holds the point
    const float u = k == 1 ? 1.0f : 0.0f, v = k == 2 ? 1.0f : 0.0f;
    const glm::vec3 x = convex.vertex(0, k);
    EXPECT_NEAR(glm::length(terminator_safe_point(convex, 0, u, v, x, up) - x), 0.0f, 1e-6f);
  }
}

// A UV sphere of radius 1 (slices around, stacks from pole to pole) with each vertex's normal its
// position: the exact sphere's normals at the vertices.
struct SphereMesh {
  std::vector<glm::vec3> points;
  std::vector<std::array<int, 3>> faces;  // counter-clockwise seen from outside
};

SphereMesh uv_sphere(int stacks, int slices) {
  SphereMesh s;
  s.points.emplace_back(0, 1, 0);
  for (int i = 1; i < stacks; ++i) {
    const double theta = std::numbers::pi * i / stacks;
    for (int j = 0; j < slices; ++j) {
      const double phi = 2 * std::numbers::pi * j / slices;
      s.points.emplace_back(std::sin(theta) * std::cos(phi), std::cos(theta),
                            std::sin(theta) * std::sin(phi));
    }
  }
  s.points.emplace_back(0, -1, 0);
  const int bottom = static_cast<int>(s.points.size()) - 1;
  auto ring = [&](int i, int j) { return 1 + (i - 1) * slices + (j % slices); };
  auto face = [&](int a, int b, int c) {
    const glm::vec3 pa = s.points[a], pb = s.points[b], pc = s.points[c];
    if (glm::dot(glm::cross(pb - pa, pc - pa), pa + pb + pc) < 0.0f) std::swap(b, c);
    s.faces.push_back({a, b, c});
  };
  for (int j = 0; j < slices; ++j) {
    face(0, ring(1, j), ring(1, j + 1));
    face(bottom, ring(stacks - 1, j), ring(stacks - 1, j + 1));
    for (int i = 1; i + 1 < stacks; ++i) {
      face(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1));
      face(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1));
    }
  }
  return s;
}

// normal_sign -1 writes every vertex normal pointing into the sphere.
std::string obj_text(const SphereMesh& s, bool normals, float normal_sign = 1.0f) {
  std::ostringstream out;
  out.precision(9);
  for (const glm::vec3& p : s.points) out << "v " << p.x << ' ' << p.y << ' ' << p.z << '\n';
  if (normals) {
    for (const glm::vec3& p : s.points) {
      const glm::vec3 n = normal_sign * p;
      out << "vn " << n.x << ' ' << n.y << ' ' << n.z << '\n';
    }
  }
  for (const auto& f : s.faces) {
    out << 'f';
    for (int k : f) out << ' ' << k + 1 << (normals ? "//" + std::to_string(k + 1) : "");
    out << '\n';
  }
  return out.str();
}

std::string ply_text(const SphereMesh& s) {
  std::ostringstream out;
  out.precision(9);
  out << "ply\nformat ascii 1.0\nelement vertex " << s.points.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\n"
         "property float ny\nproperty float nz\nelement face "
      << s.faces.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const glm::vec3& p : s.points) {
    out << p.x << ' ' << p.y << ' ' << p.z << ' ' << p.x << ' ' << p.y << ' ' << p.z << '\n';
  }
  for (const auto& f : s.faces) out << "3 " << f[0] << ' ' << f[1] << ' ' << f[2] << '\n';
  return out.str();
}

class SmoothSphere : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("tritrace-smooth-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    const SphereMesh sphere = uv_sphere(7, 12);
    std::ofstream(dir_ / "smooth.obj") << obj_text(sphere, true);
    std::ofstream(dir_ / "flat.obj") << obj_text(sphere, false);
    std::ofstream(dir_ / "inward.obj") << obj_text(sphere, true, -1.0f);
    std::ofstream(dir_ / "smooth.ply") << ply_text(sphere);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The sphere, diffuse, seen from -z, lit by a point light or by a uniform environment.
  Scene scene(const std::string& file, const std::string& albedo, bool furnace) const {
    const std::string light =
        furnace ? R"("environment": {"color": [1, 1, 1]},)"
                : R"("lights": [{"position": [2, -1, -3], "power": [60, 60, 60]}],)";
    const std::string text = R"({"camera": {"position": [0, 0, -3.2], "look_at": [0, 0, 0],
        "up": [0, -1, 0], "vertical_fov": 42, "width": 40, "height": 40},)" +
                             light + R"("materials": [{"name": "m", "albedo": )" + albedo +
                             R"(}], "meshes": [{"file": ")" + file + R"(", "material": "m"}]})";
    LoadedScene loaded = parse_scene_json(text, (dir_ / "scene.json").string());
    apply_overrides(loaded, {});
    return std::move(loaded.scene);
  }

  fs::path dir_;
};

TEST_F(SmoothSphere, FilesWithVertexNormalsGiveShadingNormals) {
  EXPECT_FALSE(scene("flat.obj", "[1, 1, 1]", true).mesh.has_shading_normals());
  for (const char* file : {"smooth.obj", "smooth.ply"}) {
    const Scene s = scene(file, "[1, 1, 1]", true);
    ASSERT_TRUE(s.mesh.has_shading_normals()) << file;
    // Every corner's normal is the sphere's normal there, its position, and faces outwards as the
    // (swapped) geometric normal does.
    for (size_t t = 0; t < s.mesh.size(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const glm::vec3 n = s.mesh.corner_normals()[3 * t + static_cast<size_t>(k)];
        EXPECT_NEAR(glm::length(n - s.mesh.vertex(t, k)), 0.0f, 1e-5f) << file << " " << t;
      }
      EXPECT_GT(glm::dot(s.mesh.normal()[t], s.mesh.corner_normals()[3 * t]), 0.0f);
    }
  }
}

struct SphereImage {
  Image image{1, 1};
  std::vector<uint32_t> prim;  // the triangle at each pixel's centre, kNoHit for none
  std::vector<glm::vec3> point;
  std::vector<uint8_t> inside;  // the pixel and its 8 neighbours see the sphere at their centres
};

SphereImage render_direct(const Scene& scene) {
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator direct(scene, PathSettings{.max_depth = 1});
  SphereImage out;
  out.image = render(scene, accel, direct, {.spp = 16, .seed = 2});
  const BruteForceAccel brute(scene.mesh, kDefaultKernel);
  for (int y = 0; y < scene.camera.height(); ++y) {
    for (int x = 0; x < scene.camera.width(); ++x) {
      const Ray ray =
          scene.camera.ray_through(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
      const Hit hit = brute.intersect(ray);
      out.prim.push_back(hit.found() ? hit.prim : kNoHit);
      out.point.push_back(ray.origin + hit.t * ray.dir);
    }
  }
  const int w = scene.camera.width(), h = scene.camera.height();
  out.inside.assign(out.prim.size(), 0);
  for (int y = 1; y + 1 < h; ++y) {
    for (int x = 1; x + 1 < w; ++x) {
      bool all = true;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) all = all && out.prim[(y + dy) * w + x + dx] != kNoHit;
      }
      out.inside[static_cast<size_t>(y * w + x)] = all;
    }
  }
  return out;
}

double brightness(glm::vec3 c) {
  return (c.x + c.y + c.z) / 3.0;
}

// Direct light on the sphere: where the exact sphere's normal faces the light by more than
// `min_cos`, the mean jump in brightness between horizontal neighbours on different facets.
double mean_facet_edge_jump(const SphereImage& s, int width, double min_cos) {
  const glm::vec3 light(2, -1, -3);
  double sum = 0.0;
  int pairs = 0;
  for (size_t i = 0; i + 1 < s.prim.size(); ++i) {
    if (static_cast<int>(i % static_cast<size_t>(width)) == width - 1) continue;
    if (!s.inside[i] || !s.inside[i + 1] || s.prim[i] == s.prim[i + 1]) continue;
    bool lit = true;
    for (size_t k : {i, i + 1}) {
      const glm::vec3 p = s.point[k];
      lit = lit && glm::dot(glm::normalize(p), glm::normalize(light - p)) > min_cos;
    }
    if (!lit) continue;
    sum += std::abs(brightness(s.image.pixels()[i]) - brightness(s.image.pixels()[i + 1]));
    ++pairs;
  }
  EXPECT_GT(pairs, 20);
  return sum / std::max(pairs, 1);
}

TEST_F(SmoothSphere, ShadesSmoothlyAcrossFacetEdges) {
  const SphereImage flat = render_direct(scene("flat.obj", "[0.8, 0.8, 0.8]", false));
  for (const char* file : {"smooth.obj", "smooth.ply"}) {
    const SphereImage smooth = render_direct(scene(file, "[0.8, 0.8, 0.8]", false));
    const double flat_jump = mean_facet_edge_jump(flat, 40, 0.2);
    const double smooth_jump = mean_facet_edge_jump(smooth, 40, 0.2);
    EXPECT_LT(smooth_jump, 0.35 * flat_jump) << file << ": flat " << flat_jump;
  }
}

// The shadow terminator: where the smooth sphere faces the light, no pixel is black (a facet that
// the shading normal calls lit but whose own plane faces away from the light, or a shadow ray
// blocked by the neighbouring facets, would make it so), and the brightness follows the sphere's
// cosine.
TEST_F(SmoothSphere, HasNoBlackTerminator) {
  const SphereImage smooth = render_direct(scene("smooth.obj", "[0.8, 0.8, 0.8]", false));
  const glm::vec3 light(2, -1, -3);
  int lit = 0;
  for (size_t i = 0; i < smooth.prim.size(); ++i) {
    if (!smooth.inside[i]) continue;  // silhouette pixels average with the black background
    const glm::vec3 p = smooth.point[i];
    const glm::vec3 to_light = light - p;
    const double cos_exact = glm::dot(glm::normalize(p), glm::normalize(to_light));
    if (cos_exact > 0.2) {
      ++lit;
      EXPECT_GT(brightness(smooth.image.pixels()[i]), 0.0) << "pixel " << i << " cos " << cos_exact;
    }
    if (cos_exact > 0.5) {
      // Lambert under a point light: rho / pi * P / (4 pi r^2) * cos; the interpolated normal of
      // this low-poly sphere is within a few degrees of the exact one (and the pixel's area
      // averages), hence the 12 %.
      const double want = 0.8 / std::numbers::pi * 60.0 / (4.0 * std::numbers::pi) /
                          glm::dot(to_light, to_light) * cos_exact;
      EXPECT_NEAR(brightness(smooth.image.pixels()[i]), want, 0.12 * want) << "pixel " << i;
    }
  }
  EXPECT_GT(lit, 150);
}

// Vertex normals that point into the sphere are turned to the geometric side: exactly the image of
// the outward ones.
TEST_F(SmoothSphere, InwardVertexNormalsAreFlippedToTheGeometricSide) {
  const SphereImage outward = render_direct(scene("smooth.obj", "[0.8, 0.8, 0.8]", false));
  const SphereImage inward = render_direct(scene("inward.obj", "[0.8, 0.8, 0.8]", false));
  ASSERT_EQ(outward.image.pixels().size(), inward.image.pixels().size());
  for (size_t i = 0; i < outward.image.pixels().size(); ++i) {
    EXPECT_EQ(outward.image.pixels()[i], inward.image.pixels()[i]) << "pixel " << i;
  }
}

// The white furnace with smooth shading: Lambert about the shading normal reflects albedo 1 at
// every bounce except for the directions that shading_agrees drops (between the facet's plane and
// the shading normal's, near the silhouette of this 12-slice sphere), so an albedo-1 sphere in a
// uniform environment of radiance 1 never exceeds 1 and falls short of it by little. Measured at
// 32 spp: image mean 0.995, darkest pixel 0.9375, brightest 1 (light sampling of the environment
// uses the bounce's cosine density: no noise is added). A rule that let light in (a pixel above 1)
// or lost whole lobes fails.
TEST_F(SmoothSphere, WhiteFurnaceLosesOnlyWhatTheShadingRuleDrops) {
  const Scene s = scene("smooth.obj", "[1, 1, 1]", true);
  ASSERT_TRUE(s.mesh.has_shading_normals());
  const BvhAccel accel(s.mesh, kDefaultKernel);
  const PathIntegrator integrator(s);
  const Image image = render(s, accel, integrator, {.spp = 32, .seed = 4});
  double sum = 0.0, sum2 = 0.0;
  double lo = 1.0, hi = 1.0;
  for (const glm::vec3& p : image.pixels()) {
    EXPECT_GT(brightness(p), 0.85);
    EXPECT_LT(brightness(p), 1.0 + 1e-5);
    lo = std::min(lo, brightness(p));
    hi = std::max(hi, brightness(p));
    sum += brightness(p);
    sum2 += brightness(p) * brightness(p);
  }
  const double n = static_cast<double>(image.pixels().size());
  const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / (n - 1.0));
  ::testing::Test::RecordProperty("mean", std::to_string(mean));
  ::testing::Test::RecordProperty("darkest", std::to_string(lo));
  ::testing::Test::RecordProperty("brightest", std::to_string(hi));
  EXPECT_LT(mean, 1.0 + 4.0 * se);
  EXPECT_GT(mean, 0.98);
}

// An open sheet (the square [-1, 1]^2 of the plane y = 0, 8 x 8 quads, its lab normal -y: up in
// the lab's y-down world) whose vertex normals lean outwards by up to 60 degrees, lit only from
// below: a point light beside and below its edge and a large emitter under it facing up. Nothing
// above it reflects, so no light can reach its top side: every pixel of a camera looking down on
// it must be exactly black, whatever the material (the rule of shading_agrees: a direction below
// the triangle's plane carries no light to its top even where the bent normal faces it).
Scene bent_sheet(const Material& material, bool from_below) {
  Scene scene;
  scene.materials.push_back(material);
  scene.materials.push_back(Material{.albedo = glm::vec3(0.0f), .emission = glm::vec3(4.0f)});
  constexpr int kQuads = 8;
  const auto point = [](int i, int j) {
    return glm::vec3(-1.0f + 2.0f * i / kQuads, 0.0f, -1.0f + 2.0f * j / kQuads);
  };
  const auto normal = [](glm::vec3 p) {
    return glm::normalize(glm::vec3(1.7f * p.x, -1.0f, 1.7f * p.z));
  };
  for (int i = 0; i < kQuads; ++i) {
    for (int j = 0; j < kQuads; ++j) {
      const glm::vec3 a = point(i, j), b = point(i + 1, j), c = point(i + 1, j + 1),
                      d = point(i, j + 1);
      // Wound so that normalize(cross(e2, e1)) = -y.
      scene.mesh.add(a, c, b, 0, {normal(a), normal(c), normal(b)});
      scene.mesh.add(a, d, c, 0, {normal(a), normal(d), normal(c)});
    }
  }
  // The emitter at y = 0.5 (below), wider than the sheet, emitting upwards (-y).
  scene.mesh.add({-6, 0.5f, -6}, {-6, 0.5f, 6}, {6, 0.5f, 6}, 1);
  scene.mesh.add({-6, 0.5f, -6}, {6, 0.5f, 6}, {6, 0.5f, -6}, 1);
  scene.lights.push_back(PointLight{.position = {1.6f, 0.15f, 0.0f}, .power = glm::vec3(40.0f)});
  // Looking straight down at the sheet from above, seeing [-0.9, 0.9]^2 of it, or up at its
  // underside from between it and the emitter.
  const float y = from_below ? 0.45f : -1.5f;
  scene.camera = Camera::look_at(24, 24, {0.0f, y, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f},
                                 Camera::focal_for_vertical_fov(24, from_below ? 90.0 : 62.0));
  return scene;
}

class OpenSheet : public ::testing::TestWithParam<int> {};

TEST_P(OpenSheet, WithBentNormalsLeaksNoLightFromBelow) {
  const Material materials[] = {
      Material{.albedo = glm::vec3(0.8f)},
      Material{.albedo = glm::vec3(0.9f), .type = MaterialType::kConductor, .roughness = 0.7f},
      Material{.albedo = glm::vec3(0.8f), .type = MaterialType::kPrincipled, .roughness = 0.6f}};
  const Material& m = materials[GetParam()];
  const Scene above = bent_sheet(m, false);
  ASSERT_TRUE(above.mesh.has_shading_normals());
  const BvhAccel accel(above.mesh, kDefaultKernel);
  const PathIntegrator integrator(above);
  const Image top = render(above, accel, integrator, {.spp = 64, .seed = 9});
  int lit = 0;
  for (const glm::vec3& p : top.pixels()) lit += p != glm::vec3(0.0f);
  EXPECT_EQ(lit, 0) << "pixels of the sheet's top that light from below reached";
  // The light is there: the sheet's underside, seen between it and the emitter, is lit.
  const Scene below = bent_sheet(m, true);
  const Image bottom = render(below, accel, PathIntegrator(below), {.spp = 16, .seed = 9});
  for (const glm::vec3& p : bottom.pixels()) EXPECT_GT(p.x + p.y + p.z, 0.0f);
}

std::string sheet_material_name(const ::testing::TestParamInfo<int>& info) {
  constexpr const char* kNames[] = {"diffuse", "rough_conductor", "principled"};
  return kNames[info.param];
}

INSTANTIATE_TEST_SUITE_P(Materials, OpenSheet, ::testing::Values(0, 1, 2), sheet_material_name);

}  // namespace
}  // namespace tritrace
