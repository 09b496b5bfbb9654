// The checked ray arguments of the module's ray queries; see ray_input.h.
#include "ray_input.h"

#include <cmath>

#include "convert.h"
#include "tritrace/job/setting_values.h"

namespace tritrace::python {

MeshInput mesh_input(const py::object& vertices_object, const py::object& triangles_object) {
  MeshInput in;
  in.vertices = float32_array("vertices", vertices_object);
  if (in.vertices.ndim() != 2 || in.vertices.shape(1) != 3) {
    throw py::value_error("vertices: must have shape (N, 3), got " + shape_text(in.vertices));
  }
  in.triangles = int64_array("triangles", triangles_object);
  if (in.triangles.ndim() != 2 || in.triangles.shape(1) != 3) {
    throw py::value_error("triangles: must have shape (M, 3), got " + shape_text(in.triangles));
  }
  return in;
}

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    s += (i ? ", " : "") + std::to_string(a.shape(i));
  }
  return s + (a.ndim() == 1 ? ",)" : ")");
}

std::vector<py::ssize_t> leading_shape(const py::array& a) {
  return std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim() - 1);
}

size_t element_count(const std::vector<py::ssize_t>& shape) {
  size_t n = 1;
  for (py::ssize_t s : shape) n *= static_cast<size_t>(s);
  return n;
}

std::vector<py::ssize_t> with_last(std::vector<py::ssize_t> shape, py::ssize_t last) {
  shape.push_back(last);
  return shape;
}

namespace {

py::array_t<float> ray_vectors(const char* name, const py::object& value) {
  py::array_t<float> a = float32_array(name, value);
  if (a.ndim() < 1 || a.shape(a.ndim() - 1) != 3) {
    throw py::value_error(std::string(name) + ": must have shape (..., 3), got " + shape_text(a));
  }
  return a;
}

// tmin or tmax: a number for every ray, or an array of the rays' shape (whose values the ray
// loop checks).
void ray_interval(const char* name, const py::object& value, const std::vector<py::ssize_t>& shape,
                  bool is_tmin, float& scalar, std::optional<py::array_t<float>>& per_ray) {
  const bool sequence = py::isinstance<py::array>(value) || py::isinstance<py::list>(value) ||
                        py::isinstance<py::tuple>(value);
  std::optional<double> one;
  py::array_t<float> array;
  if (!sequence) {
    one = number_arg(name, value);
  } else {
    array = float32_array(name, value);
    if (array.ndim() == 0) one = array.at();
  }
  if (one) {
    if (is_tmin && !(*one >= 0.0)) {
      throw py::value_error(std::string(name) + ": must be a number >= 0, got " +
                            format_double(*one));
    }
    if (std::isnan(*one)) throw py::value_error(std::string(name) + ": must not be NaN");
    scalar = static_cast<float>(*one);
    return;
  }
  const std::vector<py::ssize_t> got(array.shape(), array.shape() + array.ndim());
  if (got != shape) {
    std::string want = "(";
    for (size_t i = 0; i < shape.size(); ++i) want += (i ? ", " : "") + std::to_string(shape[i]);
    want += shape.size() == 1 ? ",)" : ")";
    throw py::value_error(std::string(name) + ": must be a number or an array of the rays' shape " +
                          want + ", got " + shape_text(array));
  }
  per_ray = array;
}

}  // namespace

RayInput ray_input(const py::object& origins, const py::object& directions, const py::object& tmin,
                   const py::object& tmax) {
  RayInput in;
  in.origins = ray_vectors("origins", origins);
  in.directions = ray_vectors("directions", directions);
  const bool one_origin = in.origins.ndim() == 1;
  const bool one_direction = in.directions.ndim() == 1;
  if (!one_origin && !one_direction && leading_shape(in.origins) != leading_shape(in.directions)) {
    throw py::value_error("origins and directions: shapes " + shape_text(in.origins) + " and " +
                          shape_text(in.directions) +
                          " do not match (give both as (..., 3), or either as (3,) for all rays)");
  }
  in.shape = one_origin ? leading_shape(in.directions) : leading_shape(in.origins);
  ray_interval("tmin", tmin, in.shape, true, in.tmin, in.tmin_array);
  ray_interval("tmax", tmax, in.shape, false, in.tmax, in.tmax_array);
  return in;
}

}  // namespace tritrace::python
