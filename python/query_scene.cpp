// tritrace.QueryScene's bindings: arguments checked and converted here, the work done by the
// library's GeometrySet and the module's parallel ray loop with the GIL released.
#include "query_scene.h"

#include <pybind11/numpy.h>

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "convert.h"
#include "ray_input.h"
#include "ray_queries.h"
#include "tritrace/accel/bvh/all_hits.h"

namespace tritrace::python {
namespace {

using namespace pybind11::literals;

// Results are built in chunks of this many rays over all cores.
constexpr size_t kResultChunk = size_t{1} << 14;

uint32_t add_geometry(QueryScene& self, const py::object& vertices_object,
                      const py::object& triangles_object) {
  const MeshInput mesh = mesh_input(vertices_object, triangles_object);
  const py::array_t<float>& vertices = mesh.vertices;
  const py::array_t<int64_t>& triangles = mesh.triangles;
  const auto vertex_count = static_cast<int64_t>(vertices.shape(0));
  const auto triangle_count = static_cast<size_t>(triangles.shape(0));
  const int64_t* index = triangles.data();
  std::vector<glm::uvec3> tris(triangle_count);
  for (size_t i = 0; i < triangle_count; ++i) {
    for (int c = 0; c < 3; ++c) {
      const int64_t k = index[3 * i + static_cast<size_t>(c)];
      if (k < 0 || k >= vertex_count) {
        throw py::value_error("triangles: triangle " + std::to_string(i) + " has vertex index " +
                              std::to_string(k) + ", but there are " +
                              std::to_string(vertex_count) + " vertices");
      }
      tris[i][c] = static_cast<uint32_t>(k);
    }
  }
  static_assert(sizeof(glm::vec3) == 3 * sizeof(float));
  const std::span<const glm::vec3> points(reinterpret_cast<const glm::vec3*>(vertices.data()),
                                          static_cast<size_t>(vertex_count));
  try {
    py::gil_scoped_release nogil;
    return self.add(points, tris);
  } catch (const Error& e) {
    raise_value_error(e);
  }
}

py::dict intersect(const QueryScene& self, const py::object& origins, const py::object& directions,
                   const py::object& tmin, const py::object& tmax) {
  const RayInput in = ray_input(origins, directions, tmin, tmax);
  const size_t n = element_count(in.shape);
  py::array_t<float> t(in.shape);
  py::array_t<int32_t> geometry_ids(in.shape), primitive_ids(in.shape);
  py::array_t<float> uvs(with_last(in.shape, 2)), normals(with_last(in.shape, 3));
  float* t_out = t.mutable_data();
  int32_t* geometry_out = geometry_ids.mutable_data();
  int32_t* prim_out = primitive_ids.mutable_data();
  float* uv_out = uvs.mutable_data();
  float* normal_out = normals.mutable_data();
  std::optional<RayProblem> problem;
  {
    py::gil_scoped_release nogil;
    std::vector<float> u(n), v(n);
    self.read([&](const GeometrySet& set) {
      problem = trace_closest(set.accel(), in.arrays(),
                              HitArrays{t_out, prim_out, u.data(), v.data(), false},
                              Coherence::kAuto, {}, false);
      if (problem) return;
      // The concatenated triangle as (geometry, triangle), and the caller's counter-clockwise
      // normal: the mesh stores the lab's normalize(cross(e2, e1)), its opposite.
      const auto& stored_normals = set.mesh().normal();
      parallel_chunks(n, kResultChunk, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
          glm::vec3 normal(0.0f);
          int32_t geometry = -1;
          if (prim_out[i] >= 0) {
            const auto prim = static_cast<uint32_t>(prim_out[i]);
            const GeometrySet::Location at = set.locate(prim);
            geometry = static_cast<int32_t>(at.geometry);
            prim_out[i] = static_cast<int32_t>(at.prim);
            normal = glm::vec3(0.0f) - stored_normals[prim];  // +0, not -0, for 0
          }
          geometry_out[i] = geometry;
          uv_out[2 * i] = u[i];
          uv_out[2 * i + 1] = v[i];
          normal_out[3 * i] = normal.x;
          normal_out[3 * i + 1] = normal.y;
          normal_out[3 * i + 2] = normal.z;
        }
      });
    });
  }
  if (problem) throw py::value_error(problem->reason);
  return py::dict("t"_a = t, "geometry_ids"_a = geometry_ids, "primitive_ids"_a = primitive_ids,
                  "primitive_uvs"_a = uvs, "primitive_normals"_a = normals);
}

py::array_t<int32_t> count_intersections(const QueryScene& self, const py::object& origins,
                                         const py::object& directions, const py::object& tmin,
                                         const py::object& tmax) {
  const RayInput in = ray_input(origins, directions, tmin, tmax);
  py::array_t<int32_t> counts(in.shape);
  auto* out = reinterpret_cast<uint32_t*>(counts.mutable_data());
  std::optional<RayProblem> problem;
  {
    py::gil_scoped_release nogil;
    self.read([&](const GeometrySet& set) {
      problem = for_each_ray_batch(in.arrays(), [&](std::span<const Ray> batch, size_t first) {
        bvh::count_intersections(set.tree(), batch, std::span<uint32_t>(out + first, batch.size()));
      });
    });
  }
  if (problem) throw py::value_error(problem->reason);
  return counts;
}

py::dict list_intersections(const QueryScene& self, const py::object& origins,
                            const py::object& directions, const py::object& tmin,
                            const py::object& tmax) {
  const RayInput in = ray_input(origins, directions, tmin, tmax);
  const size_t n = element_count(in.shape);
  // Each batch's crossings apart, then joined in ray order.
  std::vector<bvh::Intersections> batches((n + kRayChunk - 1) / kRayChunk);
  std::optional<RayProblem> problem;
  {
    py::gil_scoped_release nogil;
    self.read([&](const GeometrySet& set) {
      problem = for_each_ray_batch(in.arrays(), [&](std::span<const Ray> batch, size_t first) {
        bvh::list_intersections(set.tree(), batch, batches[first / kRayChunk]);
      });
    });
  }
  if (problem) throw py::value_error(problem->reason);
  std::vector<size_t> offset(batches.size() + 1, 0);
  for (size_t b = 0; b < batches.size(); ++b) offset[b + 1] = offset[b] + batches[b].hits.size();
  const auto total = static_cast<py::ssize_t>(offset.back());
  py::array_t<int64_t> ray_splits(static_cast<py::ssize_t>(n + 1));
  py::array_t<int32_t> ray_ids(total), geometry_ids(total), primitive_ids(total);
  py::array_t<float> t(total), uvs(std::vector<py::ssize_t>{total, 2});
  int64_t* splits_out = ray_splits.mutable_data();
  int32_t* ray_out = ray_ids.mutable_data();
  int32_t* geometry_out = geometry_ids.mutable_data();
  int32_t* prim_out = primitive_ids.mutable_data();
  float* t_out = t.mutable_data();
  float* uv_out = uvs.mutable_data();
  {
    py::gil_scoped_release nogil;
    splits_out[0] = 0;
    self.read([&](const GeometrySet& set) {
      parallel_chunks(batches.size(), 1, [&](size_t begin, size_t end) {
        for (size_t b = begin; b < end; ++b) {
          const bvh::Intersections& batch = batches[b];
          const size_t first_ray = b * kRayChunk;
          for (size_t r = 0; r + 1 < batch.ray_splits.size(); ++r) {
            const size_t ray = first_ray + r;
            splits_out[ray + 1] = static_cast<int64_t>(offset[b] + batch.ray_splits[r + 1]);
            for (uint64_t k = batch.ray_splits[r]; k < batch.ray_splits[r + 1]; ++k) {
              const size_t o = offset[b] + k;
              const Hit& h = batch.hits[k];
              const GeometrySet::Location at = set.locate(h.prim);
              ray_out[o] = static_cast<int32_t>(ray);
              t_out[o] = h.t;
              geometry_out[o] = static_cast<int32_t>(at.geometry);
              prim_out[o] = static_cast<int32_t>(at.prim);
              uv_out[2 * o] = h.u;
              uv_out[2 * o + 1] = h.v;
            }
          }
        }
      });
    });
  }
  return py::dict("ray_splits"_a = ray_splits, "ray_ids"_a = ray_ids, "t"_a = t,
                  "geometry_ids"_a = geometry_ids, "primitive_ids"_a = primitive_ids,
                  "primitive_uvs"_a = uvs);
}

}  // namespace

QuerySceneClass register_query_scene(py::module_& m) {
  const double inf = std::numeric_limits<double>::infinity();
  QuerySceneClass cls(m, "QueryScene", R"(Several triangle meshes in one BVH for geometric queries.

QueryScene() is empty; add(vertices, triangles) appends a mesh and returns its geometry id (0, 1,
2, ... in the order added). Every query answers with the geometry id and the triangle's index in
that geometry's triangles array. The BVH (watertight kernel) is built on the first query after an
add(). Queries release the GIL, use every core and may run from several threads at once.)");
  cls.def(py::init([] { return std::make_shared<QueryScene>(); }))
      .def("add", &add_geometry, "vertices"_a, "triangles"_a,
           R"(Appends a mesh; returns its geometry id.

vertices: (N, 3) numbers (converted to float32; each must be finite); triangles: (M, 3) integer
indices into vertices. Zero-area triangles are kept, so that triangle indices stay yours: rays
never hit them. ValueError naming the argument for a bad shape, value or index.)")
      .def_property_readonly("geometry_count", &QueryScene::geometry_count,
                             "How many meshes were added.")
      .def_property_readonly("triangle_count", &QueryScene::triangle_count,
                             "How many triangles all meshes hold together.")
      .def("intersect", &intersect, "origins"_a, "directions"_a, "tmin"_a = 0.0, "tmax"_a = inf,
           R"(The first hit of each ray within [tmin, tmax].

origins and directions: arrays of shape (..., 3), or (3,) for one shared by every ray; tmin and
tmax: numbers or arrays of the rays' shape; t is in units of each direction's length. Returns a
dict of arrays of the rays' shape: "t" (float32, inf on a miss), "geometry_ids" and
"primitive_ids" (int32, -1 on a miss), "primitive_uvs" (..., 2) float32 barycentric weights of
the triangle's second and third vertices, "primitive_normals" (..., 3) float32 unit normal
normalize(cross(b - a, c - a)) of the triangle (a, b, c) as given (0 on a miss). A ray with a
non-finite origin or direction, a zero direction, a negative or NaN tmin or a NaN tmax raises
ValueError naming the first one.)")
      .def("count_intersections", &count_intersections, "origins"_a, "directions"_a, "tmin"_a = 0.0,
           "tmax"_a = inf,
           R"(How many triangles each ray crosses within [tmin, tmax]: an int32 array of the rays'
shape. Arguments as for intersect(). Each crossing counts once, also where the ray passes
exactly through an edge or a vertex shared by several triangles, so the count along a line
through a closed mesh is even, and its parity from a point says whether the point is inside;
a ray that only grazes an edge or touches a vertex counts 0 or 2 there. Triangles seen edge-on
and zero-area triangles are never crossed.)")
      .def("list_intersections", &list_intersections, "origins"_a, "directions"_a, "tmin"_a = 0.0,
           "tmax"_a = inf,
           R"(Every crossing of each ray within [tmin, tmax], counted as count_intersections()
counts them. Arguments as for intersect(). Returns a dict of flat arrays, the crossings ray by
ray (rays in C order of their shape) and by increasing t within each ray: "ray_splits" (int64,
one more than the rays: ray i's crossings are [ray_splits[i], ray_splits[i + 1])), "ray_ids"
(int32, the ray of each crossing), "t" (float32), "geometry_ids" and "primitive_ids" (int32),
"primitive_uvs" (K, 2) float32 barycentric weights of the triangle's second and third
vertices.)");
  return cls;
}

}  // namespace tritrace::python
