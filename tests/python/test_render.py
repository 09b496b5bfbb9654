# tritrace.render against the CLI: the same settings give the image `tritrace render` writes to a
# PFM file bit for bit (and its EXR AOVs), for the lab integrator and the path tracer, built-in
# scenes, scene files, cameras given as keyword arguments, and scenes built from arrays.
import json
import struct

import numpy as np
import pytest

import tritrace
from conftest import REPO, read_exr, read_pfm, run_cli


def cli_image(tmp_path, *args):
    out = tmp_path / "cli.pfm"
    run_cli("render", *args, "-q", "-o", out)
    return read_pfm(out)


def assert_same_bits(a, b):
    assert a.dtype == b.dtype == np.float32 and a.shape == b.shape
    np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))


def test_lab_image_is_the_clis(tmp_path, cornell):
    frame = tritrace.render(cornell, width=120, height=90, yaw=0.4)
    assert frame.image.shape == (90, 120, 3) and frame.integrator == "lab" and frame.spp == 1
    assert_same_bits(frame.image, cli_image(tmp_path, "--width", 120, "--height", 90, "--yaw",
                                            0.4))
    # The default view and size: the lab's 500 x 500 image.
    assert_same_bits(tritrace.render(cornell).image, cli_image(tmp_path))


@pytest.mark.parametrize("kwargs, flags", [
    ({"seed": 5}, ["--seed", 5]),
    ({"sampler": "independent", "filter": "gaussian", "max_depth": 3, "seed": 11},
     ["--sampler", "independent", "--filter", "gaussian", "--max-depth", 3, "--seed", 11]),
    ({"distance": 2.5, "light": (0.2, -0.6, -0.4), "threads": 1},
     ["--distance", 2.5, "--light", "0.2,-0.6,-0.4", "--threads", 1]),
])
def test_path_traced_image_is_the_clis(tmp_path, kwargs, flags):
    scene = tritrace.Scene.builtin("cornell-area")
    frame = tritrace.render(scene, width=40, height=32, spp=4, **kwargs)
    assert frame.integrator == "path" and frame.spp == 4
    assert_same_bits(frame.image, cli_image(tmp_path, "--scene", "cornell-area", "--width", 40,
                                            "--height", 32, "--spp", 4, *flags))


def test_a_time_limited_render_is_the_image_of_the_spp_it_reached(tmp_path):
    # A limit that is over at once still renders the first pass of 8 samples; one that never ends
    # stops at spp. Neither depends on the clock.
    scene = tritrace.Scene.builtin("cornell-area")
    quick = tritrace.render(scene, width=24, height=16, time_limit=1e-9)
    assert quick.spp == 8
    capped = tritrace.render(scene, width=24, height=16, spp=12, time_limit=1e6)
    assert capped.spp == 12
    assert_same_bits(capped.image, cli_image(tmp_path, "--scene", "cornell-area", "--width", 24,
                                             "--height", 16, "--spp", 12))
    with pytest.raises(ValueError, match="time_limit: must be a number of seconds"):
        tritrace.render(scene, time_limit=0)
    with pytest.raises(ValueError, match="time_limit: applies to the path tracer"):
        tritrace.render(tritrace.Scene.builtin("cornell"), time_limit=1)


def test_a_denoised_render_is_the_clis(tmp_path):
    scene = tritrace.Scene.builtin("cornell-area")
    frame = tritrace.render(scene, width=40, height=32, spp=8, denoise=True)
    assert_same_bits(frame.image, cli_image(tmp_path, "--scene", "cornell-area", "--width", 40,
                                            "--height", 32, "--spp", 8, "--denoise"))
    noisy = tritrace.render(scene, width=40, height=32, spp=8)
    assert not np.array_equal(frame.image, noisy.image)
    with pytest.raises(TypeError, match="denoise: must be a bool"):
        tritrace.render(scene, denoise=1)
    with pytest.raises(ValueError, match="denoise: applies to the path tracer"):
        tritrace.render(tritrace.Scene.builtin("cornell"), denoise=True)


def test_a_clamped_render_is_the_clis(tmp_path):
    scene = tritrace.load(REPO / "scenes" / "glass.json")
    frame = tritrace.render(scene, width=32, height=24, spp=8, clamp=1.0)
    assert_same_bits(frame.image, cli_image(tmp_path, REPO / "scenes" / "glass.json", "--width",
                                            32, "--height", 24, "--spp", 8, "--clamp", 1))
    with pytest.raises(ValueError, match="clamp: "):
        tritrace.render(scene, clamp=-1)


def test_integrator_and_kernel_choices_are_the_clis(tmp_path, cornell):
    frame = tritrace.render(cornell, integrator="path", spp=2, width=32, height=24,
                            kernel="moller-trumbore", accel="bvh-single")
    assert_same_bits(frame.image, cli_image(tmp_path, "--integrator", "path", "--spp", 2,
                                            "--width", 32, "--height", 24, "--kernel",
                                            "moller-trumbore", "--accel", "bvh-single"))


def test_bdpt_is_the_clis(tmp_path, cornell):
    frame = tritrace.render(cornell, integrator="bdpt", spp=2, width=32, height=24)
    assert frame.integrator == "bdpt"
    assert_same_bits(frame.image, cli_image(tmp_path, "--integrator", "bdpt", "--spp", 2,
                                            "--width", 32, "--height", 24))
    with pytest.raises(ValueError, match="clamp: "):
        tritrace.render(cornell, integrator="bdpt", spp=2, clamp=1.0)


def test_bdpt_light_paths_is_the_clis(tmp_path, cornell):
    frame = tritrace.render(cornell, integrator="bdpt", spp=4, width=32, height=24,
                            light_paths=0.25)
    assert_same_bits(frame.image, cli_image(tmp_path, "--integrator", "bdpt", "--spp", 4,
                                            "--width", 32, "--height", 24, "--light-paths", 0.25))
    with pytest.raises(ValueError, match="light_paths: "):
        tritrace.render(cornell, integrator="bdpt", spp=2, light_paths=1.5)
    with pytest.raises(ValueError, match="light_paths: "):
        tritrace.render(cornell, integrator="path", spp=2, light_paths=0.5)


def test_bdpt_light_paths_auto_is_the_clis(tmp_path, cornell):
    frame = tritrace.render(cornell, integrator="bdpt", spp=4, width=32, height=24,
                            light_paths="auto")
    assert frame.light_paths in [2.0 ** -k for k in range(7)]  # 1, 1/2, ..., 1/64
    assert_same_bits(frame.image, cli_image(tmp_path, "--integrator", "bdpt", "--spp", 4,
                                            "--width", 32, "--height", 24, "--light-paths", "auto"))
    # auto's image is the chosen share's.
    fixed = tritrace.render(cornell, integrator="bdpt", spp=4, width=32, height=24,
                            light_paths=frame.light_paths)
    assert_same_bits(frame.image, fixed.image)
    with pytest.raises(ValueError, match="light_paths: must be auto"):
        tritrace.render(cornell, integrator="bdpt", spp=2, light_paths="half")
    assert tritrace.render(cornell, integrator="path", spp=1, width=8, height=8).light_paths == 0.0


def test_aovs_are_the_clis_exr_layers(tmp_path):
    scene = tritrace.Scene.builtin("cornell-area")
    frame = tritrace.render(scene, width=36, height=28, spp=3, aovs=("albedo", "normal", "depth"))
    out = tmp_path / "cli.exr"
    run_cli("render", "--scene", "cornell-area", "--width", 36, "--height", 28, "--spp", 3,
            "--aovs", "albedo,normal,depth", "-q", "-o", out)
    exr = read_exr(out)

    def layer(*names):
        return np.stack([exr[n] for n in names], axis=-1)

    assert_same_bits(frame.image, layer("R", "G", "B"))
    assert_same_bits(frame.albedo, layer("albedo.R", "albedo.G", "albedo.B"))
    assert_same_bits(frame.normal, layer("normal.X", "normal.Y", "normal.Z"))
    assert_same_bits(frame.depth, exr["Z"])
    # With AOVs the image comes from a film, without them from render(): the same bits.
    assert_same_bits(frame.image, tritrace.render(scene, width=36, height=28, spp=3).image)
    only_depth = tritrace.render(scene, width=36, height=28, spp=3, aovs=["depth"])
    assert only_depth.albedo is None and only_depth.normal is None
    assert_same_bits(only_depth.depth, frame.depth)


def test_camera_keywords_are_a_scene_files_camera(tmp_path):
    scene_json = {"meshes": [{"generator": "cornell"}],
                  "lights": [{"position": [0, -0.5, -0.7], "power": [14, 14, 14]}],
                  "integrator": {"type": "path", "spp": 2}}
    base = tmp_path / "base.json"
    base.write_text(json.dumps(scene_json))
    camera = {"position": [0.5, -0.4, -2.5], "look_at": [0.1, 0.2, 0.3], "up": [0, -1, 0.1],
              "vertical_fov": 50, "width": 48, "height": 36}
    posed = tmp_path / "posed.json"
    posed.write_text(json.dumps(dict(scene_json, camera=camera)))
    scene = tritrace.load(base)
    frame = tritrace.render(scene, position=camera["position"], look_at=camera["look_at"],
                            up=camera["up"], vertical_fov=camera["vertical_fov"], width=48,
                            height=36)
    assert_same_bits(frame.image, cli_image(tmp_path, posed))
    # ... and yaw and distance then orbit it, as the flags orbit the file's camera.
    frame = tritrace.render(scene, position=camera["position"], look_at=camera["look_at"],
                            up=camera["up"], vertical_fov=camera["vertical_fov"], width=48,
                            height=36, yaw=-0.3, distance=2.0)
    assert_same_bits(frame.image, cli_image(tmp_path, posed, "--yaw", -0.3, "--distance", 2))
    # The scene keeps its own camera between renders.
    assert scene.camera["position"] == (0.0, 0.0, -3.0)


def test_lens_keywords_are_the_lens_flags(tmp_path):
    # aperture and focus render what --aperture and --focus render, bit for bit, and the lab
    # integrator refuses a lens as the CLI does.
    scene = tritrace.load(REPO / "scenes" / "tetrahedron_in_box.json")
    frame = tritrace.render(scene, integrator="path", width=40, height=30, spp=2, aperture=0.05,
                            focus=2.5)
    assert_same_bits(frame.image, cli_image(tmp_path, REPO / "scenes" / "tetrahedron_in_box.json",
                                            "--integrator", "path", "--width", 40, "--height", 30,
                                            "--spp", 2, "--aperture", 0.05, "--focus", 2.5))
    assert scene.camera["aperture_radius"] == 0.0 and scene.camera["focus_distance"] is None
    assert not scene.camera["orthographic"]
    pinhole = tritrace.render(scene, integrator="path", width=40, height=30, spp=2)
    assert not np.array_equal(frame.image, pinhole.image)
    with pytest.raises(ValueError, match="^aperture: applies to the path tracer"):
        tritrace.render(scene, width=8, height=8, integrator="lab", aperture=0.05)
    with pytest.raises(ValueError, match="^aperture: must be a lens radius"):
        tritrace.render(scene, integrator="path", width=8, height=8, aperture=-1)


def test_scene_files_render_as_the_cli_renders_them(tmp_path):
    path = REPO / "scenes" / "tetrahedron_in_box.json"
    scene = tritrace.load(path)
    frame = tritrace.render(scene, width=50, height=40, spp=2)
    assert_same_bits(frame.image, cli_image(tmp_path, path, "--width", 50, "--height", 40,
                                            "--spp", 2))


def write_binary_ply(path, vertices, triangles):
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(vertices)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              f"element face {len(triangles)}\nproperty list uchar int vertex_indices\n"
              "end_header\n").encode()
    body = np.asarray(vertices, "<f4").tobytes()
    for t in triangles:
        body += struct.pack("<B3i", 3, *t)
    path.write_bytes(header + body)


def test_from_arrays_is_the_scene_a_mesh_file_gives(tmp_path):
    # A small terrain-like mesh: a 5 x 4 grid with varying heights, float32 values written as
    # binary PLY so that the file holds exactly the same floats.
    xs, zs = np.meshgrid(np.linspace(-1, 1, 5), np.linspace(-1, 1, 4))
    heights = 0.3 * np.sin(3 * xs) * np.cos(2 * zs)
    # + 0 turns the grid's -0.0 heights into +0.0, which is what assimp reads them as (and a hit
    # point's zero's sign steers the ray offsets' ULP steps).
    vertices = np.stack([xs, heights, zs], axis=-1).reshape(-1, 3).astype(np.float32) + 0.0
    triangles = []
    for r in range(3):
        for c in range(4):
            i = r * 5 + c
            triangles += [(i, i + 5, i + 1), (i + 1, i + 5, i + 6)]
    triangles = np.array(triangles, np.int32)
    ply = tmp_path / "grid.ply"
    write_binary_ply(ply, vertices, triangles)
    # assimp gives a file without materials its default material, white.
    scene = tritrace.Scene.from_arrays(vertices, triangles, materials=(1, 1, 1))
    assert scene.triangle_count == 24 and scene.integrator == "path"
    assert scene.camera == tritrace.load(ply).camera
    frame = tritrace.render(scene, width=40, height=30, spp=2)
    assert_same_bits(frame.image, cli_image(tmp_path, ply, "--width", 40, "--height", 30,
                                            "--spp", 2))
    # The same triangles, hit alike: from_arrays reports u and v in the order given.
    origin, directions = scene.camera_rays(width=40, height=30)
    ours = tritrace.Accel(scene).intersect(origin, directions)
    loaded = tritrace.Accel(tritrace.load(ply)).intersect(origin, directions)
    np.testing.assert_array_equal(ours.prim, loaded.prim)
    np.testing.assert_array_equal(ours.t, loaded.t)
    np.testing.assert_array_equal(ours.normal, loaded.normal)
    np.testing.assert_array_equal(ours.u, loaded.v)  # the file's triangles are stored (a, c, b)


def test_a_prebuilt_accel_renders_the_same_image(cornell):
    accel = tritrace.Accel(cornell)
    views = [tritrace.render(cornell, width=40, height=30, yaw=y, accel=accel).image
             for y in (0.0, 0.5)]
    for y, image in zip((0.0, 0.5), views):
        assert_same_bits(image, tritrace.render(cornell, width=40, height=30, yaw=y).image)
    assert not np.array_equal(views[0], views[1])


def test_from_arrays_materials_colour_the_triangles():
    v = np.float32([[-1, -1, 0], [1, -1, 0], [0, 1, 0], [-1, -1, 1], [1, -1, 1], [0, 1, 1]])
    f = np.int32([[0, 1, 2], [3, 4, 5]])
    albedo = np.float32([[0.9, 0.1, 0.1], [0.1, 0.9, 0.1]])
    scene = tritrace.Scene.from_arrays(v, f, materials=albedo)
    frame = tritrace.render(scene, width=16, height=16, spp=1, aovs=("albedo",),
                            position=(0, 0, -4), look_at=(0, 0, 0), up=(0, 1, 0))
    centre = frame.albedo[8, 8]
    np.testing.assert_array_equal(centre, albedo[0])  # the front triangle, seen first
    grey = tritrace.render(tritrace.Scene.from_arrays(v, f), width=16, height=16, spp=1,
                           aovs=("albedo",), position=(0, 0, -4), look_at=(0, 0, 0),
                           up=(0, 1, 0)).albedo[8, 8]
    np.testing.assert_array_equal(grey, np.float32([0.6, 0.6, 0.6]))


def test_instances_are_copied_out_into_one_mesh():
    # scenes/instances.json: the 30-triangle box once and a 4-triangle tetrahedron placed five
    # times; the module copies the instances out (in the CLI's triangle numbering), drops none.
    scene = tritrace.load(REPO / "scenes" / "instances.json")
    assert scene.triangle_count == 30 + 5 * 4
    frame = tritrace.render(scene, width=32, height=24)
    assert frame.image.shape == (24, 32, 3) and frame.image.max() > 0


def test_noise_threshold_renders_the_clis_adaptive_image(tmp_path):
    scene = tritrace.Scene.builtin("cornell-area")
    # Every pixel takes a pilot of 64 samples, so 128 leaves room for the neighbours to decide.
    frame = tritrace.render(scene, width=24, height=16, spp=128, noise_threshold=0.05,
                            aovs=("spp",))
    assert frame.spp == 128 and frame.mean_spp < 128
    assert frame.spp_map.shape == (16, 24)
    # Whole counts, stored as float32: summed in float64 the mean is exact to rounding.
    assert abs(float(frame.spp_map.astype(np.float64).mean()) - frame.mean_spp) < 1e-9
    assert_same_bits(frame.image, cli_image(tmp_path, "--scene", "cornell-area", "--width", 24,
                                            "--height", 16, "--spp", 128,
                                            "--noise-threshold", 0.05))
    with pytest.raises(ValueError, match="noise_threshold: must be a relative error"):
        tritrace.render(scene, noise_threshold=1.5)


def test_bdpt_noise_threshold_renders_the_clis_adaptive_image(tmp_path):
    # bdpt's light tracing is rendered pass by pass with adaptive sampling (docs/BDPT.md): the
    # module's image is the CLI's bit for bit, and the spp map shows pixels that went past the
    # pilot of 64 beside pixels that stopped there.
    scene = tritrace.Scene.builtin("cornell-area")
    frame = tritrace.render(scene, integrator="bdpt", width=24, height=16, spp=128,
                            noise_threshold=0.1, aovs=("spp",))
    assert frame.integrator == "bdpt" and frame.spp == 128
    assert frame.spp_map.min() == 64 and frame.spp_map.max() == 128
    assert_same_bits(frame.image, cli_image(tmp_path, "--scene", "cornell-area", "--integrator",
                                            "bdpt", "--width", 24, "--height", 16, "--spp", 128,
                                            "--noise-threshold", 0.1))


def test_a_gltfs_spot_and_directional_lights_are_listed_and_render_as_the_clis(tmp_path):
    # tests/data/gltf/plane_lights.gltf: 1366 cd and 683 lux, converted at 683 lm/W (Blender's
    # glTF importer's default) to 2 W/sr and 1 W/m^2 (times the sun's colour (1, 0.5, 0.25)).
    path = REPO / "tests" / "data" / "gltf" / "plane_lights.gltf"
    scene = tritrace.load(str(path))
    [spot] = scene.spot_lights
    assert spot["intensity"] == pytest.approx((2.0, 2.0, 2.0))
    assert spot["outer_angle"] == pytest.approx(0.6 * 180 / np.pi, rel=1e-6)
    assert spot["falloff"] == "gltf"
    [sun] = scene.directional_lights
    assert sun["irradiance"] == pytest.approx((1.0, 0.5, 0.25))
    assert sun["direction"] == pytest.approx((0.0, -1.0, 0.0), abs=1e-6)
    frame = tritrace.render(scene, width=24, height=16, spp=4)
    assert frame.image.max() > 0
    assert_same_bits(frame.image, cli_image(tmp_path, path, "--width", 24, "--height", 16, "--spp", 4))
