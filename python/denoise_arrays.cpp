// tritrace.denoise: arrays checked and copied into the library's images with the GIL held, the
// filter run with it released (in an arena of `threads` when given), the result copied out.
#include "denoise_arrays.h"

#include <cmath>
#include <optional>
#include <string>

#include "convert.h"
#include "tritrace/denoise/denoiser.h"
#include "tritrace/image/image.h"
#include "tritrace/image/image_limits.h"
#include "tritrace/parallel.h"

namespace tritrace::python {
namespace {

// The same bounds as `tritrace denoise --search-radius`.
constexpr int kMinSearchRadius = 1, kMaxSearchRadius = 32;

std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

std::string type_of(const py::object& value) {
  return Py_TYPE(value.ptr())->tp_name;
}

// `value` as an image of `width` x `height` (both 0: take them from the array, which must then
// have at least one pixel), with `channels` 3 ((H, W, 3)) or 1 ((H, W), copied into all three
// channels, as `tritrace denoise` reads the EXR's Z). Every value must be finite.
Image image_arg(const char* name, const py::object& value, int channels, int* width, int* height,
                const char* like) {
  const py::array_t<float> a = float32_array(name, value);
  const std::string wanted = channels == 3 ? "(height, width, 3)" : "(height, width)";
  const bool shape_ok = a.ndim() == (channels == 3 ? 3 : 2) && (channels == 1 || a.shape(2) == 3);
  if (*width == 0) {
    if (!shape_ok) {
      throw py::value_error(std::string(name) + ": must have shape " + wanted + ", got " +
                            shape_of(a));
    }
    if (a.shape(0) == 0 || a.shape(1) == 0) {
      throw py::value_error(std::string(name) + ": must have at least one pixel, got shape " +
                            shape_of(a));
    }
    if (a.shape(0) > kMaxImageSide || a.shape(1) > kMaxImageSide) {
      throw py::value_error(std::string(name) + ": must be at most " +
                            std::to_string(kMaxImageSide) + " pixels on a side, got shape " +
                            shape_of(a));
    }
    *height = static_cast<int>(a.shape(0));
    *width = static_cast<int>(a.shape(1));
  } else if (!shape_ok || a.shape(0) != *height || a.shape(1) != *width) {
    const std::string expected = "(" + std::to_string(*height) + ", " + std::to_string(*width) +
                                 (channels == 3 ? ", 3)" : ")");
    throw py::value_error(std::string(name) + ": must have shape " + expected + " (" + like +
                          "'s height and width), got " + shape_of(a));
  }
  const int w = *width, h = *height;
  Image image(w, h);
  const float* p = a.data();
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x, p += channels) {
      glm::vec3& out = image.at(x, y);
      for (int c = 0; c < 3; ++c) {
        const float v = p[channels == 3 ? c : 0];
        if (!std::isfinite(v)) {
          throw py::value_error(std::string(name) + ": must be finite, got " + std::to_string(v) +
                                " at row " + std::to_string(y) + ", column " + std::to_string(x));
        }
        out[c] = v;
      }
    }
  }
  return image;
}

int search_radius_arg(const py::object& value) {
  if (PyBool_Check(value.ptr()) || !PyIndex_Check(value.ptr())) {
    raise_type_error("search_radius: must be an int, got " + type_of(value));
  }
  const py::int_ index = py::reinterpret_steal<py::int_>(PyNumber_Index(value.ptr()));
  int overflow = 0;
  const long long r = PyLong_AsLongLongAndOverflow(index.ptr(), &overflow);
  if (overflow != 0 || r < kMinSearchRadius || r > kMaxSearchRadius) {
    throw py::value_error(
        "search_radius: must be an integer from " + std::to_string(kMinSearchRadius) + " to " +
        std::to_string(kMaxSearchRadius) + ", got " + std::string(py::str(value)));
  }
  return static_cast<int>(r);
}

// The sampler that rendered the variance's halves: "sobol" (render()'s default) or
// "independent".
SamplerKind sampler_arg(const py::object& value) {
  if (!PyUnicode_Check(value.ptr()))
    raise_type_error("sampler: must be a str, got " + type_of(value));
  const std::string name = value.cast<std::string>();
  const std::optional<SamplerKind> kind = parse_sampler(name);
  if (!kind) {
    throw py::value_error("sampler: must be 'sobol' or 'independent', got '" + name + "'");
  }
  return *kind;
}

}  // namespace

py::array_t<float> denoise_arrays(const py::object& color, const py::object& albedo,
                                  const py::object& normal, const py::object& depth,
                                  const py::object& variance, const py::object& search_radius,
                                  const py::object& sampler, const py::object& threads) {
  int width = 0, height = 0;
  const Image colour = image_arg("color", color, 3, &width, &height, "");
  DenoiseOptions options;
  options.search_radius = search_radius_arg(search_radius);
  const float overestimate = half_buffer_variance_ratio(sampler_arg(sampler));
  FlagTexts texts;
  texts.add_int("--threads", threads);
  const int thread_count_given = thread_count(texts.parse());

  // A feature not given is a black image whose distances are left out (scale 0); without albedo
  // there is nothing to divide the colour by.
  const auto feature = [&](const char* name, const py::object& value, int channels) {
    return value.is_none() ? Image(width, height)
                           : image_arg(name, value, channels, &width, &height, "color");
  };
  const Image albedo_image = feature("albedo", albedo, 3);
  const Image normal_image = feature("normal", normal, 3);
  const Image depth_image = feature("depth", depth, 1);
  std::optional<Image> variance_image;
  if (!variance.is_none()) {
    variance_image = image_arg("variance", variance, 3, &width, &height, "color");
  }
  if (albedo.is_none()) {
    options.albedo_scale = 0.0f;
    options.albedo_relative_scale = 0.0f;
    options.demodulate_albedo = false;
  }
  if (normal.is_none()) options.normal_scale = 0.0f;
  if (depth.is_none()) options.depth_scale = 0.0f;

  Image result;
  {
    py::gil_scoped_release nogil;
    // What `tritrace denoise` does with an EXR's layers (apps/tritrace/denoise_command.cpp): the
    // variance layer averaged over 5 x 5 pixels and divided by the sampler's overestimate, else
    // the variance estimated from the image.
    const auto run = [&] {
      const Image v = variance_image ? smooth_variance(*variance_image, 2, overestimate)
                                     : estimate_variance_spatially(colour, albedo_image);
      result = denoise(colour, v, {albedo_image, normal_image, depth_image}, options);
    };
    if (thread_count_given > 0) {
      parallel::in_arena(thread_count_given, run);
    } else {
      run();
    }
  }
  py::array_t<float> out({static_cast<py::ssize_t>(height), static_cast<py::ssize_t>(width),
                          static_cast<py::ssize_t>(3)});
  float* o = out.mutable_data();
  for (const glm::vec3& p : result.pixels()) {
    *o++ = p.x;
    *o++ = p.y;
    *o++ = p.z;
  }
  return out;
}

}  // namespace tritrace::python
