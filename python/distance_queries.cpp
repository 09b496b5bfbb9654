// tritrace.QueryScene's point queries: points checked and read in place, the library's
// distance_queries.h doing the work over all cores with the GIL released, and a RuntimeWarning
// where an inside test meets a geometry that is not closed.
#include "distance_queries.h"

#include <pybind11/numpy.h>

#include <cmath>
#include <string>
#include <vector>

#include "convert.h"
#include "ray_input.h"
#include "tritrace/job/setting_values.h"

namespace tritrace::python {
namespace {

using namespace pybind11::literals;

// The checked query points: a float32 array of shape (..., 3), every value finite.
struct PointInput {
  py::array_t<float> array;
  std::vector<py::ssize_t> shape;  // the points' shape: all dimensions but the last
  std::span<const glm::vec3> points() const {
    return {reinterpret_cast<const glm::vec3*>(array.data()), element_count(shape)};
  }
};

PointInput point_input(const py::object& points_object) {
  PointInput in;
  in.array = float32_array("points", points_object);
  if (in.array.ndim() < 1 || in.array.shape(in.array.ndim() - 1) != 3) {
    throw py::value_error("points: must have shape (..., 3), got " + shape_text(in.array));
  }
  in.shape = leading_shape(in.array);
  const float* p = in.array.data();
  const size_t n = element_count(in.shape);
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(p[3 * i]) || !std::isfinite(p[3 * i + 1]) || !std::isfinite(p[3 * i + 2])) {
      throw py::value_error("points: point " + std::to_string(i) + " is not finite: (" +
                            format_float(p[3 * i]) + ", " + format_float(p[3 * i + 1]) + ", " +
                            format_float(p[3 * i + 2]) + ")");
    }
  }
  return in;
}

py::dict closest_points(const QueryScene& self, const py::object& points_object) {
  const PointInput in = point_input(points_object);
  const size_t n = element_count(in.shape);
  py::array_t<float> points(with_last(in.shape, 3)), uvs(with_last(in.shape, 2)),
      normals(with_last(in.shape, 3));
  py::array_t<int32_t> geometry_ids(in.shape), primitive_ids(in.shape);
  float* point_out = points.mutable_data();
  float* uv_out = uvs.mutable_data();
  float* normal_out = normals.mutable_data();
  int32_t* geometry_out = geometry_ids.mutable_data();
  int32_t* prim_out = primitive_ids.mutable_data();
  {
    py::gil_scoped_release nogil;
    std::vector<SurfacePoint> found(n);
    self.read([&](const GeometrySet& set) { tritrace::closest_points(set, in.points(), found); });
    for (size_t i = 0; i < n; ++i) {
      const SurfacePoint& s = found[i];
      const bool hit = s.prim != kNoHit;
      for (int a = 0; a < 3; ++a) {
        // An empty scene has no surface: its closest points are at infinity.
        point_out[3 * i + a] = hit ? s.point[a] : std::numeric_limits<float>::infinity();
        normal_out[3 * i + a] = s.normal[a];
      }
      geometry_out[i] = hit ? static_cast<int32_t>(s.geometry) : -1;
      prim_out[i] = hit ? static_cast<int32_t>(s.prim) : -1;
      uv_out[2 * i] = s.u;
      uv_out[2 * i + 1] = s.v;
    }
  }
  return py::dict("points"_a = points, "geometry_ids"_a = geometry_ids,
                  "primitive_ids"_a = primitive_ids, "primitive_uvs"_a = uvs,
                  "primitive_normals"_a = normals);
}

py::array_t<float> distance(const QueryScene& self, const py::object& points_object) {
  const PointInput in = point_input(points_object);
  py::array_t<float> out(in.shape);
  float* d = out.mutable_data();
  {
    py::gil_scoped_release nogil;
    std::vector<SurfacePoint> found(element_count(in.shape));
    self.read([&](const GeometrySet& set) { tritrace::closest_points(set, in.points(), found); });
    for (size_t i = 0; i < found.size(); ++i) d[i] = found[i].distance;
  }
  return out;
}

// RuntimeWarning naming every geometry whose inside is ill-defined.
void warn_not_closed(const std::vector<EdgeReport>& edges, const char* query) {
  std::string list;
  for (size_t g = 0; g < edges.size(); ++g) {
    const EdgeReport& e = edges[g];
    if (e.closed()) continue;
    if (!list.empty()) list += "; ";
    list += "geometry " + std::to_string(g) + " has " + std::to_string(e.boundary) + " boundary, " +
            std::to_string(e.non_manifold) + " non-manifold and " + std::to_string(e.misoriented) +
            " inconsistently oriented edges";
  }
  if (list.empty()) return;
  const std::string message = std::string(query) + ": the scene is not closed (" + list +
                              "), so inside and outside are not well defined; points count as "
                              "inside where the generalised winding number is above 1/2";
  if (PyErr_WarnEx(PyExc_RuntimeWarning, message.c_str(), 2) != 0) throw py::error_already_set();
}

py::array_t<float> signed_distance(const QueryScene& self, const py::object& points_object) {
  const PointInput in = point_input(points_object);
  py::array_t<float> out(in.shape);
  float* d = out.mutable_data();
  std::vector<EdgeReport> edges;
  {
    py::gil_scoped_release nogil;
    self.read_inside([&](const GeometrySet& set, const InsideTest& inside) {
      inside.signed_distance(set, in.points(), std::span(d, element_count(in.shape)));
      edges = inside.edges();
    });
  }
  warn_not_closed(edges, "signed_distance");
  return out;
}

py::array_t<float> occupancy(const QueryScene& self, const py::object& points_object) {
  const PointInput in = point_input(points_object);
  const size_t n = element_count(in.shape);
  py::array_t<float> out(in.shape);
  float* o = out.mutable_data();
  std::vector<EdgeReport> edges;
  {
    py::gil_scoped_release nogil;
    std::vector<uint8_t> inside_flags(n);
    self.read_inside([&](const GeometrySet& set, const InsideTest& inside) {
      inside.occupancy(set, in.points(), inside_flags);
      edges = inside.edges();
    });
    for (size_t i = 0; i < n; ++i) o[i] = inside_flags[i] ? 1.0f : 0.0f;
  }
  warn_not_closed(edges, "occupancy");
  return out;
}

}  // namespace

void register_distance_queries(QuerySceneClass& cls) {
  cls.def("closest_points", &closest_points, "points"_a,
          R"(The nearest surface point to each query point.

points: array of shape (..., 3) (any real dtype, converted to float32; every value finite).
Returns a dict of arrays of the points' leading shape: "points" (..., 3) float32, the nearest
point on any geometry; "geometry_ids" and "primitive_ids" (int32) of its triangle;
"primitive_uvs" (..., 2) float32 barycentric weights of the triangle's second and third
vertices at that point; "primitive_normals" (..., 3) float32 unit normal
normalize(cross(b - a, c - a)) of the triangle (a, b, c) as given (0 for a zero-area one). The
distance is exact (Ericson's point/triangle regions in double); among triangles at exactly the
same distance the one added first wins. An empty scene gives points at inf and ids -1.
ValueError naming points for a bad shape or a value that is not finite.)")
      .def("distance", &distance, "points"_a,
           R"(The distance from each point to the nearest surface point, float32 of the points'
leading shape (inf for an empty scene). points as for closest_points.)")
      .def("signed_distance", &signed_distance, "points"_a,
           R"(distance() with a sign: negative inside, positive outside, +0 on the surface.

Inside is where the generalised winding number of all geometries together (Jacobson et al.
2013; evaluated hierarchically after Barill et al. 2018, exactly near the surface) is above 1/2
in magnitude, so a closed mesh counts whichever way its triangles face, as long as they face
one way. Meant for closed meshes: when any geometry has boundary edges, edges of three or more
triangles, or neighbours facing opposite ways, a RuntimeWarning says so and the answer is the
winding number's (a hole lowers it near the hole, so points there may count as outside).)")
      .def("occupancy", &occupancy, "points"_a,
           R"(1.0 for points inside the geometries, 0.0 outside, float32 of the points' leading
shape: the inside of signed_distance (the generalised winding number above 1/2 in magnitude),
with the same RuntimeWarning for geometries that are not closed.)");
}

}  // namespace tritrace::python
