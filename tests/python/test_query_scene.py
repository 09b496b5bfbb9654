# tritrace.QueryScene: geometry ids in the order added, first hits equal to a NumPy brute force in
# double precision over the caller's own arrays, hand-computed hits and normals, zero-area
# triangles that keep their index but are never hit, and bad input refused naming the argument.
import numpy as np
import pytest

import tritrace


def unit_quad(z):
    """The square [-1, 1]^2 at height z as two counter-clockwise triangles (normal +z)."""
    vertices = np.array([[-1, -1, z], [1, -1, z], [1, 1, z], [-1, 1, z]], np.float64)
    return vertices, np.array([[0, 1, 2], [0, 2, 3]])


def brute_force_first_hits(meshes, origins, directions):
    """Möller–Trumbore in double over every triangle of every mesh: (t, geometry, prim), with
    inf / -1 on a miss, and whether each ray passes within 1e-6 of some triangle's border or has
    a near tie (where float may rightly decide otherwise)."""
    n = len(origins)
    best = np.full(n, np.inf)
    second = np.full(n, np.inf)
    geometry = np.full(n, -1)
    prim = np.full(n, -1)
    unsure = np.zeros(n, bool)
    o = origins.astype(np.float64)
    d = directions.astype(np.float64)
    for g, (vertices, triangles) in enumerate(meshes):
        v = np.asarray(vertices, np.float32).astype(np.float64)
        for k, (a, b, c) in enumerate(np.asarray(triangles)):
            e1, e2 = v[b] - v[a], v[c] - v[a]
            p = np.cross(d, e2)
            det = p @ e1
            with np.errstate(divide="ignore", invalid="ignore"):
                s = o - v[a]
                u = np.einsum("ij,ij->i", s, p) / det
                q = np.cross(s, e1)
                w = np.einsum("ij,ij->i", d, q) / det
                t = q @ e2 / det
            margin = np.minimum(np.minimum(u, w), 1 - u - w)
            unsure |= (t > 0) & (np.abs(margin) < 1e-6)
            hit = (det != 0) & (margin >= 0) & (t >= 0)
            closer = hit & (t < best)
            second = np.where(closer, best, np.where(hit & (t < second), t, second))
            best = np.where(closer, t, best)
            geometry = np.where(closer, g, geometry)
            prim = np.where(closer, k, prim)
    with np.errstate(invalid="ignore"):
        unsure |= np.isfinite(best) & (second - best < 1e-5 * (1 + best))
    return best, geometry, prim, unsure


def test_geometry_ids_follow_the_order_added():
    scene = tritrace.QueryScene()
    assert scene.geometry_count == 0 and scene.triangle_count == 0
    assert scene.add(*unit_quad(1)) == 0
    assert scene.add(*unit_quad(2)) == 1
    assert scene.add(np.zeros((0, 3)), np.zeros((0, 3), np.int64)) == 2
    assert scene.geometry_count == 3
    assert scene.triangle_count == 4


def test_hand_computed_hits_uvs_and_normals():
    scene = tritrace.QueryScene()
    scene.add(*unit_quad(2))
    scene.add(*unit_quad(1))
    # (0.5, -0.5) lies in triangle 0 = (-1,-1), (1,-1), (1,1) of each quad: (0.5,-0.5) =
    # a + 0.75 (b - a) + 0.25 (c - b), so the weights of b and c are 0.5 and 0.25.
    hits = scene.intersect(np.array([[0.5, -0.5, 0], [0.5, -0.5, 1.5], [5, 5, 0]]), [0, 0, 1])
    np.testing.assert_array_equal(hits["t"], np.float32([1, 0.5, np.inf]))
    np.testing.assert_array_equal(hits["geometry_ids"], [1, 0, -1])
    np.testing.assert_array_equal(hits["primitive_ids"], [0, 0, -1])
    np.testing.assert_allclose(hits["primitive_uvs"], [[0.5, 0.25], [0.5, 0.25], [0, 0]],
                               atol=1e-6)
    np.testing.assert_array_equal(hits["primitive_normals"], [[0, 0, 1], [0, 0, 1], [0, 0, 0]])
    assert hits["t"].dtype == np.float32 and hits["geometry_ids"].dtype == np.int32
    # tmax before the first quad: a miss; tmin past it: the second.
    hits = scene.intersect([0.5, -0.5, 0], [0, 0, 1], tmin=1.5)
    assert hits["t"] == 2 and hits["geometry_ids"] == 0
    assert scene.intersect([0.5, -0.5, 0], [0, 0, 1], tmax=0.5)["t"] == np.inf


def test_first_hits_match_a_double_precision_brute_force():
    rng = np.random.default_rng(3)
    meshes = []
    for centre in ([0, 0, 0], [0.5, 0, 0], [0, 0.5, 0.5]):
        vertices = rng.uniform(-1, 1, (60, 3)) + centre
        meshes.append((vertices, rng.integers(0, 60, (50, 3))))
    scene = tritrace.QueryScene()
    for vertices, triangles in meshes:
        scene.add(vertices, triangles)
    origins = rng.uniform(-3, 3, (3000, 3)).astype(np.float32)
    directions = (rng.uniform(-0.5, 0.5, (3000, 3)) - origins / 3).astype(np.float32)
    t, geometry, prim, unsure = brute_force_first_hits(meshes, origins, directions)
    hits = scene.intersect(origins, directions)
    sure = ~unsure
    assert sure.sum() > 2500
    np.testing.assert_array_equal(hits["geometry_ids"][sure], geometry[sure])
    np.testing.assert_array_equal(hits["primitive_ids"][sure], prim[sure])
    hit = sure & np.isfinite(t)
    assert hit.sum() > 500
    np.testing.assert_allclose(hits["t"][hit], t[hit], rtol=1e-5, atol=1e-6)


def test_zero_area_triangles_keep_their_index_but_are_never_hit():
    vertices = np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2], [-3, -3, 5], [6, -3, 5], [-3, 6, 5]])
    scene = tritrace.QueryScene()
    scene.add(vertices, [[0, 1, 2], [1, 1, 1], [3, 4, 5]])
    assert scene.triangle_count == 3
    rng = np.random.default_rng(1)
    directions = rng.uniform(-1, 1, (2000, 3))
    directions[:, 2] = 0.2 + np.abs(directions[:, 2])
    targets = vertices[rng.integers(0, 3, 2000)] * rng.choice([0.5, 1.0], (2000, 1))
    hits = scene.intersect(targets - 3 * directions, directions)
    assert set(np.unique(hits["primitive_ids"])) <= {-1, 2}


def test_rays_keep_their_shape():
    scene = tritrace.QueryScene()
    scene.add(*unit_quad(1))
    hits = scene.intersect(np.zeros((4, 5, 3)), [0, 0, 1])
    assert hits["t"].shape == (4, 5) and hits["primitive_uvs"].shape == (4, 5, 2)
    assert hits["primitive_normals"].shape == (4, 5, 3)
    assert np.all(hits["t"] == 1)


def test_an_empty_scene_misses_everything():
    hits = tritrace.QueryScene().intersect(np.zeros((3, 3)), [0, 0, 1])
    np.testing.assert_array_equal(hits["geometry_ids"], [-1, -1, -1])


@pytest.mark.parametrize("vertices, triangles, message", [
    (np.zeros((3, 2)), [[0, 1, 2]], "vertices: must have shape (N, 3), got (3, 2)"),
    (np.zeros((3, 3)), [[0, 1]], "triangles: must have shape (M, 3), got (1, 2)"),
    (np.zeros((3, 3)), [[0, 1, 3]], "triangles: triangle 0 has vertex index 3, but there are 3"),
    (np.zeros((3, 3)), [[0, -1, 2]], "triangles: triangle 0 has vertex index -1"),
    ([[0, 0, 0], [1, np.inf, 0], [0, 1, 0]], [[0, 1, 2]], "vertices: vertex 1 is not finite"),
    ([[0, 0, 0], [1e39, 0, 0], [0, 1, 0]], [[0, 1, 2]], "vertices: vertex 1 is not finite"),
])
def test_bad_meshes_raise_value_error_naming_the_argument(vertices, triangles, message):
    scene = tritrace.QueryScene()
    with pytest.raises(ValueError) as error, np.errstate(over="ignore"):
        scene.add(vertices, triangles)
    assert str(error.value).startswith(message)
    assert scene.geometry_count == 0


def test_bad_rays_raise_value_error_naming_the_argument():
    scene = tritrace.QueryScene()
    scene.add(*unit_quad(1))
    with pytest.raises(ValueError, match="^directions: ray 1 is zero"):
        scene.intersect(np.zeros((2, 3)), [[0, 0, 1], [0, 0, 0]])
    with pytest.raises(ValueError, match="^origins: must have shape"):
        scene.intersect(np.zeros((2, 2)), [0, 0, 1])
    with pytest.raises(ValueError, match="^tmin: must be a number >= 0"):
        scene.intersect(np.zeros(3), [0, 0, 1], tmin=-1)
