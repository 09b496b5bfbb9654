// Tessellation of pbrt-v4's quadrics: a (phi, second parameter) grid over each surface, the
// vertices placed exactly on it, so flat triangles inscribe the shape and the vertex normals are
// the shape's own.
#include "tritrace/scene/io/pbrt_shapes.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tritrace {
namespace {

int segments_around(double phimax_degrees) {
  const double share = std::clamp(phimax_degrees, 0.0, 360.0) / 360.0;
  return std::max(3, static_cast<int>(std::ceil(kPbrtTessellationAround * share)));
}

double radians(double degrees) {
  return std::clamp(degrees, 0.0, 360.0) * std::numbers::pi / 180.0;
}

// Fills `mesh` from a grid of (around + 1) x (rows + 1) vertices given by `vertex(i, j)` (which
// sets position, normal and uv), two triangles per cell, counter-clockwise about the normal seen
// from outside, dropping a triangle with two identical corners.
template <typename Vertex>
void grid(PbrtMesh& mesh, int around, int rows, Vertex vertex) {
  const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
  for (int j = 0; j <= rows; ++j) {
    for (int i = 0; i <= around; ++i) {
      glm::vec3 p, n;
      glm::vec2 uv;
      vertex(i, j, p, n, uv);
      mesh.positions.push_back(p);
      mesh.normals.push_back(n);
      mesh.uvs.push_back(uv);
    }
  }
  const auto at = [&](int i, int j) { return base + static_cast<uint32_t>(j * (around + 1) + i); };
  const auto add = [&](uint32_t a, uint32_t b, uint32_t c) {
    const glm::vec3 &pa = mesh.positions[a], &pb = mesh.positions[b], &pc = mesh.positions[c];
    if (pa == pb || pb == pc || pa == pc) return;
    mesh.indices.insert(mesh.indices.end(), {a, b, c});
  };
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < around; ++i) {
      add(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      add(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  }
}

}  // namespace

PbrtMesh tessellate_sphere(double radius, double zmin, double zmax, double phimax_degrees) {
  PbrtMesh mesh;
  const double r = std::abs(radius);
  const double z0 = std::clamp(std::min(zmin, zmax), -r, r);
  const double z1 = std::clamp(std::max(zmin, zmax), -r, r);
  // theta measured from -z, so that rows go from zmin up to zmax (v = 0 at zmin, as in pbrt).
  const double t0 = std::acos(std::clamp(-z0 / r, -1.0, 1.0));
  const double t1 = std::acos(std::clamp(-z1 / r, -1.0, 1.0));
  const double phimax = radians(phimax_degrees);
  const int around = segments_around(phimax_degrees);
  const int rows = std::max(
      2, static_cast<int>(std::ceil(kPbrtTessellationRings * (t1 - t0) / std::numbers::pi)));
  grid(mesh, around, rows, [&](int i, int j, glm::vec3& p, glm::vec3& n, glm::vec2& uv) {
    const double v = static_cast<double>(j) / rows;
    const double u = static_cast<double>(i) / around;
    const double theta = t0 + v * (t1 - t0);
    const double phi = u * phimax;
    // Exact zeros at the poles, so that their corners coincide and are merged.
    const double s = (theta == 0.0 || theta == std::numbers::pi) ? 0.0 : std::sin(theta);
    const glm::dvec3 d(s * std::cos(phi), s * std::sin(phi), -std::cos(theta));
    p = glm::vec3(r * d);
    n = glm::vec3(d);
    uv = glm::vec2(static_cast<float>(u), static_cast<float>(v));
  });
  return mesh;
}

PbrtMesh tessellate_disk(double height, double radius, double inner_radius, double phimax_degrees) {
  PbrtMesh mesh;
  const double phimax = radians(phimax_degrees);
  const int around = segments_around(phimax_degrees);
  grid(mesh, around, 1, [&](int i, int j, glm::vec3& p, glm::vec3& n, glm::vec2& uv) {
    const double u = static_cast<double>(i) / around;
    const double phi = u * phimax;
    // Row 0 the outer rim (pbrt's v = 0), row 1 the inner one; the centre when innerradius is 0.
    const double rho = j == 0 ? radius : inner_radius;
    const double c = rho == 0.0 ? 0.0 : std::cos(phi), s = rho == 0.0 ? 0.0 : std::sin(phi);
    p = glm::vec3(glm::dvec3(rho * c, rho * s, height));
    n = glm::vec3(0.0f, 0.0f, 1.0f);
    uv = glm::vec2(static_cast<float>(u), static_cast<float>(j));
  });
  return mesh;
}

PbrtMesh tessellate_cylinder(double radius, double zmin, double zmax, double phimax_degrees) {
  PbrtMesh mesh;
  const double phimax = radians(phimax_degrees);
  const int around = segments_around(phimax_degrees);
  grid(mesh, around, 1, [&](int i, int j, glm::vec3& p, glm::vec3& n, glm::vec2& uv) {
    const double u = static_cast<double>(i) / around;
    const double phi = u * phimax;
    const double z = j == 0 ? std::min(zmin, zmax) : std::max(zmin, zmax);
    p = glm::vec3(glm::dvec3(radius * std::cos(phi), radius * std::sin(phi), z));
    n = glm::vec3(glm::dvec3(std::cos(phi), std::sin(phi), 0.0));
    uv = glm::vec2(static_cast<float>(u), static_cast<float>(j));
  });
  return mesh;
}

}  // namespace tritrace
