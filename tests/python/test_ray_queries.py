# Accel.intersect and Accel.occluded: hits on the lab box computed by hand, an independent
# double-precision ray/triangle test on many rays, every accel giving the same hits bit for bit,
# the CLI's depth, normal and albedo images of the same camera rays, broadcasting and shapes, and
# result memory reused once released.
import numpy as np
import pytest

import tritrace
from conftest import lab_box_triangles, read_exr, run_cli

INF = np.float32(np.inf)

# (origin, direction, t, triangle, u, v, normal): each worked out from the fact sheet's corners
# (conftest.lab_box_triangles), with the origins high in the room (y = -0.5, above both blocks)
# or beside the blocks so that nothing else is in the way.
HAND_HITS = [
    # Back wall (z = 1), triangle 9 = G(-1,-1,1), H(1,-1,1), D(1,1,1): e1 = (2,0,0),
    # e2 = (2,2,0); the point (0,-0.5,1) = G + 0.25 e1 + 0.25 e2; normal cross(e2, e1) ~ (0,0,-1).
    ((0, -0.5, 0), (0, 0, 1), 1.0, 9, 0.25, 0.25, (0, 0, -1)),
    # The same with a direction of length 2: t halves, the hit is the same.
    ((0, -0.5, 0), (0, 0, 2), 0.5, 9, 0.25, 0.25, (0, 0, -1)),
    # Ceiling (y = -1), triangle 6 = E(-1,-1,-1), F(1,-1,-1), G(-1,-1,1): e1 = (2,0,0),
    # e2 = (0,0,2); (-0.5,-1,0) = E + 0.25 e1 + 0.5 e2; normal cross(e2, e1) ~ (0,1,0).
    ((-0.5, -0.5, 0), (0, -1, 0), 0.5, 6, 0.25, 0.5, (0, 1, 0)),
    # Floor (y = 1), triangle 0 = C(-1,1,1), B(1,1,-1), A(-1,1,-1): e1 = (2,0,-2), e2 = (0,0,-2);
    # (-0.5,1,-0.9) = C + 0.25 e1 + 0.7 e2 (x = -0.5 and z = -0.9 are clear of both blocks);
    # normal cross(e2, e1) ~ (0,-1,0).
    ((-0.5, -0.5, -0.9), (0, 1, 0), 1.5, 0, 0.25, 0.7, (0, -1, 0)),
    # Left (purple) wall x = -1, triangle 3 = C(-1,1,1), E(-1,-1,-1), G(-1,-1,1): e1 = (0,-2,-2),
    # e2 = (0,-2,0); (-1,-0.5,0.5) = C + 0.25 e1 + 0.5 e2; normal cross(e2, e1) ~ (1,0,0).
    ((0.5, -0.5, 0.5), (-1, 0, 0), 1.5, 3, 0.25, 0.5, (1, 0, 0)),
]


@pytest.fixture(scope="module")
def accel(cornell):
    return tritrace.Accel(cornell)


@pytest.mark.parametrize("origin, direction, t, prim, u, v, normal", HAND_HITS)
def test_hand_computed_hits_on_the_lab_box(accel, origin, direction, t, prim, u, v, normal):
    hits = accel.intersect(np.array([origin], np.float32), np.array([direction], np.float32))
    assert hits.prim[0] == prim
    assert hits.t[0] == pytest.approx(t, rel=1e-6)
    assert hits.u[0] == pytest.approx(u, abs=1e-6)
    assert hits.v[0] == pytest.approx(v, abs=1e-6)
    np.testing.assert_allclose(hits.normal[0], normal, atol=1e-6)
    assert hits.hit[0]


def test_ray_out_of_the_open_side_misses(accel):
    hits = accel.intersect([0, -0.5, 0], [0, 0, -1])
    assert hits.prim == -1 and hits.t == INF and hits.u == 0 and hits.v == 0
    assert not hits.hit
    np.testing.assert_array_equal(hits.normal, [0, 0, 0])
    assert not accel.occluded([0, -0.5, 0], [0, 0, -1])


def test_interval_bounds_are_inclusive_and_respected(accel):
    o, d = [0, -0.5, 0], [0, 0, 1]  # the back wall at t = 1 exactly
    assert accel.intersect(o, d, tmax=1.0).prim == 9
    assert accel.intersect(o, d, tmax=np.nextafter(np.float32(1), np.float32(0))).prim == -1
    assert accel.intersect(o, d, tmin=1.0).prim == 9
    assert accel.intersect(o, d, tmin=1.5).prim == -1
    assert accel.occluded(o, d, 0.0, 1.0)
    assert not accel.occluded(o, d, 0.0, 0.999)
    # Per-ray intervals.
    origins = np.tile(np.float32(o), (3, 1))
    hits = accel.intersect(origins, d, tmin=[0, 0, 1.5], tmax=[2, 0.5, 3])
    np.testing.assert_array_equal(hits.prim, [9, -1, -1])


def double_precision_hits(tris, origins, directions):
    """Closest hits by Möller–Trumbore in float64 over every triangle: (t, prim), inf/-1 on a
    miss. An oracle independent of tritrace's float kernels (it can disagree only on rays that
    pass within rounding of an edge, which the comparison below leaves out)."""
    v0, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    best_t = np.full(len(origins), np.inf)
    best_prim = np.full(len(origins), -1)
    margin = np.full(len(origins), np.inf)  # how far the hit is from its triangle's edges
    for i in range(len(tris)):
        p = np.cross(directions, e2[i])
        det = p @ e1[i]
        s = origins - v0[i]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.sum(s * p, axis=1) / det
            q = np.cross(s, e1[i])
            v = np.sum(directions * q, axis=1) / det
            t = (q @ e2[i]) / det
        ok = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0)
        closer = ok & (t < best_t)
        best_t = np.where(closer, t, best_t)
        best_prim = np.where(closer, i, best_prim)
        margin = np.where(closer, np.minimum(np.minimum(u, v), 1 - u - v), margin)
    return best_t, best_prim, margin


def test_hits_agree_with_a_double_precision_oracle(accel):
    rng = np.random.default_rng(7)
    n = 20000
    origins = rng.uniform(-0.95, 0.95, (n, 3)).astype(np.float32)
    directions = rng.normal(size=(n, 3)).astype(np.float32)
    hits = accel.intersect(origins, directions)
    t, prim, margin = double_precision_hits(
        lab_box_triangles().astype(np.float32).astype(np.float64),
        origins.astype(np.float64), directions.astype(np.float64))
    # Rays from inside the box (and inside no block) always hit something; leave out those
    # within rounding of an edge, where float and double may pick different neighbours.
    clear = margin > 1e-4
    assert clear.mean() > 0.95
    np.testing.assert_array_equal(hits.prim[clear], prim[clear])
    np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize("scene_name", ["cornell", "terrain:20k"])
def test_every_accel_gives_the_same_hits_bit_for_bit(scene_name):
    scene = tritrace.Scene.builtin(scene_name)
    rng = np.random.default_rng(3)
    n = 30000
    lo, hi = scene.bounds
    origins = rng.uniform(lo, hi, (n, 3)).astype(np.float32)
    directions = rng.normal(size=(n, 3)).astype(np.float32)
    cam_origin, cam_dirs = scene.camera_rays(width=160, height=120)
    reference = tritrace.Accel(scene, "brute")
    expected = reference.intersect(origins, directions)
    expected_cam = reference.intersect(cam_origin, cam_dirs)
    expected_occ = reference.occluded(origins, directions, 0.0, 0.5)
    for kind in ("bvh", "bvh-single"):
        accel = tritrace.Accel(scene, kind)
        assert accel.kernel == "watertight"
        for coherent in (None, True, False):
            for (o, d), want in (((origins, directions), expected),
                                 ((cam_origin, cam_dirs), expected_cam)):
                got = accel.intersect(o, d, coherent=coherent)
                for name in ("t", "prim", "u", "v"):
                    np.testing.assert_array_equal(getattr(got, name), getattr(want, name),
                                                  err_msg=f"{kind} {coherent} {name}")
            np.testing.assert_array_equal(
                accel.occluded(origins, directions, 0.0, 0.5, coherent=coherent), expected_occ)


@pytest.mark.skipif("embree" not in tritrace.accels, reason="built without Embree")
def test_embree_finds_the_same_triangles_within_its_own_rounding(cornell):
    rng = np.random.default_rng(5)
    origins = rng.uniform(-0.9, 0.9, (20000, 3)).astype(np.float32)
    directions = rng.normal(size=(20000, 3)).astype(np.float32)
    ours = tritrace.Accel(cornell).intersect(origins, directions)
    embree = tritrace.Accel(cornell, "embree")
    assert embree.kernel == "embree"
    theirs = embree.intersect(origins, directions)
    same = ours.prim == theirs.prim
    assert same.mean() > 0.999
    np.testing.assert_allclose(theirs.t[same], ours.t[same], rtol=1e-4)


def test_camera_rays_hit_what_the_cli_writes_as_depth_normal_and_albedo(tmp_path, cornell):
    # The lab integrator traces one ray through each pixel's corner, and its AOVs are that ray's
    # first hit: the CLI's EXR holds t, the normal turned toward the camera and the albedo.
    out = tmp_path / "aovs.exr"
    run_cli("render", "--width", 96, "--height", 64, "--yaw", 0.3, "--aovs",
            "albedo,normal,depth", "-q", "-o", out)
    exr = read_exr(out)
    origin, directions = cornell.camera_rays(width=96, height=64, yaw=0.3)
    assert directions.shape == (64, 96, 3) and origin.shape == (3,)
    hits = tritrace.Accel(cornell).intersect(origin, directions)
    assert hits.t.shape == (64, 96)
    np.testing.assert_array_equal(np.where(hits.hit, hits.t, 0), exr["Z"])
    cli_normal = np.stack([exr["normal.X"], exr["normal.Y"], exr["normal.Z"]], axis=-1)
    facing = np.where(np.sum(hits.normal * directions, axis=-1, keepdims=True) > 0,
                      -hits.normal, hits.normal)
    np.testing.assert_array_equal(facing, cli_normal)
    # Albedo: the fact sheet's colours by triangle (room walls, then the two blocks).
    colours = {"red": (0.75, 0.15, 0.15), "purple": (0.75, 0.15, 0.75),
               "yellow": (0.75, 0.75, 0.15), "cyan": (0.15, 0.75, 0.75),
               "green": (0.15, 0.75, 0.15), "white": (0.75, 0.75, 0.75),
               "blue": (0.15, 0.15, 0.75)}
    by_triangle = np.array(
        [colours[c] for c in ["green"] * 2 + ["purple"] * 2 + ["yellow"] * 2 + ["cyan"] * 2 +
         ["white"] * 2 + ["red"] * 10 + ["blue"] * 10] + [(0, 0, 0)], np.float32)
    cli_albedo = np.stack([exr["albedo.R"], exr["albedo.G"], exr["albedo.B"]], axis=-1)
    np.testing.assert_array_equal(by_triangle[hits.prim], cli_albedo)


def test_shapes_broadcast_like_numpy(accel):
    rng = np.random.default_rng(1)
    directions = rng.normal(size=(4, 5, 3)).astype(np.float32)
    origin = np.float32([0, -0.5, 0])
    hits = accel.intersect(origin, directions)
    assert hits.t.shape == hits.prim.shape == hits.u.shape == hits.v.shape == (4, 5)
    assert hits.normal.shape == (4, 5, 3)
    assert accel.occluded(origin, directions).shape == (4, 5)
    flat = accel.intersect(np.tile(origin, (20, 1)), directions.reshape(20, 3))
    np.testing.assert_array_equal(hits.t.reshape(20), flat.t)
    # One ray: 0-d arrays, as NumPy broadcasting of two (3,) vectors gives.
    one = accel.intersect(origin, [0, 0, 1])
    assert one.t.shape == () and one.normal.shape == (3,)
    # Many origins, one direction.
    assert accel.intersect(rng.uniform(-0.5, 0.5, (7, 3)), [0, 0, 1]).t.shape == (7,)
    empty = accel.intersect(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32))
    assert empty.t.shape == (0,) and empty.normal.shape == (0, 3)
    assert accel.occluded(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)


def test_any_real_dtype_or_layout_gives_the_hits_of_its_float32_values(accel):
    rng = np.random.default_rng(2)
    o64 = rng.uniform(-0.9, 0.9, (1000, 3))
    d64 = rng.normal(size=(1000, 3))
    expected = accel.intersect(o64.astype(np.float32), d64.astype(np.float32))
    # float64, a strided view, Fortran order, a list of lists, integers.
    for o, d in ((o64, d64), (o64[::1], np.asfortranarray(d64)),
                 (np.repeat(o64, 2, axis=0)[::2], d64.tolist())):
        got = accel.intersect(o, d)
        np.testing.assert_array_equal(got.t, expected.t)
        np.testing.assert_array_equal(got.prim, expected.prim)
    o_int = np.int64([[0, -1, 0], [0, 0, -2], [1, 0, 0]])
    d_int = np.int32([[0, 1, 0], [0, 0, 1], [-1, 0, 0]])
    ints = accel.intersect(o_int, d_int)
    floats = accel.intersect(o_int.astype(np.float32), d_int.astype(np.float32))
    np.testing.assert_array_equal(ints.t, floats.t)
    np.testing.assert_array_equal(ints.prim, floats.prim)


def test_result_memory_is_reused_once_released_and_never_while_alive(accel):
    # The accel keeps released result buffers for its next queries (BufferCache): after the
    # results of one query are freed, the next query of the same size, float32 or converted from
    # float64, gets the same memory back; while results are alive, a query gets other memory.
    n = 1 << 16
    rng = np.random.default_rng(4)
    o32 = rng.uniform(-0.9, 0.9, (n, 3)).astype(np.float32)
    d32 = rng.normal(size=(n, 3)).astype(np.float32)

    def addresses(hits):
        return {a.__array_interface__["data"][0] for a in (hits.t, hits.prim, hits.u, hits.v)}

    first = accel.intersect(o32, d32)
    used = addresses(first)
    expected_t = first.t.copy()
    alive = accel.intersect(o32, d32)
    assert addresses(alive).isdisjoint(used)
    del first
    for o, d in ((o32, d32), (o32.astype(np.float64), d32.astype(np.float64))):
        again = accel.intersect(o, d)
        assert addresses(again) == used
        np.testing.assert_array_equal(again.t, expected_t)
        del again
    np.testing.assert_array_equal(alive.t, expected_t)
