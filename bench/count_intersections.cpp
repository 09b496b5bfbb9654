// tritrace_count_intersections: issue 28's yardstick for counting every crossing along a ray.
// The same random rays through the same mesh are counted by tritrace's all-hits traversal
// (accel/bvh/all_hits.h) and by Embree's rtcIntersect1 with an intersection filter callback that
// counts each hit and rejects it so that traversal goes on (the classic Embree all-hits idiom, the
// one Open3D's RaycastingScene.count_intersections uses), in alternating rounds on one thread;
// prints the median thread CPU time of each and their ratio.
//
//   tritrace_count_intersections [SCENE [RAYS [ROUNDS]]]   (default terrain:1m 1000000 5)
//
// Rays: origins uniform in the scene's bounding box, directions uniform on the sphere (a fixed
// seed), tmin 0 and no tmax. Embree builds with its default (medium) quality, once without and
// once with RTC_SCENE_FLAG_ROBUST (Open3D's setting).
#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <time.h>
#include <xmmintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "tritrace/accel/bvh/all_hits.h"
#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/scene/procedural.h"

namespace {

using namespace tritrace;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The calling thread's CPU time: on a machine shared with other work it counts only this
// thread's own cycles, where wall time counts the waits for a core too.
double thread_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<Ray> random_rays(const Bounds3& box, size_t n) {
  std::mt19937 rng(2028);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), normal_ish(-1.0f, 1.0f);
  std::vector<Ray> rays(n);
  for (Ray& r : rays) {
    r.origin = box.lo + glm::vec3(unit(rng), unit(rng), unit(rng)) * (box.hi - box.lo);
    glm::vec3 d;
    do {
      d = glm::vec3(normal_ish(rng), normal_ish(rng), normal_ish(rng));
    } while (glm::dot(d, d) > 1.0f || glm::dot(d, d) < 1e-6f);
    r.dir = glm::normalize(d);
  }
  return rays;
}

// The filter's state travels with the intersect context (Embree 3: a struct that begins with it).
struct CountContext {
  RTCIntersectContext context;
  uint32_t count;
};

void count_and_reject(const RTCFilterFunctionNArguments* args) {
  auto* ctx = reinterpret_cast<CountContext*>(const_cast<RTCIntersectContext*>(args->context));
  ++ctx->count;
  args->valid[0] = 0;  // reject: traversal goes on to the next hit
}

class EmbreeCounter {
 public:
  EmbreeCounter(const TriangleMesh& mesh, bool robust) {
    device_ = rtcNewDevice(nullptr);
    scene_ = rtcNewScene(device_);
    if (robust) rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), 3 * mesh.size()));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.size()));
    for (size_t t = 0; t < mesh.size(); ++t) {
      for (int c = 0; c < 3; ++c) {
        const glm::vec3 p = mesh.vertex(t, c);
        vertices[9 * t + 3 * static_cast<size_t>(c)] = p.x;
        vertices[9 * t + 3 * static_cast<size_t>(c) + 1] = p.y;
        vertices[9 * t + 3 * static_cast<size_t>(c) + 2] = p.z;
        indices[3 * t + static_cast<size_t>(c)] = static_cast<unsigned>(3 * t + c);
      }
    }
    rtcSetGeometryIntersectFilterFunction(geometry, count_and_reject);
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene_);
  }
  ~EmbreeCounter() {
    rtcReleaseScene(scene_);
    rtcReleaseDevice(device_);
  }
  EmbreeCounter(const EmbreeCounter&) = delete;
  EmbreeCounter& operator=(const EmbreeCounter&) = delete;

  uint32_t count(const Ray& ray) const {
    CountContext ctx;
    rtcInitIntersectContext(&ctx.context);
    ctx.count = 0;
    RTCRayHit rh;
    rh.ray.org_x = ray.origin.x;
    rh.ray.org_y = ray.origin.y;
    rh.ray.org_z = ray.origin.z;
    rh.ray.dir_x = ray.dir.x;
    rh.ray.dir_y = ray.dir.y;
    rh.ray.dir_z = ray.dir.z;
    rh.ray.tnear = ray.tmin;
    rh.ray.tfar = ray.tmax;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.flags = 0;
    rh.ray.time = 0.0f;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &ctx.context, &rh);
    return ctx.count;
  }

 private:
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
};

}  // namespace

int main(int argc, char** argv) {
  // Embree's recommended denormal settings, for both, as in embree_first_frame.
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  const std::string scene_name = argc > 1 ? argv[1] : "terrain:1m";
  const size_t ray_count = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1000000;
  const int rounds = argc > 3 ? std::atoi(argv[3]) : 5;
  const Scene scene = make_builtin_scene(scene_name);
  const TriangleMesh& mesh = scene.mesh;
  const std::vector<Ray> rays = random_rays(mesh.bounds(), ray_count);

  auto start = Clock::now();
  const bvh::WideBvh tree = bvh::build_wide_bvh(mesh, bvh::default_build_config(mesh.size()));
  const double tritrace_build = seconds_since(start);
  start = Clock::now();
  const EmbreeCounter embree(mesh, false);
  const double embree_build = seconds_since(start);
  start = Clock::now();
  const EmbreeCounter embree_robust(mesh, true);
  const double embree_robust_build = seconds_since(start);
  std::printf("%s: %zu triangles, %zu rays, %d rounds, one thread\n", scene_name.c_str(),
              mesh.size(), rays.size(), rounds);
  std::printf("build: tritrace %.2f s, embree %.2f s, embree robust %.2f s\n", tritrace_build,
              embree_build, embree_robust_build);

  std::vector<double> t_tritrace, t_embree, t_robust;
  uint64_t sum_tritrace = 0, sum_embree = 0, sum_robust = 0;
  size_t differ = 0;
  std::vector<uint32_t> counts(rays.size());
  for (int round = 0; round < rounds; ++round) {
    double cpu = thread_seconds();
    bvh::count_intersections(tree, rays, counts);
    t_tritrace.push_back(thread_seconds() - cpu);
    sum_tritrace = 0;
    for (uint32_t c : counts) sum_tritrace += c;

    cpu = thread_seconds();
    sum_embree = 0;
    size_t d = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      const uint32_t c = embree.count(rays[i]);
      sum_embree += c;
      d += c != counts[i];
    }
    t_embree.push_back(thread_seconds() - cpu);
    differ = d;

    cpu = thread_seconds();
    sum_robust = 0;
    for (const Ray& ray : rays) sum_robust += embree_robust.count(ray);
    t_robust.push_back(thread_seconds() - cpu);
  }
  const double mt = median(t_tritrace), me = median(t_embree), mr = median(t_robust);
  const double n = static_cast<double>(rays.size());
  std::printf(
      "crossings: tritrace %llu, embree %llu (%zu rays count differently), embree robust "
      "%llu\n",
      static_cast<unsigned long long>(sum_tritrace), static_cast<unsigned long long>(sum_embree),
      differ, static_cast<unsigned long long>(sum_robust));
  std::printf(
      "median CPU time: tritrace %.3f s (%.2f Mrays/s), embree %.3f s (%.2f Mrays/s), embree "
      "robust %.3f s (%.2f Mrays/s)\n",
      mt, n / mt * 1e-6, me, n / me * 1e-6, mr, n / mr * 1e-6);
  std::printf("speed-up of tritrace: %.2fx over embree, %.2fx over embree robust\n", me / mt,
              mr / mt);
  return 0;
}
