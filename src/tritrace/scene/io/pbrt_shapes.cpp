// Tessellation of pbrt-v4's quadrics: a (phi, second parameter) grid over each surface, the
// vertices placed exactly on it, so flat triangles inscribe the shape and the vertex normals are
// the shape's own.
#include "tritrace/scene/io/pbrt_shapes.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <map>
#include <numbers>
#include <utility>

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

namespace {

double loop_beta(size_t valence) {
  return valence == 3 ? 3.0 / 16.0 : 3.0 / (8.0 * static_cast<double>(valence));
}

// One mesh's edges: for each (lo, hi) vertex pair, the vertices opposite it in its faces.
struct EdgeInfo {
  uint32_t midpoint = 0;  // the new vertex's index
  std::vector<uint32_t> opposite;
};

using EdgeMap = std::map<std::pair<uint32_t, uint32_t>, EdgeInfo>;

EdgeMap edges_of(const std::vector<uint32_t>& indices) {
  EdgeMap edges;
  for (size_t t = 0; t + 2 < indices.size(); t += 3) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = indices[t + static_cast<size_t>(k)];
      const uint32_t b = indices[t + static_cast<size_t>((k + 1) % 3)];
      const uint32_t c = indices[t + static_cast<size_t>((k + 2) % 3)];
      edges[std::minmax(a, b)].opposite.push_back(c);
    }
  }
  return edges;
}

// Each vertex's neighbours and its neighbours along boundary edges (edges of one face).
void rings(size_t vertices, const EdgeMap& edges, std::vector<std::vector<uint32_t>>& ring,
           std::vector<std::vector<uint32_t>>& boundary) {
  ring.assign(vertices, {});
  boundary.assign(vertices, {});
  for (const auto& [e, info] : edges) {
    ring[e.first].push_back(e.second);
    ring[e.second].push_back(e.first);
    if (info.opposite.size() == 1) {
      boundary[e.first].push_back(e.second);
      boundary[e.second].push_back(e.first);
    }
  }
}

}  // namespace

PbrtMesh loop_subdivide(const std::vector<glm::vec3>& positions,
                        const std::vector<uint32_t>& indices, int levels) {
  std::vector<glm::dvec3> p(positions.begin(), positions.end());
  std::vector<uint32_t> tri = indices;
  std::vector<std::vector<uint32_t>> ring, boundary;
  for (int level = 0; level < levels; ++level) {
    EdgeMap edges = edges_of(tri);
    rings(p.size(), edges, ring, boundary);
    std::vector<glm::dvec3> next(p.size());
    for (size_t v = 0; v < p.size(); ++v) {
      if (ring[v].empty()) {
        next[v] = p[v];
      } else if (boundary[v].empty()) {
        const double beta = loop_beta(ring[v].size());
        glm::dvec3 sum(0.0);
        for (uint32_t n : ring[v]) sum += p[n];
        next[v] = (1.0 - static_cast<double>(ring[v].size()) * beta) * p[v] + beta * sum;
      } else if (boundary[v].size() == 2) {
        next[v] = 0.75 * p[v] + 0.125 * (p[boundary[v][0]] + p[boundary[v][1]]);
      } else {
        next[v] = p[v];
      }
    }
    for (auto& [e, info] : edges) {
      info.midpoint = static_cast<uint32_t>(next.size());
      const glm::dvec3 mid = p[e.first] + p[e.second];
      if (info.opposite.size() == 2) {
        next.push_back(0.375 * mid + 0.125 * (p[info.opposite[0]] + p[info.opposite[1]]));
      } else {
        next.push_back(0.5 * mid);
      }
    }
    std::vector<uint32_t> finer;
    finer.reserve(tri.size() * 4);
    for (size_t t = 0; t + 2 < tri.size(); t += 3) {
      const uint32_t v0 = tri[t], v1 = tri[t + 1], v2 = tri[t + 2];
      const uint32_t e01 = edges.at(std::minmax(v0, v1)).midpoint;
      const uint32_t e12 = edges.at(std::minmax(v1, v2)).midpoint;
      const uint32_t e20 = edges.at(std::minmax(v2, v0)).midpoint;
      finer.insert(finer.end(), {v0, e01, e20, v1, e12, e01, v2, e20, e12, e01, e12, e20});
    }
    p = std::move(next);
    tri = std::move(finer);
  }
  // The limit positions.
  rings(p.size(), edges_of(tri), ring, boundary);
  PbrtMesh mesh;
  mesh.positions.resize(p.size());
  for (size_t v = 0; v < p.size(); ++v) {
    glm::dvec3 limit = p[v];
    if (!ring[v].empty() && boundary[v].empty()) {
      const double n = static_cast<double>(ring[v].size());
      const double gamma = 1.0 / (n + 3.0 / (8.0 * loop_beta(ring[v].size())));
      glm::dvec3 sum(0.0);
      for (uint32_t w : ring[v]) sum += p[w];
      limit = (1.0 - n * gamma) * p[v] + gamma * sum;
    } else if (boundary[v].size() == 2) {
      limit = 0.6 * p[v] + 0.2 * (p[boundary[v][0]] + p[boundary[v][1]]);
    }
    mesh.positions[v] = glm::vec3(limit);
  }
  mesh.indices = std::move(tri);
  std::vector<glm::dvec3> normal(p.size(), glm::dvec3(0.0));
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const glm::dvec3 a(mesh.positions[mesh.indices[t]]), b(mesh.positions[mesh.indices[t + 1]]),
        c(mesh.positions[mesh.indices[t + 2]]);
    const glm::dvec3 face = glm::cross(b - a, c - a);  // twice the area, along the normal
    for (int k = 0; k < 3; ++k) normal[mesh.indices[t + static_cast<size_t>(k)]] += face;
  }
  mesh.normals.resize(p.size());
  for (size_t v = 0; v < p.size(); ++v) {
    const double len = glm::length(normal[v]);
    mesh.normals[v] = len > 0.0 ? glm::vec3(normal[v] / len) : glm::vec3(0.0f);
  }
  return mesh;
}

}  // namespace tritrace
