// tritrace.QueryScene: several meshes from NumPy arrays in one BVH, for the geometric queries that
// robotics, lidar simulation and mesh processing ask of a mesh (the shape of Open3D's
// RaycastingScene): each answer names the geometry (the id add() returned) and its triangle.
#pragma once

#include <pybind11/pybind11.h>

#include <memory>
#include <mutex>
#include <shared_mutex>

#include "tritrace/accel/distance_queries.h"
#include "tritrace/accel/geometry_set.h"

namespace tritrace::python {

namespace py = pybind11;

class QueryScene {
 public:
  // The geometries, as a query reads them: built, and with no add() running meanwhile. Call with
  // the GIL released (a build can take seconds, and an add() may be waiting for the lock).
  template <typename Fn>
  decltype(auto) read(Fn&& fn) const {
    for (;;) {
      {
        std::shared_lock lock(mutex_);
        if (set_.built()) return fn(static_cast<const GeometrySet&>(set_));
      }
      std::unique_lock lock(mutex_);
      set_.build();
    }
  }
  // The same with the set's inside test (distance_queries.h), made on first use after a build.
  template <typename Fn>
  decltype(auto) read_inside(Fn&& fn) const {
    for (;;) {
      {
        std::shared_lock lock(mutex_);
        if (set_.built() && inside_) {
          return fn(static_cast<const GeometrySet&>(set_),
                    static_cast<const InsideTest&>(*inside_));
        }
      }
      std::unique_lock lock(mutex_);
      set_.build();
      if (!inside_) inside_ = std::make_unique<InsideTest>(set_);
    }
  }
  // Adds a geometry (GeometrySet::add); call with the GIL released.
  uint32_t add(std::span<const glm::vec3> vertices, std::span<const glm::uvec3> triangles) {
    std::unique_lock lock(mutex_);
    inside_.reset();
    return set_.add(vertices, triangles);
  }
  size_t geometry_count() const {
    std::shared_lock lock(mutex_);
    return set_.geometry_count();
  }
  size_t triangle_count() const {
    std::shared_lock lock(mutex_);
    return set_.triangle_count();
  }

 private:
  mutable GeometrySet set_;                     // built lazily by read()
  mutable std::unique_ptr<InsideTest> inside_;  // made lazily by read_inside(), dropped by add()
  mutable std::shared_mutex mutex_;
};

using QuerySceneClass = py::class_<QueryScene, std::shared_ptr<QueryScene>>;

// Adds tritrace.QueryScene with its constructor, add() and the ray queries to `m`, and returns the
// class so that other files can add their queries to it.
QuerySceneClass register_query_scene(py::module_& m);

}  // namespace tritrace::python
