// tritrace_closest_point_bench: issue 28's yardstick for closest-point queries. The same query
// points against the same triangles through tritrace's wide BVH (bvh::closest_points) and through
// Embree's rtcPointQuery with a closest-point callback, the API Open3D's distance queries use.
// Embree's callback computes the distance with tritrace's own exact point/triangle function, so
// only the traversal differs. Both run on every core (TBB); rounds alternate between the two and
// the medians are printed, with the count of queries where the two disagree on the distance.
//
//   tritrace_closest_point_bench [terrain:1m | sphere:LEVEL] [POINTS] [ROUNDS]
//
// terrain:N is the procedural height field of `tritrace render --scene terrain:N` (its room
// included); sphere:L an icosahedron subdivided L times (sphere:8, 1.3M triangles, is closed).
// POINTS (default 1000000) are uniform in the mesh's bounding box grown by 10% on each side.
#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <sys/resource.h>
#include <xmmintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <glm/geometric.hpp>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "tritrace/accel/bvh/closest_point.h"
#include "tritrace/accel/bvh/winding_number.h"
#include "tritrace/geometry/point_triangle_distance.h"
#include "tritrace/parallel.h"
#include "tritrace/scene/procedural.h"

namespace {

using namespace tritrace;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// User + system CPU seconds of the whole process so far: on a machine shared with other work, the
// CPU time of a phase is a steadier measure than its wall time.
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec) + double(u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

TriangleMesh icosphere(int levels) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<glm::dvec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                               {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                               {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<uint32_t, 3>> f = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& p : v) p = glm::normalize(p);
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoint;
    auto mid = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto [it, added] = midpoint.try_emplace(key, static_cast<uint32_t>(v.size()));
      if (added) v.push_back(glm::normalize(v[a] + v[b]));
      return it->second;
    };
    std::vector<std::array<uint32_t, 3>> next;
    next.reserve(4 * f.size());
    for (const auto& tri : f) {
      const uint32_t ab = mid(tri[0], tri[1]), bc = mid(tri[1], tri[2]), ca = mid(tri[2], tri[0]);
      next.push_back({tri[0], ab, ca});
      next.push_back({tri[1], bc, ab});
      next.push_back({tri[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    f = std::move(next);
  }
  TriangleMesh mesh;
  mesh.reserve(f.size());
  for (const auto& tri : f)
    mesh.add(glm::vec3(v[tri[0]]), glm::vec3(v[tri[1]]), glm::vec3(v[tri[2]]), 0);
  return mesh;
}

// What Embree's callback keeps per query.
struct EmbreeResult {
  const TriangleMesh* mesh;
  double distance2;
  uint32_t prim;
};

bool closest_point_callback(RTCPointQueryFunctionArguments* args) {
  auto* r = static_cast<EmbreeResult*>(args->userPtr);
  const uint32_t prim = args->primID;
  const TriangleMesh& m = *r->mesh;
  const glm::vec3 q(args->query->x, args->query->y, args->query->z);
  const TrianglePoint p = closest_point_on_triangle(q, m.v0()[prim], m.v1()[prim], m.v2()[prim]);
  if (p.distance2 < r->distance2 || (p.distance2 == r->distance2 && prim < r->prim)) {
    r->distance2 = p.distance2;
    r->prim = prim;
    // Shrinking the query's radius is what prunes Embree's traversal.
    args->query->radius = static_cast<float>(std::sqrt(p.distance2));
    return true;
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string scene_name = argc > 1 ? argv[1] : "terrain:1m";
  const size_t count = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1000000;
  const int rounds = argc > 3 ? std::atoi(argv[3]) : 5;
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);

  TriangleMesh mesh;
  if (scene_name.rfind("sphere:", 0) == 0) {
    mesh = icosphere(std::atoi(scene_name.c_str() + 7));
  } else {
    const auto triangles = parse_terrain_triangles(scene_name);
    if (!triangles) {
      std::fprintf(stderr, "tritrace_closest_point_bench: %s: not terrain:N or sphere:L\n",
                   scene_name.c_str());
      return 2;
    }
    mesh = make_terrain_scene(*triangles).mesh;
  }
  const Bounds3 box = mesh.bounds();
  const glm::vec3 grow = 0.1f * (box.hi - box.lo);
  std::mt19937 rng(28);
  std::uniform_real_distribution<float> ux(box.lo.x - grow.x, box.hi.x + grow.x),
      uy(box.lo.y - grow.y, box.hi.y + grow.y), uz(box.lo.z - grow.z, box.hi.z + grow.z);
  std::vector<glm::vec3> points(count);
  for (auto& p : points) p = glm::vec3(ux(rng), uy(rng), uz(rng));
  std::printf("%s: %zu triangles, %zu query points, %d rounds, %d threads\n", scene_name.c_str(),
              mesh.size(), count, rounds, tbb::this_task_arena::max_concurrency());

  auto start = Clock::now();
  const bvh::WideBvh tree = bvh::build_wide_bvh(mesh);
  std::printf("tritrace BVH build: %.3f s\n", seconds_since(start));

  RTCDevice device = rtcNewDevice(nullptr);
  start = Clock::now();
  RTCScene scene = rtcNewScene(device);
  RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * mesh.size()));
  auto* indices = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), mesh.size()));
  for (size_t t = 0; t < mesh.size(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const glm::vec3 v = mesh.vertex(t, c);
      for (int a = 0; a < 3; ++a) vertices[9 * t + 3 * c + a] = v[a];
      indices[3 * t + c] = static_cast<uint32_t>(3 * t + c);
    }
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(scene);
  std::printf("Embree scene build: %.3f s\n", seconds_since(start));

  std::vector<bvh::ClosestPoint> ours(count);
  std::vector<EmbreeResult> theirs(count);
  auto run_tritrace = [&] { bvh::closest_points(tree, mesh, points, ours); };
  auto run_embree = [&] {
    parallel::for_range(tbb::blocked_range<size_t>(0, count, 256), [&](const auto& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) {
        RTCPointQuery query;
        query.x = points[i].x;
        query.y = points[i].y;
        query.z = points[i].z;
        query.time = 0.0f;
        query.radius = std::numeric_limits<float>::infinity();
        RTCPointQueryContext context;
        rtcInitPointQueryContext(&context);
        theirs[i] = {&mesh, std::numeric_limits<double>::infinity(), kNoHit};
        rtcPointQuery(scene, &query, &context, closest_point_callback, &theirs[i]);
      }
    });
  };
  std::vector<double> t_ours, t_theirs, cpu_ours, cpu_theirs;
  for (int round = 0; round < rounds; ++round) {
    double cpu = cpu_seconds();
    start = Clock::now();
    run_tritrace();
    t_ours.push_back(seconds_since(start));
    cpu_ours.push_back(cpu_seconds() - cpu);
    cpu = cpu_seconds();
    start = Clock::now();
    run_embree();
    t_theirs.push_back(seconds_since(start));
    cpu_theirs.push_back(cpu_seconds() - cpu);
  }
  size_t differ = 0;
  for (size_t i = 0; i < count; ++i) {
    if (ours[i].distance != static_cast<float>(std::sqrt(theirs[i].distance2))) ++differ;
  }
  const double a = median(t_ours), b = median(t_theirs);
  std::printf(
      "closest points: tritrace %.3f s (%.2f Mpoints/s), Embree rtcPointQuery %.3f s "
      "(%.2f Mpoints/s), tritrace / Embree time %.3f; distances differ at %zu points\n",
      a, count / a * 1e-6, b, count / b * 1e-6, a / b, differ);
  const double ca = median(cpu_ours), cb = median(cpu_theirs);
  std::printf(
      "  CPU time: tritrace %.3f s (%.2f us per point), Embree %.3f s (%.2f us per point), "
      "tritrace / Embree %.3f\n",
      ca, ca / count * 1e6, cb, cb / count * 1e6, ca / cb);

  start = Clock::now();
  const bvh::WindingNumber winding(tree, mesh);
  std::printf("winding-number expansions: %.3f s\n", seconds_since(start));
  std::vector<uint8_t> inside(count);
  std::vector<double> t_inside, cpu_inside;
  for (int round = 0; round < rounds; ++round) {
    const double cpu = cpu_seconds();
    start = Clock::now();
    winding.inside(tree, points, inside);
    t_inside.push_back(seconds_since(start));
    cpu_inside.push_back(cpu_seconds() - cpu);
  }
  size_t n_inside = 0;
  for (uint8_t x : inside) n_inside += x;
  const double c = median(t_inside);
  std::printf(
      "occupancy (winding number): %.3f s (%.2f Mpoints/s, CPU %.2f us per point), %zu "
      "inside\n",
      c, count / c * 1e-6, median(cpu_inside) / count * 1e6, n_inside);
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
  return differ == 0 ? 0 : 1;
}
