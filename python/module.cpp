// The Python module `tritrace` (pybind11): scenes loaded as `tritrace render` loads them or built
// from NumPy arrays, the library's accels for batched ray queries on arrays, and renders that are
// the CLI's images bit for bit. The work runs in the library with the GIL released; this file only
// converts arguments, arrays and errors.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "buffer_cache.h"
#include "convert.h"
#include "denoise_arrays.h"
#include "distance_queries.h"
#include "query_scene.h"
#include "ray_input.h"
#include "ray_queries.h"
#include "scene_data.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/job/render_job.h"
#include "tritrace/job/setting_values.h"
#include "tritrace/render/make_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/procedural.h"

namespace tritrace::python {
namespace {

using namespace pybind11::literals;

// ---------------------------------------------------------------------------------------------
// Errors

[[noreturn]] void raise_os_error(PyObject* type, const std::string& message) {
  PyErr_SetString(type, message.c_str());
  throw py::error_already_set();
}

// The OSError subclass for a file that failed to load, from the state of the file the error names
// (a scene file's mesh, or the scene file itself); the message stays the CLI's.
PyObject* os_error_type(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return PyExc_FileNotFoundError;
    if (errno == EACCES) return PyExc_PermissionError;
    return PyExc_OSError;
  }
  if (S_ISDIR(st.st_mode)) return PyExc_IsADirectoryError;
  if (::access(path.c_str(), R_OK) != 0) return PyExc_PermissionError;
  return PyExc_OSError;
}

// The CLI's warning about dropped triangles, as a RuntimeWarning.
void warn_dropped(const SceneData& data, const std::string& subject) {
  const LoadStats& s = data.loaded.stats;
  if (s.dropped_degenerate + s.dropped_non_finite == 0) return;
  const std::string message = subject + ": dropped " + std::to_string(s.dropped_degenerate) +
                              " degenerate and " + std::to_string(s.dropped_non_finite) +
                              " non-finite triangles";
  if (PyErr_WarnEx(PyExc_RuntimeWarning, message.c_str(), 2) != 0) throw py::error_already_set();
}

// ---------------------------------------------------------------------------------------------
// Scenes

py::tuple vec3_tuple(glm::vec3 v) {
  return py::make_tuple(v.x, v.y, v.z);
}

py::array_t<float> vec3_array(glm::vec3 v) {
  py::array_t<float> a(3);
  a.mutable_at(0) = v.x;
  a.mutable_at(1) = v.y;
  a.mutable_at(2) = v.z;
  return a;
}

std::shared_ptr<SceneData> load(const py::object& path_object) {
  const std::string path = path_arg("path", path_object);
  std::shared_ptr<SceneData> data;
  try {
    py::gil_scoped_release nogil;
    data = load_file(path);
  } catch (const Error& e) {
    raise_os_error(os_error_type(e.subject().empty() ? path : e.subject()), e.what());
  }
  warn_dropped(*data, path);
  return data;
}

std::shared_ptr<SceneData> builtin(const py::object& name_object) {
  const std::string name = string_arg("name", name_object);
  const std::string why = check_builtin_scene(name);
  if (!why.empty()) throw py::value_error("name: " + why);
  py::gil_scoped_release nogil;
  return load_builtin(name);
}

std::shared_ptr<SceneData> from_arrays(const py::object& vertices_object,
                                       const py::object& triangles_object,
                                       const py::object& materials_object) {
  const MeshInput mesh = mesh_input(vertices_object, triangles_object);
  const py::array_t<float>& vertices = mesh.vertices;
  const py::array_t<int64_t>& triangles = mesh.triangles;
  py::array_t<float> albedo(0);  // empty: no materials given
  if (!materials_object.is_none()) {
    albedo = float32_array("materials", materials_object);
    const bool one = albedo.ndim() == 1 && albedo.shape(0) == 3;
    const bool each =
        albedo.ndim() == 2 && albedo.shape(0) == triangles.shape(0) && albedo.shape(1) == 3;
    if (!one && !each) {
      throw py::value_error("materials: must be one albedo of shape (3,) or one per triangle, (" +
                            std::to_string(triangles.shape(0)) + ", 3), got " + shape_text(albedo));
    }
  }
  std::shared_ptr<SceneData> data;
  try {
    py::gil_scoped_release nogil;
    data = scene_from_arrays(std::span(vertices.data(), static_cast<size_t>(vertices.size())),
                             std::span(triangles.data(), static_cast<size_t>(triangles.size())),
                             std::span(albedo.data(), static_cast<size_t>(albedo.size())));
  } catch (const Error& e) {
    raise_value_error(e);
  }
  warn_dropped(*data, "triangles");
  return data;
}

py::dict camera_dict(const SceneData& data) {
  const CameraSpec& c = data.loaded.camera;
  const Camera& cam = data.camera;
  py::dict d;
  d["width"] = cam.width();
  d["height"] = cam.height();
  d["position"] = vec3_tuple(cam.position());
  d["look_at"] = vec3_tuple(c.look_at);
  d["up"] = vec3_tuple(c.up);
  d["forward"] = vec3_tuple(cam.forward());
  d["focal_length"] = cam.focal_px();
  d["vertical_fov"] = c.vertical_fov_degrees ? py::object(py::float_(*c.vertical_fov_degrees))
                                             : py::object(py::none());
  d["lab_orbit"] = c.lab_orbit;
  // The lens and projection of the camera as loaded (a glTF file's first camera may be
  // orthographic; scene and pbrt files may give a lens).
  d["aperture_radius"] = cam.lens_radius();
  d["focus_distance"] =
      cam.has_lens() ? py::object(py::float_(cam.focus_distance())) : py::object(py::none());
  d["orthographic"] = cam.is_orthographic();
  return d;
}

// The camera keyword arguments beyond the CLI's flags.
CameraPose camera_pose(const py::object& position, const py::object& look_at, const py::object& up,
                       const py::object& vertical_fov, const py::object& focal_length) {
  CameraPose pose;
  pose.position = optional_vec3("position", position);
  pose.look_at = optional_vec3("look_at", look_at);
  pose.up = optional_vec3("up", up);
  pose.vertical_fov_degrees = optional_number("vertical_fov", vertical_fov);
  if (const std::optional<double> f = optional_number("focal_length", focal_length)) {
    if (!(std::abs(*f) <= std::numeric_limits<float>::max())) {
      throw py::value_error("focal_length: must be positive, got " + format_double(*f));
    }
    pose.focal_length_px = static_cast<float>(*f);
  }
  return pose;
}

View view_of(const SceneData& data, const CameraPose& pose, const SceneOverrides& overrides) {
  try {
    return make_view(data, pose, overrides);
  } catch (const Error& e) {
    raise_value_error(e);
  }
}

py::tuple camera_rays(const std::shared_ptr<SceneData>& data, const py::object& width,
                      const py::object& height, const py::object& yaw, const py::object& distance,
                      const py::object& position, const py::object& look_at, const py::object& up,
                      const py::object& vertical_fov, const py::object& focal_length) {
  FlagTexts texts;
  texts.add_int("--width", width);
  texts.add_int("--height", height);
  texts.add_number("--yaw", yaw);
  texts.add_number("--distance", distance);
  const JobSettings flags = texts.parse();
  const View view = view_of(*data, camera_pose(position, look_at, up, vertical_fov, focal_length),
                            scene_overrides(flags));
  const Camera& camera = view.camera;
  const int w = camera.width(), h = camera.height();
  py::array_t<float> directions(
      {static_cast<py::ssize_t>(h), static_cast<py::ssize_t>(w), py::ssize_t{3}});
  float* out = directions.mutable_data();
  {
    py::gil_scoped_release nogil;
    parallel_chunks(static_cast<size_t>(h), 1, [&](size_t y0, size_t y1) {
      std::vector<Ray> rays(static_cast<size_t>(w));
      for (size_t y = y0; y < y1; ++y) {
        camera.primary_rays(0, static_cast<int>(y), w, static_cast<int>(y) + 1, rays.data());
        float* row = out + y * static_cast<size_t>(w) * 3;
        for (size_t x = 0; x < rays.size(); ++x) {
          row[3 * x] = rays[x].dir.x;
          row[3 * x + 1] = rays[x].dir.y;
          row[3 * x + 2] = rays[x].dir.z;
        }
      }
    });
  }
  return py::make_tuple(vec3_array(camera.position()), directions);
}

// ---------------------------------------------------------------------------------------------
// Accels and ray queries

// Released result memory an accel keeps for its next queries (BufferCache): enough for the
// results of 16M rays.
constexpr size_t kCachedOutputBytes = size_t{256} << 20;

struct PyAccel {
  std::shared_ptr<SceneData> scene;
  AccelKind kind = AccelKind::kBvh;
  Kernel kernel = kDefaultKernel;
  AccelInfo info;
  std::unique_ptr<Accel> accel;
  std::shared_ptr<BufferCache> outputs = std::make_shared<BufferCache>(kCachedOutputBytes);
};

// A buffer from `cache` owned by a capsule, the base object of the result arrays made over it:
// when the last of them is freed, the buffer goes back to the cache.
py::capsule cached_buffer(const std::shared_ptr<BufferCache>& cache, size_t bytes, void** data) {
  struct Owner {
    std::shared_ptr<BufferCache> cache;
    BufferCache::Buffer buffer;
  };
  auto owner = std::make_unique<Owner>(Owner{cache, cache->take(bytes)});
  *data = owner->buffer.data;
  py::capsule capsule(owner.get(), [](void* p) {
    auto* o = static_cast<Owner*>(p);
    o->cache->give(o->buffer);
    delete o;
  });
  owner.release();  // the capsule owns it now
  return capsule;
}

std::shared_ptr<PyAccel> make_py_accel(const std::shared_ptr<SceneData>& scene,
                                       const py::object& kind, const py::object& kernel) {
  FlagTexts texts;
  texts.add_string("--accel", kind, "kind");
  texts.add_string("--kernel", kernel);
  const JobSettings flags = texts.parse();
  auto out = std::make_shared<PyAccel>();
  out->scene = scene;
  out->kind = accel_kind(flags);
  out->kernel = kernel_choice(flags);
  py::gil_scoped_release nogil;
  out->accel = make_accel(out->kind, scene->loaded.scene.mesh, out->kernel, &out->info);
  return out;
}

// The results of Accel.intersect, arrays of the rays' leading shape.
struct Hits {
  py::array_t<float> t, u, v;
  py::array_t<int32_t> prim;
  std::shared_ptr<SceneData> scene;
  py::object normal;  // None until first asked for
};

py::array_t<float> hit_normals(Hits& hits) {
  if (!hits.normal.is_none()) return hits.normal;
  const py::array_t<int32_t>& prim = hits.prim;
  std::vector<py::ssize_t> shape(prim.shape(), prim.shape() + prim.ndim());
  py::array_t<float> normal(with_last(shape, 3));
  const int32_t* p = prim.data();
  float* n = normal.mutable_data();
  const SceneData& data = *hits.scene;
  const auto& normals = data.loaded.scene.mesh.normal();
  {
    py::gil_scoped_release nogil;
    parallel_chunks(static_cast<size_t>(prim.size()), 1 << 14, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        glm::vec3 value(0.0f);
        if (p[i] >= 0) {
          const int32_t tri = data.scene_index.empty() ? p[i] : data.scene_index[p[i]];
          value = normals[static_cast<size_t>(tri)];
        }
        n[3 * i] = value.x;
        n[3 * i + 1] = value.y;
        n[3 * i + 2] = value.z;
      }
    });
  }
  hits.normal = normal;
  return normal;
}

Coherence coherence_arg(const py::object& coherent) {
  if (coherent.is_none()) return Coherence::kAuto;
  if (!PyBool_Check(coherent.ptr())) {
    raise_type_error("coherent: must be True, False or None, got " +
                     std::string(Py_TYPE(coherent.ptr())->tp_name));
  }
  return coherent.cast<bool>() ? Coherence::kCoherent : Coherence::kIncoherent;
}

Hits intersect(const PyAccel& self, const py::object& origins, const py::object& directions,
               const py::object& tmin, const py::object& tmax, const py::object& coherent) {
  const Coherence c = coherence_arg(coherent);
  RayInput in = ray_input(origins, directions, tmin, tmax);
  // The four result arrays share one buffer: t, prim, u, v one after another, each starting on
  // a cache line.
  const size_t n = element_count(in.shape);
  const size_t stride = (n + 15) / 16 * 16;  // floats
  void* data = nullptr;
  const py::capsule base = cached_buffer(self.outputs, 16 * stride, &data);
  float* t = static_cast<float*>(data);
  auto* prim = reinterpret_cast<int32_t*>(t + stride);
  float* u = t + 2 * stride;
  float* v = t + 3 * stride;
  Hits hits{py::array_t<float>(in.shape, t, base),
            py::array_t<float>(in.shape, u, base),
            py::array_t<float>(in.shape, v, base),
            py::array_t<int32_t>(in.shape, prim, base),
            self.scene,
            py::none()};
  // Results beyond what the caches hold (4 MiB) are streamed to memory.
  const HitArrays out{t, prim, u, v, 16 * n > (size_t{4} << 20)};
  std::optional<RayProblem> problem;
  {
    py::gil_scoped_release nogil;
    problem = trace_closest(*self.accel, in.arrays(), out, c, self.scene->caller_index,
                            self.scene->caller_order_swapped);
  }
  if (problem) throw py::value_error(problem->reason);
  return hits;
}

py::array_t<bool> occluded(const PyAccel& self, const py::object& origins,
                           const py::object& directions, const py::object& tmin,
                           const py::object& tmax, const py::object& coherent) {
  const Coherence c = coherence_arg(coherent);
  RayInput in = ray_input(origins, directions, tmin, tmax);
  static_assert(sizeof(bool) == 1);
  void* data = nullptr;
  const py::capsule base = cached_buffer(self.outputs, element_count(in.shape), &data);
  auto* bytes = static_cast<uint8_t*>(data);
  py::array_t<bool> out(in.shape, reinterpret_cast<bool*>(bytes), base);
  std::optional<RayProblem> problem;
  {
    py::gil_scoped_release nogil;
    problem = trace_occluded(*self.accel, in.arrays(), bytes, c);
  }
  if (problem) throw py::value_error(problem->reason);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Renders

struct Frame {
  py::array_t<float> image;
  py::object albedo = py::none(), normal = py::none(), depth = py::none(), variance = py::none();
  py::object spp_map = py::none();  // the spp AOV: samples per pixel, (height, width)
  std::string integrator;
  uint32_t spp = 0;
  double mean_spp = 0.0;
  float light_paths = 0.0f;  // bdpt's share of samples with a light subpath (0: not bdpt)
  double milliseconds = 0.0;
  uint64_t rays = 0;
  int threads = 0;
};

AovSet aov_set(const py::object& aovs) {
  AovSet set;
  if (aovs.is_none()) return set;
  if (py::isinstance<py::str>(aovs) || !py::isinstance<py::sequence>(aovs)) {
    raise_type_error(
        "aovs: must be a sequence of names (albedo, normal, depth, variance, spp), got " +
        std::string(Py_TYPE(aovs.ptr())->tp_name));
  }
  for (const py::handle item : aovs) {
    const std::string name = string_arg("aovs", py::reinterpret_borrow<py::object>(item));
    if (!add_aov(name, &set)) {
      throw py::value_error("aovs: unknown AOV '" + name +
                            "' (use albedo, normal, depth, variance, spp)");
    }
  }
  return set;
}

// The job setting's text for `set`: "albedo,normal,depth,variance" or a subset; empty for none.
std::string aov_names(const AovSet& set) {
  return aov_list(set);
}

// An H x W x channels float32 array of an image's first `channels` channels, row 0 at the top.
py::array_t<float> image_array(const Image& image, int channels) {
  const py::ssize_t h = image.height(), w = image.width();
  py::array_t<float> out(channels == 3 ? std::vector<py::ssize_t>{h, w, 3}
                                       : std::vector<py::ssize_t>{h, w});
  float* o = out.mutable_data();
  const std::vector<glm::vec3>& pixels = image.pixels();
  for (size_t i = 0; i < pixels.size(); ++i) {
    for (int c = 0; c < channels; ++c) o[channels * i + c] = pixels[i][c];
  }
  return out;
}

Frame render_scene(const std::shared_ptr<SceneData>& data, const py::object& integrator,
                   const py::object& spp, const py::object& width, const py::object& height,
                   const py::object& seed, const py::object& sampler, const py::object& max_depth,
                   const py::object& filter, const py::object& aovs, const py::object& accel,
                   const py::object& kernel, const py::object& threads, const py::object& position,
                   const py::object& look_at, const py::object& up, const py::object& vertical_fov,
                   const py::object& focal_length, const py::object& yaw,
                   const py::object& distance, const py::object& light,
                   const py::object& time_limit, const py::object& denoise, const py::object& clamp,
                   const py::object& noise_threshold, const py::object& aperture,
                   const py::object& focus, const py::object& light_paths) {
  // The CLI's flags, parsed and checked by the CLI's own code.
  FlagTexts texts;
  texts.add_string("--integrator", integrator);
  texts.add_int("--spp", spp);
  texts.add_int("--width", width);
  texts.add_int("--height", height);
  texts.add_int("--seed", seed);
  texts.add_string("--sampler", sampler);
  texts.add_int("--max-depth", max_depth);
  texts.add_string("--filter", filter);
  texts.add_int("--threads", threads);
  texts.add_number("--yaw", yaw);
  texts.add_number("--distance", distance);
  texts.add_vec3("--light", light);
  texts.add_number("--time-limit", time_limit);
  texts.add_number("--clamp", clamp);
  texts.add_number("--noise-threshold", noise_threshold);
  texts.add_number("--aperture", aperture);
  texts.add_number("--focus", focus);
  // A share, or "auto" (the pilot's choice, bdpt_pilot.h).
  if (py::isinstance<py::str>(light_paths)) {
    texts.add_string("--light-paths", light_paths);
  } else {
    texts.add_number("--light-paths", light_paths);
  }
  std::shared_ptr<PyAccel> prebuilt;
  if (!accel.is_none() && !py::isinstance<py::str>(accel)) {
    if (!py::isinstance<PyAccel>(accel)) {
      raise_type_error("accel: must be a str or a tritrace.Accel, got " +
                       std::string(Py_TYPE(accel.ptr())->tp_name));
    }
    prebuilt = accel.cast<std::shared_ptr<PyAccel>>();
    if (prebuilt->scene != data) throw py::value_error("accel: was built for another scene");
    if (!kernel.is_none()) {
      throw py::value_error("kernel: give it to tritrace.Accel; this accel has its own");
    }
  } else {
    texts.add_string("--accel", accel);
    texts.add_string("--kernel", kernel);
  }
  JobSettings settings = texts.parse();
  if (!denoise.is_none()) {
    if (!PyBool_Check(denoise.ptr())) {
      raise_type_error("denoise: must be a bool, got " +
                       std::string(Py_TYPE(denoise.ptr())->tp_name));
    }
    settings.denoise = denoise.cast<bool>();
  }
  const AovSet aov = aov_set(aovs);
  settings.aovs = aov_names(aov);
  const View view = view_of(*data, camera_pose(position, look_at, up, vertical_fov, focal_length),
                            scene_overrides(settings));

  Frame frame;
  RenderedImage rendered;
  RenderStats stats;
  IntegratorSpec spec;
  float used_light_paths = 0.0f;
  try {
    py::gil_scoped_release nogil;
    // The view's camera and lights are the scene's while the lock lives: the job is made, builds
    // the tree `tritrace render` would build (or takes the prebuilt accel) and renders under it.
    ViewLock lock(*data, view);
    RenderJob job(settings, lock.scene(), data->loaded.integrator);
    job.prepare(nullptr, prebuilt ? prebuilt->accel.get() : nullptr);
    rendered = job.render(&stats);
    spec = job.spec();
    used_light_paths = job.light_paths();
  } catch (const Error& e) {
    // A combination of arguments the job refuses (time_limit with the lab integrator ...).
    if (e.exit_code() == ExitCode::kUsage) raise_value_error(e);
    throw;
  }
  const Image& image = rendered.image;
  const Image& albedo_image = rendered.aovs.albedo;
  const Image& normal_image = rendered.aovs.normal;
  const Image& depth_image = rendered.aovs.depth;
  frame.image = image_array(image, 3);
  if (aov.albedo) frame.albedo = image_array(albedo_image, 3);
  if (aov.normal) frame.normal = image_array(normal_image, 3);
  if (aov.depth) frame.depth = image_array(depth_image, 1);
  if (aov.variance) frame.variance = image_array(rendered.aovs.variance, 3);
  if (aov.spp) frame.spp_map = image_array(rendered.aovs.spp, 1);
  frame.integrator = std::string(integrator_name(spec.kind));
  frame.spp = stats.spp;
  frame.mean_spp = stats.mean_spp();
  frame.light_paths = used_light_paths;
  frame.milliseconds = stats.milliseconds;
  frame.rays = stats.rays;
  frame.threads = stats.threads;
  return frame;
}

py::tuple names(const std::vector<std::string>& list) {
  py::tuple t(list.size());
  for (size_t i = 0; i < list.size(); ++i) t[i] = list[i];
  return t;
}

}  // namespace
}  // namespace tritrace::python

// ---------------------------------------------------------------------------------------------

PYBIND11_MODULE(tritrace, m) {
  using namespace tritrace;
  using namespace tritrace::python;
  const py::object inf = py::float_(std::numeric_limits<double>::infinity());
  const py::object none = py::none();

  m.doc() =
      "tritrace: fast, watertight ray queries and renders of triangle scenes on NumPy arrays.\n\n"
      "Scenes come from files (tritrace.load), built-in scenes (Scene.builtin) or arrays\n"
      "(Scene.from_arrays); tritrace.Accel traces batches of rays on every core with the GIL\n"
      "released; tritrace.render renders what `tritrace render` renders, bit for bit.\n"
      "See docs/PYTHON.md.";
  m.attr("__version__") = TRITRACE_VERSION;
  {
    std::vector<std::string> accels, kernels;
    for (AccelKind k : available_accels()) accels.emplace_back(accel_name(k));
    for (Kernel k : kAllKernels) kernels.emplace_back(kernel_name(k));
    m.attr("accels") = names(accels);
    m.attr("kernels") = names(kernels);
  }

  py::class_<SceneData, std::shared_ptr<SceneData>>(
      m, "Scene",
      R"(A triangle scene: geometry, materials, lights and a camera. Read-only once made.

Make one with tritrace.load(path), Scene.builtin(name) or Scene.from_arrays(...).)")
      .def_static("builtin", &builtin, "name"_a,
                  R"(A built-in scene: "cornell" (the lab's box, 30 triangles), "cornell-area"
(the box lit by a ceiling light) or "terrain:<triangles>" ("terrain:1m", "terrain:250k"),
exactly as `tritrace render --scene NAME` builds it.)")
      .def_static("from_arrays", &from_arrays, "vertices"_a, "triangles"_a, "materials"_a = none,
                  R"(A scene of triangles given as arrays, set up as a mesh file is.

vertices: (N, 3) numbers; triangles: (M, 3) integer vertex indices; materials: None (the
neutral grey 0.6 of mesh files), one albedo (3,) for every triangle, or one per triangle
(M, 3), each in [0, 1]. The camera is framed on the bounds, with a point light near it, as
`tritrace render mesh.obj` does. Degenerate and non-finite triangles are dropped (with a
RuntimeWarning); hits still report indices into `triangles`.)")
      .def_property_readonly(
          "source", [](const SceneData& s) { return s.source; },
          "The file, the built-in scene's name, or 'arrays'.")
      .def_property_readonly(
          "triangle_count", [](const SceneData& s) { return s.loaded.scene.mesh.size(); },
          "Triangles in the scene (after dropping degenerate and non-finite ones).")
      .def_property_readonly(
          "dropped_degenerate",
          [](const SceneData& s) { return s.loaded.stats.dropped_degenerate; },
          "Zero-area triangles dropped while loading.")
      .def_property_readonly(
          "dropped_non_finite",
          [](const SceneData& s) { return s.loaded.stats.dropped_non_finite; },
          "Triangles with a NaN or infinite vertex (or overflowing edges) dropped while loading.")
      .def_property_readonly(
          "bounds",
          [](const SceneData& s) {
            const Bounds3 b = s.loaded.scene.mesh.bounds();
            return py::make_tuple(vec3_array(b.lo), vec3_array(b.hi));
          },
          "(lo, hi): the corners of the scene's bounding box, float32 arrays of shape (3,).")
      .def_property_readonly(
          "integrator",
          [](const SceneData& s) { return std::string(integrator_name(s.loaded.integrator.kind)); },
          "The integrator the scene asks for when render() is given none: 'lab', 'path' or 'bdpt'.")
      .def_property_readonly("camera", &camera_dict,
                             "The scene's own camera: width, height, position, look_at, up, "
                             "forward, focal_length (pixels), vertical_fov (degrees or None), "
                             "lab_orbit, aperture_radius (0: a pinhole), focus_distance (None "
                             "without a lens), orthographic.")
      .def_property_readonly(
          "lights",
          [](const SceneData& s) {
            py::list out;
            for (const PointLight& l : s.lights) {
              out.append(
                  py::dict("position"_a = vec3_tuple(l.position), "power"_a = vec3_tuple(l.power)));
            }
            return out;
          },
          "The point lights: a list of {'position': (x, y, z), 'power': (r, g, b)}.")
      .def_property_readonly(
          "spot_lights",
          [](const SceneData& s) {
            py::list out;
            for (const SpotLight& l : s.loaded.scene.spot_lights) {
              const double to_degrees = 180.0 / std::numbers::pi;
              out.append(py::dict(
                  "position"_a = vec3_tuple(l.position), "direction"_a = vec3_tuple(l.direction),
                  "intensity"_a = vec3_tuple(l.intensity),
                  "inner_angle"_a = std::acos(static_cast<double>(l.cos_inner)) * to_degrees,
                  "outer_angle"_a = std::acos(static_cast<double>(l.cos_outer)) * to_degrees,
                  "falloff"_a = l.falloff == SpotFalloff::kGltf ? "gltf" : "smoothstep"));
            }
            return out;
          },
          "The spot lights: a list of {'position', 'direction' (unit), 'intensity' (W/sr on the "
          "axis), 'inner_angle', 'outer_angle' (degrees from the axis), 'falloff' ('gltf' or "
          "'smoothstep')}.")
      .def_property_readonly(
          "directional_lights",
          [](const SceneData& s) {
            py::list out;
            for (const DirectionalLight& l : s.loaded.scene.directional_lights) {
              out.append(py::dict("direction"_a = vec3_tuple(l.direction),
                                  "irradiance"_a = vec3_tuple(l.irradiance)));
            }
            return out;
          },
          "The directional lights: a list of {'direction': the way the light travels (unit), "
          "'irradiance': (r, g, b) W/m^2}.")
      .def("camera_rays", &camera_rays, py::kw_only(), "width"_a = none, "height"_a = none,
           "yaw"_a = none, "distance"_a = none, "position"_a = none, "look_at"_a = none,
           "up"_a = none, "vertical_fov"_a = none, "focal_length"_a = none,
           R"(The camera's rays through every pixel's top-left corner, as the lab integrator
traces them: (origin, directions), origin of shape (3,) and unit directions of shape
(height, width, 3), float32. The keyword arguments are render()'s camera settings.)")
      .def("__repr__", [](const SceneData& s) {
        return "<tritrace.Scene '" + s.source + "', " + std::to_string(s.loaded.scene.mesh.size()) +
               " triangles>";
      });

  m.def("load", &load, "path"_a,
        R"(Loads a scene file (.json) or a mesh file (anything assimp reads: .obj, .ply, .stl,
.gltf, .glb, ...) as `tritrace render FILE` does. Raises OSError (FileNotFoundError,
IsADirectoryError, PermissionError where they apply) with the CLI's message.)");

  py::class_<Hits>(m, "Hits", R"(The closest hits of a batch of rays, as arrays of the rays' shape.

t: float32 distance along each ray in units of its direction's length (inf where it missed);
prim: int32 triangle index (-1 where it missed); u, v: float32 barycentric weights of the
triangle's second and third vertices (0 where it missed; for Scene.from_arrays those of
triangles[prim, 1] and triangles[prim, 2]); normal: float32 (..., 3) unit geometric normal of
the hit triangle, not turned toward the ray (0 where it missed), computed when first read: the
counter-clockwise normalize(cross(b - a, c - a)) of each triangle (a, b, c) of Scene.from_arrays
and of mesh files, the lab's normalize(cross(v2 - v0, v1 - v0)) in built-in scenes and scene
files' inline meshes; hit: bool, prim >= 0.)")
      .def_readonly("t", &Hits::t)
      .def_readonly("prim", &Hits::prim)
      .def_readonly("u", &Hits::u)
      .def_readonly("v", &Hits::v)
      .def_property_readonly("normal", &hit_normals)
      .def_property_readonly("hit",
                             [](const Hits& h) { return py::array(h.prim.attr("__ge__")(0)); })
      .def("__repr__", [](const Hits& h) {
        size_t found = 0;
        const int32_t* p = h.prim.data();
        for (py::ssize_t i = 0; i < h.prim.size(); ++i) found += p[i] >= 0 ? 1 : 0;
        return "<tritrace.Hits: " + std::to_string(h.prim.size()) + " rays, " +
               std::to_string(found) + " hit>";
      });

  py::class_<PyAccel, std::shared_ptr<PyAccel>>(
      m, "Accel", R"(An acceleration structure over a scene's triangles, for batched ray queries.

Accel(scene, kind="bvh", kernel=None): kind is one of tritrace.accels ("bvh", "bvh-single",
"brute", and the Embree modes where built); kernel one of tritrace.kernels, by default the
watertight kernel (Embree always uses its own). Queries release the GIL, use every core and
may run from several threads at once.)")
      .def(py::init(&make_py_accel), "scene"_a, "kind"_a = "bvh", "kernel"_a = none)
      .def("intersect", &intersect, "origins"_a, "directions"_a, "tmin"_a = 0.0, "tmax"_a = inf,
           py::kw_only(), "coherent"_a = none,
           R"(The closest hit of each ray within [tmin, tmax], as a tritrace.Hits.

origins and directions: arrays of shape (..., 3), or (3,) for one shared by every ray; any
real dtype (C-contiguous float32 is read in place, anything else converted once). tmin and
tmax: numbers, or arrays of the rays' shape. Directions need not be unit length: t is in
units of their length. A ray with a non-finite origin or direction, a zero direction, a
negative or NaN tmin or a NaN tmax raises ValueError naming the first one. coherent: None
chooses per batch of 256 rays between packet traversal (rays sharing a direction octant, as
a camera's do) and single rays; True or False forces one. The hits are the same either way,
bit for bit.)")
      .def("occluded", &occluded, "origins"_a, "directions"_a, "tmin"_a = 0.0, "tmax"_a = inf,
           py::kw_only(), "coherent"_a = none,
           "Whether each ray hits any triangle within [tmin, tmax]: a bool array of the rays' "
           "shape. Arguments as for intersect().")
      .def_property_readonly(
          "kind", [](const PyAccel& a) { return std::string(accel_name(a.kind)); },
          "The structure's name.")
      .def_property_readonly(
          "kernel",
          [](const PyAccel& a) {
            const bool embree = accel_name(a.kind).starts_with("embree");
            return embree ? std::string("embree") : std::string(kernel_name(a.kernel));
          },
          "The ray/triangle kernel ('embree' for Embree's own).")
      .def_property_readonly(
          "scene", [](const PyAccel& a) { return a.scene; }, "The scene it was built over.")
      .def_property_readonly(
          "build_ms", [](const PyAccel& a) { return a.info.build_ms; },
          "Milliseconds the build took.")
      .def("__repr__", [](const PyAccel& a) {
        return "<tritrace.Accel " + std::string(accel_name(a.kind)) + " over " +
               std::to_string(a.scene->loaded.scene.mesh.size()) + " triangles>";
      });

  py::class_<Frame>(m, "Frame", R"(A rendered image and its AOVs.

image: float32 (height, width, 3), linear radiance (row 0 at the top: a PFM file stores rows
bottom-up); albedo, normal: (height, width, 3) and depth: (height, width), or None when not
asked for; variance: (height, width, 3), the estimated variance of each pixel's mean (from
the halves of its samples split by sample index parity), or None; spp_map: (height, width), the
samples each pixel took (aovs "spp"), or None; integrator, spp (the most a pixel took), mean_spp,
light_paths (bdpt: the share of samples with a light subpath, light_paths="auto"'s choice; 0
otherwise), milliseconds, rays, threads: what was rendered and how.)")
      .def_readonly("image", &Frame::image)
      .def_readonly("albedo", &Frame::albedo)
      .def_readonly("normal", &Frame::normal)
      .def_readonly("depth", &Frame::depth)
      .def_readonly("variance", &Frame::variance)
      .def_readonly("integrator", &Frame::integrator)
      .def_readonly("spp", &Frame::spp)
      .def_readonly("mean_spp", &Frame::mean_spp)
      .def_readonly("light_paths", &Frame::light_paths)
      .def_readonly("spp_map", &Frame::spp_map)
      .def_readonly("milliseconds", &Frame::milliseconds)
      .def_readonly("rays", &Frame::rays)
      .def_readonly("threads", &Frame::threads)
      .def("__repr__", [](const Frame& f) {
        return "<tritrace.Frame " + std::to_string(f.image.shape(1)) + "x" +
               std::to_string(f.image.shape(0)) + ", " + f.integrator + ", " +
               std::to_string(f.spp) + " spp>";
      });

  QuerySceneClass query_scene = register_query_scene(m);
  register_distance_queries(query_scene);

  m.def("denoise", &denoise_arrays, "color"_a, "albedo"_a = none, "normal"_a = none,
        "depth"_a = none, "variance"_a = none, py::kw_only(), "search_radius"_a = 7,
        "sampler"_a = "sobol", "threads"_a = none,
        R"(Denoises an image with the built-in feature-guided denoiser, as `tritrace denoise`
denoises an EXR with the same layers, returning a new float32 (height, width, 3) array.

color: (height, width, 3) linear radiance; albedo and normal: (height, width, 3), depth:
(height, width), the first non-specular hit's features as render() returns them (aovs
"albedo", "normal", "depth"), or None to leave that feature out (without albedo the colour is
not divided by it); variance: (height, width, 3), the variance of each pixel's mean (render()'s
aovs "variance"), averaged over 5 x 5 pixels as `tritrace denoise` averages an EXR's variance
layer, or None to estimate it from the image (larger than the truth at edges). sampler: the
sampler the render used, "sobol" (render()'s default) or "independent": the variance of the
Sobol sampler's sample halves is about twice the truth and is halved, the independent
sampler's is taken as it is. So denoise(f.image, f.albedo, f.normal, f.depth, f.variance,
sampler=s) of a render f with sampler s is the image render(..., denoise=True) returns, bit
for bit. Any real dtype (converted once to float32); every value must be finite.
search_radius: 1 to 32 (a (2r+1)^2 window; larger smooths more and takes longer); threads: None (all cores) or a count. The result is the same for any
thread count. Releases the GIL while filtering. Bad shapes or values raise ValueError naming
the argument, wrong types TypeError.)");

  m.def("render", &render_scene, "scene"_a, py::kw_only(), "integrator"_a = none, "spp"_a = none,
        "width"_a = none, "height"_a = none, "seed"_a = none, "sampler"_a = none,
        "max_depth"_a = none, "filter"_a = none, "aovs"_a = py::tuple(), "accel"_a = none,
        "kernel"_a = none, "threads"_a = none, "position"_a = none, "look_at"_a = none,
        "up"_a = none, "vertical_fov"_a = none, "focal_length"_a = none, "yaw"_a = none,
        "distance"_a = none, "light"_a = none, "time_limit"_a = none, "denoise"_a = none,
        "clamp"_a = none, "noise_threshold"_a = none, "aperture"_a = none, "focus"_a = none,
        "light_paths"_a = none,
        R"(Renders the scene as `tritrace render` does, returning a tritrace.Frame.

The image is bit for bit the one `tritrace render ... -o out.pfm` writes with the same
settings. Every argument left None is the scene's own (or the CLI's default): integrator
("lab", "path" or "bdpt"), spp, width, height, seed, sampler ("sobol" or "independent"),
max_depth, filter ("box", "gaussian", "blackman-harris"), accel (a name, or an Accel built
over this scene, to reuse it across renders), kernel, threads (default all cores), yaw
(radians, orbiting look_at), distance (to look_at), light (the first point light's position),
time_limit (seconds: the path tracer's samples in passes until the time is up, spp the most;
Frame.spp says how many were reached, and the image is the one that spp gives), denoise (True:
the path tracer's image through the built-in denoiser, as `tritrace render --denoise`), clamp
(the most one sample's indirect light adds to a pixel, per channel: biased, as
`tritrace render --clamp`), noise_threshold (adaptive sampling: every pixel takes a pilot of 64
samples, then 64 e / T more in steps of 64, 128, 256, ..., spp the most, e the error of its 5 x 5
neighbours' pilots within its 16 x 16 tile, never its own, so the image is unbiased, as
`tritrace render --noise-threshold`; Frame.mean_spp says how many it took), aperture
(a thin lens's radius in world units, as `tritrace render --aperture`; path only), focus
(the distance of the plane in focus, as --focus), light_paths (bdpt only: the share of samples,
in (0, 1], that also trace a light subpath, as `tritrace render --light-paths`; or
"auto", the default: the pilot's choice per scene, which Frame.light_paths reports).
aovs: any of "albedo", "normal", "depth", "variance", "spp". Camera settings beyond the CLI's
flags, as a scene file's camera has them: position, look_at, up, vertical_fov (degrees) or
focal_length (pixels); giving any to a built-in scene replaces the lab's orbit camera with a
look-at camera. Bad values raise ValueError with the CLI's message.)");
}
