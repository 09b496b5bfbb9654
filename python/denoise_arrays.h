// tritrace.denoise: the built-in feature-guided denoiser (tritrace/denoise/denoiser.h) on NumPy
// arrays, so that images rendered elsewhere, or a render's colour and AOVs, are denoised as
// `tritrace denoise` denoises an EXR with the same layers.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace tritrace::python {

namespace py = pybind11;

// color (H, W, 3); albedo, normal and variance (H, W, 3) or None; depth (H, W) or None. The
// variance is that of each pixel's mean (a render's variance AOV), averaged over 5 x 5 pixels as
// `tritrace denoise` averages an EXR's variance layer; None: estimated from the image as
// `tritrace denoise` does for an EXR without one. A feature left None is left out of the
// neighbours' weights (and without albedo the colour is filtered as it is, not demodulated).
// search_radius: 1 to 32, as the CLI's --search-radius; sampler: "sobol" or "independent", the
// sampler that rendered the variance (its halves' overestimate divides it); threads: None (all
// cores) or as render()'s. Checks every argument (ValueError or TypeError naming it), then filters
// with the GIL released. Returns a new (H, W, 3) float32 array.
py::array_t<float> denoise_arrays(const py::object& color, const py::object& albedo,
                                  const py::object& normal, const py::object& depth,
                                  const py::object& variance, const py::object& search_radius,
                                  const py::object& sampler, const py::object& threads);

}  // namespace tritrace::python
