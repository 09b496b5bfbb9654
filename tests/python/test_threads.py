# Several Python threads querying one accel at once get exactly the answers each query gets alone,
# and a query releases the GIL while it traces, so other Python threads run meanwhile.
import sys
import threading

import numpy as np

import tritrace


def test_concurrent_queries_on_one_accel_give_the_single_thread_answers():
    scene = tritrace.Scene.builtin("terrain:20k")
    accel = tritrace.Accel(scene)
    lo, hi = scene.bounds
    rng = np.random.default_rng(11)
    jobs = []
    for k in range(12):
        n = 20000 + 1000 * k
        if k % 3 == 0:  # camera rays (packets)
            origin, d = scene.camera_rays(width=150, height=100 + k, yaw=0.1 * k)
            jobs.append((origin, d.reshape(-1, 3)))
        else:  # random rays (one by one)
            jobs.append((rng.uniform(lo, hi, (n, 3)).astype(np.float32),
                         rng.normal(size=(n, 3)).astype(np.float32)))
    expected = [(accel.intersect(o, d), accel.occluded(o, d, 0.0, 0.3)) for o, d in jobs]

    results = [None] * len(jobs)
    errors = []
    start = threading.Barrier(len(jobs))

    def work(i):
        try:
            start.wait()
            o, d = jobs[i]
            outcome = []
            for _ in range(3):
                outcome.append((accel.intersect(o, d), accel.occluded(o, d, 0.0, 0.3)))
            results[i] = outcome
        except Exception as e:  # reported below, in the main thread
            errors.append(e)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(len(jobs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for (want_hits, want_occluded), outcome in zip(expected, results):
        for hits, occluded in outcome:
            for name in ("t", "prim", "u", "v"):
                np.testing.assert_array_equal(getattr(hits, name), getattr(want_hits, name))
            np.testing.assert_array_equal(hits.normal, want_hits.normal)
            np.testing.assert_array_equal(occluded, want_occluded)


def test_other_threads_run_while_a_query_traces():
    # With a switch interval far longer than the test, CPython hands the GIL to another thread only
    # where the holder releases it itself. The main thread waits for the worker to start its
    # queries; it can run again, and see them unfinished, only if a query released the GIL: with
    # the GIL held throughout, it would run only once the worker had finished.
    scene = tritrace.Scene.builtin("terrain:20k")
    accel = tritrace.Accel(scene)
    lo, hi = scene.bounds
    rng = np.random.default_rng(12)
    n = 1 << 20
    origins = rng.uniform(lo, hi, (n, 3)).astype(np.float32)
    directions = rng.normal(size=(n, 3)).astype(np.float32)
    started, done = threading.Event(), threading.Event()

    def trace():
        started.set()
        accel.intersect(origins, directions, coherent=False)
        accel.intersect(origins, directions, coherent=False)
        done.set()

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1000.0)
    try:
        worker = threading.Thread(target=trace)
        worker.start()
        started.wait()
        ran_while_tracing = not done.is_set()
        done.wait()  # releases the GIL for the worker to finish
        worker.join()
    finally:
        sys.setswitchinterval(interval)
    assert ran_while_tracing
