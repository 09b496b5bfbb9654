# tritrace.QueryScene's point queries: closest points equal to a NumPy brute force in double (each
# triangle's plane projection when it falls inside, else the nearest of its three edges: another
# method than the library's Voronoi regions), analytic signed distances to a box and a sphere,
# occupancy against analytic insides, the warning for meshes that are not closed, shapes and errors.
import warnings

import numpy as np
import pytest

import tritrace


def box(lo, hi):
    """The box [lo, hi] as 12 counter-clockwise triangles (normals out)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1], hi[2] if i & 4 else lo[2]]
                  for i in range(8)])
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    t = [(a, b, c) for a, b, c, d in faces] + [(a, c, d) for a, b, c, d in faces]
    return v, np.array(t)


def icosphere(levels, radius):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [np.array(p) / np.linalg.norm(p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        cache = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = v[a] + v[b]
                v.append(m / np.linalg.norm(m))
                cache[key] = len(v) - 1
            return cache[key]

        nf = []
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return radius * np.array(v), np.array(f)


def segment_distance2(p, a, b):
    d = b - a
    t = np.clip(((p - a) @ d) / max(d @ d, 1e-300), 0, 1)
    q = a + t[:, None] * d
    return np.einsum("ij,ij->i", p - q, p - q)


def brute_force(meshes, points):
    """Least squared distance per point in double, the (geometry, prim) that reaches it, and the
    second least, over every triangle of every mesh."""
    p = points.astype(np.float64)
    best = np.full(len(p), np.inf)
    second = np.full(len(p), np.inf)
    geometry = np.full(len(p), -1)
    prim = np.full(len(p), -1)
    for g, (vertices, triangles) in enumerate(meshes):
        v = np.asarray(vertices, np.float32).astype(np.float64)
        for k, (ia, ib, ic) in enumerate(triangles):
            a, b, c = v[ia], v[ib], v[ic]
            n = np.cross(b - a, c - a)
            d2 = np.minimum(np.minimum(segment_distance2(p, a, b), segment_distance2(p, b, c)),
                            segment_distance2(p, c, a))
            nn = n @ n
            if nn > 0:
                h = (p - a) @ n / nn
                foot = p - h[:, None] * n
                # Inside when the foot is on the inner side of all three edges.
                inside = np.ones(len(p), bool)
                for s, e in ((a, b), (b, c), (c, a)):
                    inside &= np.cross(e - s, foot - s) @ n >= 0
                d2 = np.where(inside, h * h * nn, d2)
            better = d2 < best
            second = np.where(better, best, np.minimum(second, d2))
            best = np.where(better, d2, best)
            geometry = np.where(better, g, geometry)
            prim = np.where(better, k, prim)
    return best, second, geometry, prim


def test_closest_points_match_brute_force():
    rng = np.random.default_rng(28)
    meshes = []
    scene = tritrace.QueryScene()
    for g in range(2):
        vertices = rng.uniform(-1, 1, (120, 3))
        triangles = rng.integers(0, 120, (150, 3))
        meshes.append((vertices, triangles))
        assert scene.add(vertices, triangles) == g
    points = rng.uniform(-1.5, 1.5, (1500, 3)).astype(np.float32)
    got = scene.closest_points(points)
    best, second, geometry, prim = brute_force(meshes, points)
    np.testing.assert_allclose(scene.distance(points), np.sqrt(best), rtol=1e-6, atol=1e-7)
    d = np.linalg.norm(got["points"].astype(np.float64) - points, axis=1)
    np.testing.assert_allclose(d, np.sqrt(best), rtol=1e-5, atol=1e-6)
    clear = second > best * (1 + 1e-5)
    assert clear.sum() > 900  # shared corners of these big triangles are exact ties
    np.testing.assert_array_equal(got["geometry_ids"][clear], geometry[clear])
    np.testing.assert_array_equal(got["primitive_ids"][clear], prim[clear])
    # The barycentrics and normals describe the triangle found.
    for i in np.flatnonzero(clear)[:300]:
        v, t = meshes[got["geometry_ids"][i]]
        a, b, c = v.astype(np.float32).astype(np.float64)[t[got["primitive_ids"][i]]]
        u, w = got["primitive_uvs"][i]
        np.testing.assert_allclose((1 - u - w) * a + u * b + w * c, got["points"][i], atol=2e-6)
        n = np.cross(b - a, c - a)
        np.testing.assert_allclose(got["primitive_normals"][i], n / np.linalg.norm(n), atol=1e-5)


def box_sdf(p):
    q = np.abs(p) - 1.0
    outside = np.linalg.norm(np.maximum(q, 0), axis=-1)
    return np.where(outside > 0, outside, np.max(q, axis=-1))


def test_box_signed_distance_and_occupancy_are_analytic():
    scene = tritrace.QueryScene()
    scene.add(*box([-1, -1, -1], [1, 1, 1]))
    points = np.random.default_rng(1).uniform(-3, 3, (5000, 3)).astype(np.float32)
    want = box_sdf(points.astype(np.float64))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a closed mesh: no warning
        sdf = scene.signed_distance(points)
        occupancy = scene.occupancy(points)
    np.testing.assert_allclose(sdf, want, atol=2e-6)
    np.testing.assert_array_equal(occupancy, (want < 0).astype(np.float32))
    assert occupancy.dtype == np.float32 and sdf.dtype == np.float32
    # On the surface: +0.
    assert scene.signed_distance([1.0, 0.25, 0.5]) == 0.0


def test_inward_facing_mesh_has_the_same_inside():
    vertices, triangles = box([-1, -1, -1], [1, 1, 1])
    scene = tritrace.QueryScene()
    scene.add(vertices, triangles[:, ::-1])
    points = np.random.default_rng(2).uniform(-2, 2, (2000, 3))
    np.testing.assert_array_equal(scene.occupancy(points), box_sdf(points) < 0)


def test_sphere_signed_distance_within_the_tessellation_bound():
    vertices, triangles = icosphere(3, 2.0)
    # Every surface point lies between the least plane distance of the faces and the sphere.
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    inner = np.min(np.einsum("ij,ij->i", n, a) / np.linalg.norm(n, axis=1))
    scene = tritrace.QueryScene()
    scene.add(vertices, triangles)
    points = np.random.default_rng(3).uniform(-4, 4, (4000, 3))
    r = np.linalg.norm(points, axis=1)
    sdf = scene.signed_distance(points).astype(np.float64)
    out, deep = r >= 2.0, r <= inner
    assert np.all(sdf[out] >= r[out] - 2.0 - 1e-5) and np.all(sdf[out] <= r[out] - inner + 1e-5)
    assert np.all(-sdf[deep] >= inner - r[deep] - 1e-5)
    assert np.all(-sdf[deep] <= 2.0 - r[deep] + 1e-5)
    np.testing.assert_array_equal(scene.occupancy(points)[out | deep], deep[out | deep])


def test_several_geometries_and_add_after_a_query():
    scene = tritrace.QueryScene()
    scene.add(*box([-1, -1, -1], [1, 1, 1]))
    points = np.array([[0, 0, 0], [5, 0, 0], [5.5, 0.5, 0.5]], np.float32)
    np.testing.assert_array_equal(scene.occupancy(points), [1, 0, 0])
    scene.add(*box([4, -1, -1], [6, 1, 1]))
    np.testing.assert_array_equal(scene.occupancy(points), [1, 1, 1])
    got = scene.closest_points(points)
    np.testing.assert_array_equal(got["geometry_ids"], [0, 1, 1])
    np.testing.assert_allclose(scene.signed_distance(points), [-1, -1, -0.5], atol=1e-6)


def test_open_mesh_warns_and_names_its_edges():
    vertices, triangles = box([-1, -1, -1], [1, 1, 1])
    scene = tritrace.QueryScene()
    scene.add(vertices, triangles[:-1])
    with pytest.warns(RuntimeWarning, match="geometry 0 has 3 boundary, 0 non-manifold"):
        inside = scene.occupancy([[0, 0, 0], [3, 0, 0]])
    # Eleven of twelve triangles still enclose the centre: winding number above 1/2.
    np.testing.assert_array_equal(inside, [1, 0])
    with pytest.warns(RuntimeWarning, match="signed_distance: the scene is not closed"):
        scene.signed_distance([0, 0, 0])
    # distance and closest_points do not need an inside: no warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene.distance([0, 0, 0])


def test_shapes():
    scene = tritrace.QueryScene()
    scene.add(*box([-1, -1, -1], [1, 1, 1]))
    points = np.zeros((4, 5, 3))
    got = scene.closest_points(points)
    assert got["points"].shape == (4, 5, 3)
    assert got["primitive_uvs"].shape == (4, 5, 2)
    assert got["primitive_normals"].shape == (4, 5, 3)
    assert got["geometry_ids"].shape == (4, 5) and got["primitive_ids"].dtype == np.int32
    assert scene.distance(points).shape == (4, 5)
    assert scene.signed_distance([0.0, 0.0, 0.0]).shape == ()
    assert scene.occupancy(np.zeros((0, 3))).shape == (0,)


def test_empty_scene_has_no_surface():
    got = tritrace.QueryScene().closest_points([[0, 0, 0]])
    assert np.isinf(got["points"]).all() and got["primitive_ids"][0] == -1
    assert got["geometry_ids"][0] == -1


def test_bad_points_are_refused_naming_the_argument():
    scene = tritrace.QueryScene()
    scene.add(*box([-1, -1, -1], [1, 1, 1]))
    with pytest.raises(ValueError, match=r"points: must have shape \(\.\.\., 3\), got \(4, 2\)"):
        scene.distance(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"points: point 1 is not finite: \(nan, 0, 0\)"):
        scene.closest_points([[0, 0, 0], [np.nan, 0, 0]])
    with pytest.raises(ValueError, match="points: point 0 is not finite"):
        scene.occupancy([np.inf, 0, 0])
    with pytest.raises(TypeError, match="points"):
        scene.signed_distance("here")


def test_threads_share_one_scene_and_its_lazy_inside_test():
    import threading

    vertices, triangles = icosphere(2, 1.0)
    scene = tritrace.QueryScene()
    scene.add(vertices, triangles)
    points = np.random.default_rng(4).uniform(-1.5, 1.5, (2000, 3))
    results = [None] * 6
    barrier = threading.Barrier(len(results))

    def work(k):
        barrier.wait()  # all threads ask at once: one builds the BVH and the inside test
        results[k] = (scene.occupancy(points), scene.distance(points))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(len(results))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    want_inside, want_distance = scene.occupancy(points), scene.distance(points)
    for inside, distance in results:
        np.testing.assert_array_equal(inside, want_inside)
        np.testing.assert_array_equal(distance, want_distance)
