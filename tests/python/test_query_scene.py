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


def grid_box(n):
    """The box [0, n]^3, each face an n x n grid of squares split along alternating diagonals:
    (vertices, triangles) with integer coordinates."""
    index = {}
    vertices, triangles = [], []

    def vertex(p):
        if p not in index:
            index[p] = len(vertices)
            vertices.append(p)
        return index[p]

    for axis in range(3):
        for side in (0, n):
            for i in range(n):
                for j in range(n):
                    def at(di, dj):
                        p = [0, 0, 0]
                        p[axis], p[(axis + 1) % 3], p[(axis + 2) % 3] = side, i + di, j + dj
                        return vertex(tuple(p))
                    a, b, c, d = at(0, 0), at(1, 0), at(1, 1), at(0, 1)
                    triangles += [(a, b, c), (a, c, d)] if (i + j) % 2 == 0 else \
                        [(a, b, d), (b, c, d)]
    return np.array(vertices, np.float64), np.array(triangles)


def dyadic_directions():
    """Directions from grid points whose shear is exact: components in {0, +-1, +-2} with the
    dominant one's ratio to the others a power of two."""
    out = []
    for d in np.ndindex(5, 5, 5):
        d = np.array(d) - 2
        if not d.any() or (np.abs(d).max() == 2 and (np.abs(d) % 2).sum() == 0):
            continue
        out.append(d)
    return np.array(out, np.float32)


def test_rays_through_grid_edges_and_vertices_cross_a_closed_box_once_from_inside():
    n = 3
    scene = tritrace.QueryScene()
    scene.add(*grid_box(n))
    points = np.array(list(np.ndindex(n - 1, n - 1, n - 1)), np.float32) + 1  # interior grid
    directions = dyadic_directions()
    origins = np.repeat(points, len(directions), axis=0)
    dirs = np.tile(directions, (len(points), 1))
    counts = scene.count_intersections(origins, dirs)
    assert counts.dtype == np.int32
    np.testing.assert_array_equal(counts, 1)
    # The same lines from far outside: in and out, two crossings each.
    counts = scene.count_intersections(origins - 8 * dirs, dirs)
    np.testing.assert_array_equal(counts, 2)


def test_parity_from_random_points_says_inside_or_outside():
    n = 2
    scene = tritrace.QueryScene()
    scene.add(*grid_box(n))
    rng = np.random.default_rng(4)
    points = rng.uniform(-0.5, n + 0.5, (4000, 3)).astype(np.float32)
    directions = rng.normal(size=(4000, 3)).astype(np.float32)
    # Half the rays aimed at grid vertices, where the crossing is on shared edges.
    targets = rng.integers(0, n + 1, (2000, 3)).astype(np.float32)
    directions[:2000] = targets - points[:2000]
    keep = np.abs(directions).max(axis=1) > 0
    points, directions = points[keep], directions[keep]
    inside = np.all((points > 0) & (points < n), axis=1)
    near_surface = np.any(np.abs(points - np.round(points / n) * n) < 1e-3, axis=1)
    counts = scene.count_intersections(points, directions)
    sure = ~near_surface
    np.testing.assert_array_equal(counts[sure] % 2, inside[sure].astype(np.int32))
    np.testing.assert_array_equal(counts[sure & inside], 1)  # convex: exactly one way out
    assert inside.sum() > 500 and (~inside).sum() > 500


def test_lists_match_a_double_precision_brute_force():
    rng = np.random.default_rng(5)
    meshes = []
    for centre in ([0, 0, 0], [0.3, 0.2, 0]):
        vertices = rng.uniform(-1, 1, (80, 3)) + centre
        meshes.append((vertices, rng.integers(0, 80, (60, 3))))
    scene = tritrace.QueryScene()
    for vertices, triangles in meshes:
        scene.add(vertices, triangles)
    origins = rng.uniform(-3, 3, (500, 3)).astype(np.float32)
    directions = (rng.uniform(-0.5, 0.5, (500, 3)) - origins / 3).astype(np.float32)
    result = scene.list_intersections(origins, directions)
    counts = scene.count_intersections(origins, directions)
    splits = result["ray_splits"]
    assert splits.dtype == np.int64 and len(splits) == 501 and splits[0] == 0
    np.testing.assert_array_equal(np.diff(splits), counts)
    np.testing.assert_array_equal(result["ray_ids"], np.repeat(np.arange(500), counts))
    # The oracle: every crossing in double, per ray sorted by t.
    crossings = [[] for _ in range(500)]
    unsure = np.zeros(500, bool)
    o, d = origins.astype(np.float64), directions.astype(np.float64)
    for g, (vertices, triangles) in enumerate(meshes):
        v = np.asarray(vertices, np.float32).astype(np.float64)
        for k, (a, b, c) in enumerate(triangles):
            e1, e2 = v[b] - v[a], v[c] - v[a]
            p = np.cross(d, e2)
            det = p @ e1
            with np.errstate(divide="ignore", invalid="ignore"):
                s = o - v[a]
                u = np.einsum("ij,ij->i", s, p) / det
                w = np.einsum("ij,ij->i", d, np.cross(s, e1)) / det
                t = np.cross(s, e1) @ e2 / det
            margin = np.minimum(np.minimum(u, w), 1 - u - w)
            unsure |= (t > 0) & (np.abs(margin) < 1e-6)
            for i in np.nonzero((det != 0) & (margin >= 0) & (t >= 0))[0]:
                crossings[i].append((t[i], g, k))
    compared = 0
    for i in range(500):
        want = sorted(crossings[i])
        ts = [c[0] for c in want]
        if unsure[i] or np.any(np.diff(ts) < 1e-5):
            continue
        got = slice(splits[i], splits[i + 1])
        np.testing.assert_array_equal(result["geometry_ids"][got], [c[1] for c in want])
        np.testing.assert_array_equal(result["primitive_ids"][got], [c[2] for c in want])
        np.testing.assert_allclose(result["t"][got], ts, rtol=1e-5, atol=1e-6)
        compared += len(want)
    assert compared > 500
    # Each crossing's uv are the barycentrics of its point on its triangle.
    points = origins[result["ray_ids"]] + result["t"][:, None] * directions[result["ray_ids"]]
    for i in range(0, len(points), 37):
        g, k = result["geometry_ids"][i], result["primitive_ids"][i]
        vertices, triangles = meshes[g]
        a, b, c = np.asarray(vertices, np.float32)[triangles[k]]
        uv = result["primitive_uvs"][i]
        np.testing.assert_allclose(a + uv[0] * (b - a) + uv[1] * (c - a), points[i], atol=1e-4)


def test_intervals_and_shapes_of_all_hits():
    scene = tritrace.QueryScene()
    scene.add(*unit_quad(1))
    scene.add(*unit_quad(2))
    origins = np.zeros((2, 3, 3))
    origins[..., :2] = 0.25
    counts = scene.count_intersections(origins, [0, 0, 1], tmax=1.5)
    assert counts.shape == (2, 3) and np.all(counts == 1)
    result = scene.list_intersections(origins, [0, 0, 1])
    assert len(result["ray_splits"]) == 7 and len(result["t"]) == 12
    np.testing.assert_array_equal(result["t"], np.tile([1, 2], 6))
    np.testing.assert_array_equal(result["geometry_ids"], np.tile([0, 1], 6))
    assert result["primitive_uvs"].shape == (12, 2)
    empty = tritrace.QueryScene().list_intersections(np.zeros((0, 3)), [0, 0, 1])
    assert list(empty["ray_splits"]) == [0] and len(empty["t"]) == 0


def test_bad_rays_for_all_hits_raise_value_error_naming_the_argument():
    scene = tritrace.QueryScene()
    scene.add(*unit_quad(1))
    for query in (scene.count_intersections, scene.list_intersections):
        with pytest.raises(ValueError, match="^origins: ray 1 is not finite"):
            query([[0, 0, 0], [0, np.nan, 0]], [0, 0, 1])
        with pytest.raises(ValueError, match="^tmax: must not be NaN"):
            query(np.zeros(3), [0, 0, 1], tmax=np.nan)
        with pytest.raises(ValueError, match="^directions: must have shape"):
            query(np.zeros(3), [0, 1])


def test_threads_query_while_another_adds():
    import threading
    scene = tritrace.QueryScene()
    scene.add(*grid_box(2))
    rng = np.random.default_rng(9)
    origins = rng.uniform(0.1, 1.9, (20000, 3)).astype(np.float32)   # inside the box
    directions = rng.normal(size=(20000, 3)).astype(np.float32)
    failures = []

    def query():
        for _ in range(10):
            counts = scene.count_intersections(origins, directions)
            hits = scene.intersect(origins, directions)
            if not (np.all(counts == 1) and np.all(hits["geometry_ids"] == 0)):
                failures.append("a query saw a wrong answer")

    threads = [threading.Thread(target=query) for _ in range(4)]
    for t in threads:
        t.start()
    for k in range(20):  # far from the box: no answer above changes
        scene.add(*unit_quad(100 + k))
    for t in threads:
        t.join()
    assert not failures
    assert scene.geometry_count == 21
