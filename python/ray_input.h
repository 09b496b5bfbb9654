// The checked ray arguments shared by the module's ray queries (Accel and QueryScene): origins and
// directions of shape (..., 3) or (3,), tmin and tmax as numbers or arrays of the rays' shape, and
// the small shape helpers their messages and results use.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ray_queries.h"

namespace tritrace::python {

namespace py = pybind11;

// "(2, 3)", "(3,)": an array's shape as Python prints it.
std::string shape_text(const py::array& a);
// All dimensions but the last.
std::vector<py::ssize_t> leading_shape(const py::array& a);
size_t element_count(const std::vector<py::ssize_t>& shape);
std::vector<py::ssize_t> with_last(std::vector<py::ssize_t> shape, py::ssize_t last);

// The checked inputs of a ray query, kept alive while it runs.
struct RayInput {
  py::array_t<float> origins, directions;
  std::optional<py::array_t<float>> tmin_array, tmax_array;  // none: one number for all rays
  float tmin = 0.0f, tmax = std::numeric_limits<float>::infinity();
  std::vector<py::ssize_t> shape;  // the rays' shape: the arrays' leading dimensions

  // Pointers into the members: taken where the RayInput stays, not where it was made.
  RayArrays arrays() const {
    RayArrays a;
    a.count = element_count(shape);
    a.origins = origins.data();
    a.origin_stride = origins.ndim() == 1 ? 0 : 3;
    a.directions = directions.data();
    a.direction_stride = directions.ndim() == 1 ? 0 : 3;
    a.tmin = tmin_array ? tmin_array->data() : &tmin;
    a.tmin_stride = tmin_array ? 1 : 0;
    a.tmax = tmax_array ? tmax_array->data() : &tmax;
    a.tmax_stride = tmax_array ? 1 : 0;
    return a;
  }
};

// The checked arguments of a triangle mesh (Scene.from_arrays, QueryScene.add_geometry):
// vertices as float32 (N, 3), triangles as int64 (M, 3) vertex indices, kept alive while in use.
struct MeshInput {
  py::array_t<float> vertices;
  py::array_t<int64_t> triangles;
};

// ValueError or TypeError naming the argument for a bad shape or dtype; the indices and values are
// checked by the caller.
MeshInput mesh_input(const py::object& vertices, const py::object& triangles);

// ValueError or TypeError naming the argument for a bad shape, dtype, tmin or tmax; the values of
// per-ray arrays are checked by the ray loop (ray_queries.h).
RayInput ray_input(const py::object& origins, const py::object& directions, const py::object& tmin,
                   const py::object& tmax);

}  // namespace tritrace::python
