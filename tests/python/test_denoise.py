# tritrace.denoise on NumPy arrays: the CLI's `tritrace denoise` of the same EXR layers bit for bit,
# render(denoise=True) bit for bit, a constant image kept exactly, noise removed from a known
# smooth image, edges in the albedo kept, the GIL released, and every bad argument refused with
# its name.
import sys
import threading

import numpy as np
import pytest

import tritrace
from conftest import read_exr, read_pfm, run_cli

SIZE = dict(width=48, height=40)


def exr_layers(path):
    """color, albedo, normal, depth, variance (None when absent) from a render's EXR."""
    ch = read_exr(path)

    def rgb(names):
        return np.stack([ch[n] for n in names], axis=-1) if names[0] in ch else None

    return (rgb(["R", "G", "B"]), rgb(["albedo.R", "albedo.G", "albedo.B"]),
            rgb(["normal.X", "normal.Y", "normal.Z"]), ch["Z"],
            rgb(["variance.R", "variance.G", "variance.B"]))


@pytest.mark.parametrize("aovs, radius", [("albedo,normal,depth,variance", None),
                                          ("albedo,normal,depth", None),
                                          ("albedo,normal,depth,variance", 3)])
def test_same_image_as_the_cli_denoise_of_the_same_exr(tmp_path, aovs, radius):
    source = tmp_path / "in.exr"
    run_cli("render", "--scene", "cornell-area", "--width", 48, "--height", 40, "--spp", 8,
            "--aovs", aovs, "-o", source, "-q")
    extra = [] if radius is None else ["--search-radius", radius]
    run_cli("denoise", source, "-o", tmp_path / "out.pfm", "-q", *extra)
    colour, albedo, normal, depth, variance = exr_layers(source)
    assert (variance is None) == ("variance" not in aovs)
    kwargs = {} if radius is None else {"search_radius": radius}
    mine = tritrace.denoise(colour, albedo, normal, depth, variance, **kwargs)
    assert mine.dtype == np.float32 and mine.shape == (40, 48, 3)
    np.testing.assert_array_equal(mine, read_pfm(tmp_path / "out.pfm"))
    # A denoiser that changes nothing would pass the test above only if the CLI did nothing too.
    assert not np.array_equal(mine, colour)


def test_render_with_denoise_is_denoise_of_the_renders_arrays():
    scene = tritrace.Scene.builtin("cornell-area")
    args = dict(SIZE, spp=16, seed=3)
    plain = tritrace.render(scene, aovs=("albedo", "normal", "depth", "variance"), **args)
    denoised = tritrace.render(scene, denoise=True, **args)
    mine = tritrace.denoise(plain.image, plain.albedo, plain.normal, plain.depth, plain.variance)
    np.testing.assert_array_equal(mine, denoised.image)
    # The input arrays are not changed.
    np.testing.assert_array_equal(plain.image, tritrace.render(scene, **args).image)


def test_sampler_keyword_matches_render_with_that_sampler():
    # The independent sampler's half-buffer variance is taken as it is, Sobol's halved: each
    # render(denoise=True) is denoise(...) with its own sampler, and not with the other.
    scene = tritrace.Scene.builtin("cornell-area")
    args = dict(SIZE, spp=8, seed=5, sampler="independent")
    plain = tritrace.render(scene, aovs=("albedo", "normal", "depth", "variance"), **args)
    denoised = tritrace.render(scene, denoise=True, **args)
    inputs = (plain.image, plain.albedo, plain.normal, plain.depth, plain.variance)
    np.testing.assert_array_equal(tritrace.denoise(*inputs, sampler="independent"), denoised.image)
    assert not np.array_equal(tritrace.denoise(*inputs), denoised.image)
    # Sobol's factor of 2 on the variance is the independent sampler's on half the variance.
    halved = (plain.image, plain.albedo, plain.normal, plain.depth, plain.variance * 0.5)
    np.testing.assert_array_equal(tritrace.denoise(*inputs, sampler="sobol"),
                                  tritrace.denoise(*halved, sampler="independent"))


def test_the_result_does_not_depend_on_the_thread_count(capfd):
    scene = tritrace.Scene.builtin("cornell-area")
    f = tritrace.render(scene, aovs=("albedo", "normal", "depth", "variance"), spp=4, **SIZE)
    inputs = (f.image, f.albedo, f.normal, f.depth, f.variance)
    capfd.readouterr()
    one = tritrace.denoise(*inputs, threads=1)
    np.testing.assert_array_equal(one, tritrace.denoise(*inputs, threads=3))
    np.testing.assert_array_equal(one, tritrace.denoise(*inputs))
    # More threads than cores are given (as render() gives them), without TBB's warning.
    np.testing.assert_array_equal(one, tritrace.denoise(*inputs, threads=64))
    assert capfd.readouterr().err == ""


@pytest.mark.parametrize("features", ["all", "none"])
@pytest.mark.parametrize("with_variance", [True, False])
def test_a_constant_image_stays_constant(features, with_variance):
    h, w = 21, 34
    colour = np.broadcast_to(np.float32([0.25, 0.5, 3.0]), (h, w, 3)).copy()
    args = {}
    if features == "all":
        args = dict(albedo=np.full((h, w, 3), 0.7, np.float32),
                    normal=np.broadcast_to(np.float32([0, 0, -1]), (h, w, 3)),
                    depth=np.full((h, w), 2.5, np.float32))
    if with_variance:
        args["variance"] = np.full((h, w, 3), 0.01, np.float32)
    np.testing.assert_array_equal(tritrace.denoise(colour, **args), colour)


def smooth_image(h, w):
    """A smooth function of the pixel position, values in [0.2, 1.8]."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    base = 1.0 + 0.8 * np.sin(2 * np.pi * x / w) * np.cos(np.pi * y / h)
    return np.stack([base, 0.5 * base + 0.3, 1.2 - 0.4 * base * base / 3.24], axis=-1)


def test_noise_on_a_smooth_image_falls_and_less_noise_gives_a_closer_image():
    h, w = 64, 80
    clean = smooth_image(h, w)
    rng = np.random.default_rng(5)
    white = rng.standard_normal((h, w, 3))
    features = dict(albedo=np.full((h, w, 3), 0.5, np.float32),
                    normal=np.broadcast_to(np.float32([0, 0, -1]), (h, w, 3)),
                    depth=np.full((h, w), 3.0, np.float32))
    errors = []
    for sigma in (0.2, 0.1, 0.05):
        noisy = (clean + sigma * white).astype(np.float32)
        variance = np.full((h, w, 3), sigma * sigma, np.float32)
        for v in (variance, None):
            out = tritrace.denoise(noisy, variance=v, **features)
            mse_in = np.mean((noisy - clean) ** 2)
            mse_out = np.mean((out - clean) ** 2)
            # At least halved (a 3 x 3 box filter would divide white noise by 9 but blur the
            # function; the denoiser's window is 15 x 15).
            assert mse_out < 0.5 * mse_in, (sigma, v is None, mse_out, mse_in)
            if v is not None:
                errors.append(mse_out)
    assert errors[0] > errors[1] > errors[2]


def test_a_rendered_image_gets_closer_to_a_converged_one():
    scene = tritrace.Scene.builtin("cornell-area")
    reference = tritrace.render(scene, spp=1024, seed=99, **SIZE).image
    # 4 spp: far noisier than the reference, whose own noise then hardly counts (measured: the
    # denoised image's relative MSE is 0.43 of the noisy one's).
    f = tritrace.render(scene, spp=4, aovs=("albedo", "normal", "depth", "variance"), **SIZE)
    out = tritrace.denoise(f.image, f.albedo, f.normal, f.depth, f.variance)

    def rel_mse(image):
        return np.mean((image - reference) ** 2 / (reference ** 2 + 1e-2))

    assert rel_mse(out) < 0.6 * rel_mse(f.image), (rel_mse(out), rel_mse(f.image))


def test_an_albedo_step_stays_a_step():
    # Left half albedo 0.2, right half 0.8, under the same noisy light (30% per pixel): the albedo
    # feature keeps the halves apart, so neither bleeds into the other.
    h, w = 32, 40
    albedo = np.full((h, w, 3), 0.2, np.float32)
    albedo[:, w // 2:] = 0.8
    rng = np.random.default_rng(8)
    light = 1.0 + 0.3 * rng.standard_normal((h, w, 1))
    colour = (albedo * light).astype(np.float32)
    variance = (albedo * albedo * 0.09).astype(np.float32)
    out = tritrace.denoise(colour, albedo, np.broadcast_to(np.float32([0, 0, -1]), (h, w, 3)),
                           np.full((h, w), 3.0, np.float32), variance)
    left, right = out[:, : w // 2 - 1], out[:, w // 2 + 1:]
    # Each side's mean stays its albedo (times the light's mean, 1) within 5%.
    assert abs(left.mean() / 0.2 - 1) < 0.05 and abs(right.mean() / 0.8 - 1) < 0.05
    # The columns beside the step keep the step: the left column is far below the right one.
    assert out[:, w // 2 - 1].mean() < 0.3 and out[:, w // 2].mean() > 0.6


def test_other_threads_run_while_it_filters():
    # As in test_threads.py: with a long switch interval, the main thread runs while the worker is
    # inside denoise() only if denoise() released the GIL.
    rng = np.random.default_rng(1)
    colour = rng.uniform(0, 1, (400, 600, 3)).astype(np.float32)
    started, done = threading.Event(), threading.Event()

    def work():
        started.set()
        tritrace.denoise(colour)
        tritrace.denoise(colour)
        done.set()

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1000.0)
    try:
        worker = threading.Thread(target=work)
        worker.start()
        started.wait()
        ran_while_filtering = not done.is_set()
        done.wait()
        worker.join()
    finally:
        sys.setswitchinterval(interval)
    assert ran_while_filtering


def test_other_dtypes_are_converted_and_lists_accepted():
    colour = smooth_image(12, 10)  # float64
    np.testing.assert_array_equal(tritrace.denoise(colour),
                                  tritrace.denoise(colour.astype(np.float32)))
    np.testing.assert_array_equal(tritrace.denoise(colour.tolist()),
                                  tritrace.denoise(colour.astype(np.float32)))


H, W = 6, 8
GOOD = dict(color=np.ones((H, W, 3), np.float32), albedo=np.ones((H, W, 3), np.float32),
            normal=np.ones((H, W, 3), np.float32), depth=np.ones((H, W), np.float32),
            variance=np.ones((H, W, 3), np.float32))


def call(**changes):
    args = dict(GOOD, **changes)
    return tritrace.denoise(args.pop("color"), **args)


@pytest.mark.parametrize("name, value, message", [
    ("color", np.ones((H, W), np.float32), "color: must have shape (height, width, 3), got (6, 8)"),
    ("color", np.ones((H, W, 4), np.float32),
     "color: must have shape (height, width, 3), got (6, 8, 4)"),
    ("color", np.ones((0, W, 3), np.float32),
     "color: must have at least one pixel, got shape (0, 8, 3)"),
    ("albedo", np.ones((H, W + 1, 3), np.float32),
     "albedo: must have shape (6, 8, 3) (color's height and width), got (6, 9, 3)"),
    ("normal", np.ones((W, H, 3), np.float32),
     "normal: must have shape (6, 8, 3) (color's height and width), got (8, 6, 3)"),
    ("depth", np.ones((H, W, 3), np.float32),
     "depth: must have shape (6, 8) (color's height and width), got (6, 8, 3)"),
    ("variance", np.ones((H, W), np.float32),
     "variance: must have shape (6, 8, 3) (color's height and width), got (6, 8)"),
])
def test_wrong_shapes_raise_value_errors_naming_the_argument(name, value, message):
    with pytest.raises(ValueError) as e:
        call(**{name: value})
    assert str(e.value) == message


@pytest.mark.parametrize("name", ["color", "albedo", "normal", "depth", "variance"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_values_raise_value_errors_naming_the_argument_and_pixel(name, bad):
    value = GOOD[name].copy()
    value[4, 5] = bad
    with pytest.raises(ValueError) as e:
        call(**{name: value})
    assert str(e.value).startswith(f"{name}: must be finite, got ")
    assert str(e.value).endswith(" at row 4, column 5")


@pytest.mark.parametrize("name", ["color", "albedo", "depth"])
@pytest.mark.parametrize("value", [np.ones((H, W, 3), bool), "image", np.ones((H, W, 3), complex)])
def test_non_numeric_arrays_raise_type_errors_naming_the_argument(name, value):
    if name == "depth" and isinstance(value, np.ndarray):
        value = value[..., 0]
    with pytest.raises(TypeError) as e:
        call(**{name: value})
    assert str(e.value).startswith(f"{name}: ")


def test_bad_options_raise_naming_the_option():
    colour = GOOD["color"]
    for radius in (0, 33, -1):
        with pytest.raises(ValueError, match=r"^search_radius: must be an integer from 1 to 32, "):
            tritrace.denoise(colour, search_radius=radius)
    for radius in (1.5, True, "3"):
        with pytest.raises(TypeError, match=r"^search_radius: must be an int, got "):
            tritrace.denoise(colour, search_radius=radius)
    with pytest.raises(ValueError, match=r"^sampler: must be 'sobol' or 'independent', got 'halton'"):
        tritrace.denoise(colour, sampler="halton")
    with pytest.raises(TypeError, match=r"^sampler: must be a str, got "):
        tritrace.denoise(colour, sampler=None)
    with pytest.raises(ValueError, match=r"^threads: "):
        tritrace.denoise(colour, threads=0)
    with pytest.raises(TypeError, match=r"^threads: "):
        tritrace.denoise(colour, threads="2")
    # search_radius and threads are keyword-only.
    with pytest.raises(TypeError):
        tritrace.denoise(colour, None, None, None, None, 3)
    assert tritrace.denoise(colour, search_radius=np.int64(1)).shape == (H, W, 3)
