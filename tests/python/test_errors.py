# Bad input raises a Python exception, never crashes the interpreter: OSError for files, ValueError
# for bad values and shapes, TypeError for wrong types, with the CLI's messages (the flag's name
# replaced by the keyword's) wherever the CLI has the same setting.
import os
import warnings

import numpy as np
import pytest

import tritrace
from conftest import REPO, cli_error


def message(excinfo):
    return str(excinfo.value)


# --- files ---------------------------------------------------------------------------------------

def test_missing_file_is_file_not_found_with_the_cli_message(tmp_path):
    path = tmp_path / "missing.obj"
    with pytest.raises(FileNotFoundError) as e:
        tritrace.load(path)
    assert message(e) == cli_error("render", path, "-o", tmp_path / "x.pfm")


def test_folder_is_is_a_directory_error(tmp_path):
    with pytest.raises(IsADirectoryError) as e:
        tritrace.load(str(tmp_path))
    assert message(e) == cli_error("render", tmp_path, "-o", tmp_path / "x.pfm")


@pytest.mark.parametrize("name, content", [
    ("empty.obj", b""),
    ("broken.json", b'{"meshes": [{"generator": "cornell"}], "camera": {"lookat": [0, 0, 0]}}'),
    ("garbage.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 99\nend_header\n\x01"),
    ("bad_mesh_ref.json", b'{"meshes": [{"file": "nowhere.obj"}]}'),
])
def test_bad_files_are_os_errors_with_the_cli_message(tmp_path, name, content):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(OSError) as e:
        tritrace.load(path)
    assert message(e) == cli_error("render", path, "-o", tmp_path / "x.pfm")


def test_path_must_be_a_path():
    with pytest.raises(TypeError):
        tritrace.load(3)
    scene = tritrace.load(os.fsencode(REPO / "scenes" / "cornell.json"))  # bytes are a path too
    assert scene.triangle_count == 30


# --- scenes --------------------------------------------------------------------------------------

def test_unknown_builtin_scene_has_the_cli_reason(tmp_path):
    with pytest.raises(ValueError) as e:
        tritrace.Scene.builtin("dodecahedron")
    cli = cli_error("render", "--scene", "dodecahedron", "-o", tmp_path / "x.pfm")
    assert message(e) == "name" + cli[len("--scene"):]
    with pytest.raises(TypeError):
        tritrace.Scene.builtin(None)
    with pytest.raises(TypeError):
        tritrace.Scene()


def test_from_arrays_checks_shapes_types_and_indices():
    v = np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    f = np.int32([[0, 1, 2]])
    with pytest.raises(ValueError, match=r"vertices: must have shape \(N, 3\), got \(3, 2\)"):
        tritrace.Scene.from_arrays(v[:, :2], f)
    with pytest.raises(ValueError, match=r"triangles: must have shape \(M, 3\)"):
        tritrace.Scene.from_arrays(v, [0, 1, 2])
    with pytest.raises(TypeError, match="triangles: must be an array of integers, got dtype float"):
        tritrace.Scene.from_arrays(v, f.astype(np.float32))
    with pytest.raises(TypeError, match="vertices: must be an array of numbers, got dtype <U1"):
        tritrace.Scene.from_arrays([["a", "b", "c"]], f)
    with pytest.raises(ValueError, match="refers to vertex 3, but there are 3 vertices"):
        tritrace.Scene.from_arrays(v, [[0, 1, 3]])
    with pytest.raises(ValueError, match="refers to vertex -1"):
        tritrace.Scene.from_arrays(v, [[0, 1, -1]])
    with pytest.raises(ValueError, match="no triangles given"):
        tritrace.Scene.from_arrays(v, np.zeros((0, 3), np.int32))
    with pytest.raises(ValueError, match=r"materials: the albedo must be in \[0, 1\]"):
        tritrace.Scene.from_arrays(v, f, materials=[1.5, 0, 0])
    with pytest.raises(ValueError, match="materials: must be one albedo"):
        tritrace.Scene.from_arrays(v, f, materials=[[1, 0, 0], [0, 1, 0]])
    with pytest.raises(ValueError, match=r"materials: the albedo of triangle 1 must be in \[0, 1\], "
                                         r"got \(nan, 0, 0\)"):
        tritrace.Scene.from_arrays(v, [[0, 1, 2], [0, 2, 1]], materials=[[0, 0, 0], [np.nan, 0, 0]])


def test_from_arrays_drops_degenerate_and_non_finite_triangles_but_keeps_indices():
    v = np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [np.nan, 0, 0], [0, 0, 1]])
    # Triangle 0 is degenerate (collinear), 1 has a NaN vertex, 2 is the one to hit.
    f = np.int64([[0, 1, 3], [0, 4, 2], [0, 1, 2]])
    with pytest.warns(RuntimeWarning, match="dropped 1 degenerate and 1 non-finite triangles"):
        scene = tritrace.Scene.from_arrays(v, f)
    assert scene.triangle_count == 1
    assert (scene.dropped_degenerate, scene.dropped_non_finite) == (1, 1)
    hits = tritrace.Accel(scene).intersect([0.25, 0.5, -1], [0, 0, 1])
    assert hits.prim == 2 and hits.t == 1.0
    # The weights of triangle 2's second and third vertices, (1,0,0) and (0,1,0), and its
    # counter-clockwise normal cross(v1 - v0, v2 - v0).
    assert (hits.u, hits.v) == (0.25, 0.5)
    np.testing.assert_array_equal(hits.normal, [0, 0, 1])
    with pytest.raises(ValueError, match="no geometry: every triangle was degenerate"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tritrace.Scene.from_arrays(v, f[:2])


# --- accels --------------------------------------------------------------------------------------

def test_accel_names_are_checked_as_the_cli_checks_them(cornell, tmp_path):
    with pytest.raises(ValueError) as e:
        tritrace.Accel(cornell, "octree")
    cli = cli_error("render", "--accel", "octree", "-o", tmp_path / "x.pfm")
    assert message(e) == "kind" + cli[len("--accel"):]
    with pytest.raises(ValueError) as e:
        tritrace.Accel(cornell, kernel="fast")
    assert message(e) == "kernel" + cli_error("render", "--kernel", "fast", "-o",
                                              tmp_path / "x.pfm")[len("--kernel"):]
    with pytest.raises(TypeError, match="kind: must be a str, got int"):
        tritrace.Accel(cornell, 3)
    with pytest.raises(TypeError):
        tritrace.Accel("cornell")


@pytest.fixture(scope="module")
def accel(cornell):
    return tritrace.Accel(cornell)


ORIGINS = np.zeros((4, 3), np.float32)
DIRECTIONS = np.float32([[0, 0, 1], [0, 1, 0], [1, 0, 0], [0, 0, -1]])


@pytest.mark.parametrize("bad, pattern", [
    (np.zeros((4, 3), np.complex64), "origins: must be an array of numbers, got dtype complex64"),
    (np.zeros((4, 3), bool), "origins: must be an array of numbers, got dtype bool"),
    (np.full((4, 3), "x"), "origins: must be an array of numbers, got dtype <U1"),
    (np.array([[None] * 3] * 4), "origins: must be an array of numbers, got dtype object"),
    (None, "origins: must be an array of numbers, got dtype object"),
])
def test_wrong_dtypes_are_type_errors(accel, bad, pattern):
    with pytest.raises(TypeError, match=pattern):
        accel.intersect(bad, DIRECTIONS)
    with pytest.raises(TypeError, match=pattern):
        accel.occluded(bad, DIRECTIONS)


@pytest.mark.parametrize("origins, directions, pattern", [
    (np.zeros((4, 2)), DIRECTIONS, r"origins: must have shape \(\.\.\., 3\), got \(4, 2\)"),
    (ORIGINS, np.zeros(4), r"directions: must have shape \(\.\.\., 3\), got \(4,\)"),
    (ORIGINS, np.zeros(()), r"directions: must have shape \(\.\.\., 3\), got \(\)"),
    (ORIGINS, DIRECTIONS[:3], r"shapes \(4, 3\) and \(3, 3\) do not match"),
    (np.zeros((2, 2, 3)), np.zeros((4, 3)), r"shapes \(2, 2, 3\) and \(4, 3\) do not match"),
    ([[0, 0], [0, 0, 0]], DIRECTIONS, ""),  # ragged: NumPy's own ValueError
])
def test_bad_shapes_are_value_errors(accel, origins, directions, pattern):
    with pytest.raises(ValueError, match=pattern):
        accel.intersect(origins, directions)


@pytest.mark.parametrize("row, column, value, pattern", [
    (2, 1, np.nan, r"origins: ray 2 is not finite: \(0, nan, 0\)"),
    (3, 0, np.inf, r"origins: ray 3 is not finite"),
])
def test_non_finite_origins_are_value_errors_naming_the_first_ray(accel, row, column, value,
                                                                   pattern):
    origins = ORIGINS.copy()
    origins[row, column] = value
    origins[min(row + 1, 3), column] = value  # a later bad ray is not the one named
    with pytest.raises(ValueError, match=pattern):
        accel.intersect(origins, DIRECTIONS)
    with pytest.raises(ValueError, match=pattern):
        accel.occluded(origins, DIRECTIONS)


def test_bad_directions_and_intervals_are_value_errors(accel):
    directions = DIRECTIONS.copy()
    directions[1] = 0
    with pytest.raises(ValueError, match="directions: ray 1 is zero"):
        accel.intersect(ORIGINS, directions)
    directions[1] = [np.nan, 0, 1]
    with pytest.raises(ValueError, match=r"directions: ray 1 is not finite: \(nan, 0, 1\)"):
        accel.occluded(ORIGINS, directions)
    with pytest.raises(ValueError, match="directions: ray 0 is zero"):
        accel.intersect([0, 0, 0], [0, 0, 0])
    with pytest.raises(ValueError, match="tmin: must be a number >= 0, got -1"):
        accel.intersect(ORIGINS, DIRECTIONS, tmin=-1)
    with pytest.raises(ValueError, match="tmin: must be a number >= 0, got nan"):
        accel.intersect(ORIGINS, DIRECTIONS, tmin=np.nan)
    with pytest.raises(ValueError, match="tmax: must not be NaN"):
        accel.occluded(ORIGINS, DIRECTIONS, 0.0, np.float32(np.nan))
    with pytest.raises(ValueError, match="tmin: ray 2 must be a number >= 0, got -0.5"):
        accel.intersect(ORIGINS, DIRECTIONS, tmin=[0, 0, -0.5, 0])
    with pytest.raises(ValueError, match="tmax: ray 3 is NaN"):
        accel.intersect(ORIGINS, DIRECTIONS, tmax=[1, 1, 1, np.nan])
    with pytest.raises(ValueError, match=r"tmax: must be a number or an array of the rays' shape "
                                         r"\(4,\), got \(3,\)"):
        accel.intersect(ORIGINS, DIRECTIONS, tmax=[1, 1, 1])
    with pytest.raises(TypeError, match="tmin: must be a number, got NoneType"):
        accel.intersect(ORIGINS, DIRECTIONS, tmin=None)
    with pytest.raises(TypeError, match="tmax: must be a number, got str"):
        accel.intersect(ORIGINS, DIRECTIONS, tmax="far")
    with pytest.raises(TypeError, match="coherent: must be True, False or None, got int"):
        accel.intersect(ORIGINS, DIRECTIONS, coherent=1)


def test_rays_far_outside_float_range_or_tiny_are_traced_without_trouble(accel):
    # Finite but extreme rays: traced (they miss or hit), never an error or a crash.
    origins = np.float32([[0, 0, 0], [0, 0, 0], [3e38, 0, 0], [0, 0, -1e30], [0, 0, 0]])
    directions = np.float32([[1e-38, 0, 1e-45], [3e38, 3e38, 3e38], [-1, 0, 0], [0, 0, 1],
                             [1e-30, 1e-30, 1e-30]])
    hits = accel.intersect(origins, directions)
    assert hits.t.shape == (5,)
    assert hits.prim[1] >= 0  # a huge direction still hits a wall, at a tiny t


# --- renders -------------------------------------------------------------------------------------

@pytest.mark.parametrize("keyword, value, flag, text", [
    ("spp", 0, "--spp", "0"),
    ("width", 0, "--width", "0"),
    ("height", 20000, "--height", "20000"),
    ("seed", -1, "--seed", "-1"),
    ("seed", 2 ** 64, "--seed", str(2 ** 64)),
    ("max_depth", 70000, "--max-depth", "70000"),
    ("threads", 0, "--threads", "0"),
    ("integrator", "whitted", "--integrator", "whitted"),
    ("sampler", "halton", "--sampler", "halton"),
    ("filter", "mitchell", "--filter", "mitchell"),
    ("yaw", float("nan"), "--yaw", "nan"),
    ("distance", 0.0, "--distance", "0"),
    ("distance", -2, "--distance", "-2"),
    ("light", (1, 2), "--light", "1,2"),
    ("light", (1, float("inf"), 2), "--light", "1,inf,2"),
    ("accel", "kd-tree", "--accel", "kd-tree"),
    ("kernel", "plucker", "--kernel", "plucker"),
])
def test_render_values_fail_with_the_cli_message(cornell, tmp_path, keyword, value, flag, text):
    with pytest.raises(ValueError) as e:
        tritrace.render(cornell, **{"width": 8, "height": 8, keyword: value})
    cli = cli_error("render", f"{flag}={text}", "-o", tmp_path / "x.pfm")
    assert message(e) == keyword + cli[len(flag):]


@pytest.mark.parametrize("keyword, value", [
    ("spp", 4.0), ("spp", "4"), ("spp", True), ("width", 1.5), ("seed", 1.0),
    ("integrator", 1), ("yaw", "0.5"), ("yaw", True), ("light", "1,2,3"), ("light", 5),
    ("light", [[1, 2, 3]]), ("aovs", "depth"), ("aovs", 3), ("aovs", [1]), ("accel", 2),
    ("position", ["a", "b", "c"]), ("vertical_fov", "wide"),
])
def test_render_wrong_types_are_type_errors(cornell, keyword, value):
    with pytest.raises(TypeError, match=keyword):
        tritrace.render(cornell, **{"width": 8, "height": 8, keyword: value})


def test_render_camera_and_aov_values_are_checked(cornell):
    def fails(pattern, **kwargs):
        with pytest.raises(ValueError, match=pattern):
            tritrace.render(cornell, width=8, height=8, **kwargs)

    fails("aovs: unknown AOV 'motion'", aovs=("depth", "motion"))
    fails("position: position and look_at must differ", position=(0, 0, 0))
    fails("up: position and look_at must differ, and up must not be parallel", up=(0, 0, 1))
    fails(r"vertical_fov: must be between 0 and 180 degrees \(exclusive\), got 180",
          vertical_fov=180)
    fails("focal_length: must be positive, got -5", focal_length=-5)
    fails("vertical_fov: give either vertical_fov or focal_length, not both", vertical_fov=40,
          focal_length=100)
    fails("position: must be three finite numbers X,Y,Z, got 'nan,0,0'",
          position=(np.nan, 0, 0))
    fails("look_at: must be three finite numbers X,Y,Z, got '1,2,3,4'", look_at=(1, 2, 3, 4))
    other = tritrace.Accel(tritrace.Scene.builtin("cornell"))
    fails("accel: was built for another scene", accel=other)
    fails("kernel: give it to tritrace.Accel", accel=tritrace.Accel(cornell), kernel="cramer")
