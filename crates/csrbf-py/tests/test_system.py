"""System, Binding and deform_many: factor once, solve and evaluate many."""

import threading
import time

import numpy as np
import pytest

import csrbf
from conftest import assert_close

pytestmark = pytest.mark.smoke


# The unit cube's diagonal: a binding sums the kernel in float32 lanes (as
# Deformation.displacements_f32 does), within 1e-6 of the diagonal of the
# float64 evaluation (issue 18's bound; 1.1e-6 absolute here, 6.5e-7 of it).
DIAGONAL = 3**0.5


def scene(m=60, n=3000, seed=3):
    """m starts and n points on the unit cube; destinations about 0.03 away."""
    rng = np.random.default_rng(seed)
    starts = rng.uniform(0, 1, (m, 3))
    return starts, rng.uniform(0, 1, (n, 3)).astype(np.float32), rng


def variants(starts, rng, k):
    return starts + rng.normal(0, 0.03, (k, *starts.shape))


def test_a_system_solves_new_destinations_like_a_fresh_fit():
    starts, points, rng = scene()
    s = csrbf.System(starts, radius=0.35)
    assert repr(s).startswith("System(c2, R=0.35, 60 controls, ") and len(s) == 60
    assert s.stats["controls"] == 60 and s.stats["solver"] in ("skyline", "supernodal")
    for targets in variants(starts, rng, 3):
        assert s.solve(targets) == csrbf.fit(starts, targets, 0.35)


def test_a_binding_agrees_with_the_deformation():
    starts, points, rng = scene()
    s = csrbf.System(starts, radius=0.35)
    t1, t2 = variants(starts, rng, 2)
    b = csrbf.Binding(s.solve(t1), points)
    assert len(b) == len(points) and repr(b).startswith(f"Binding({len(points)} points, ")
    for t in (t1, t2):
        d = s.solve(t)
        got = b.displacements(d)
        assert got.dtype == np.float32
        assert_close(got, d.displacements(points), DIAGONAL, 1e-6)
    out = np.zeros_like(points)
    assert b.displacements(s.solve(t2), out=out) is out
    bound = s.bind(points.astype(np.float64))
    assert bound.displacements(s.solve(t2)).dtype == np.float64
    assert_close(bound.displacements(s.solve(t2)), out, 1.0, 1e-7)


def test_a_binding_refuses_a_deformation_of_other_starts():
    starts, points, rng = scene()
    b = csrbf.System(starts, radius=0.35).bind(points)
    fewer = csrbf.fit(starts[:10], starts[:10], 0.35)
    with pytest.raises(csrbf.Error, match="start"):
        b.displacements(fewer)
    # Other starts of the same count, kernel and radius (issue 21): refused too.
    moved = starts + 0.01
    with pytest.raises(csrbf.Error, match="start"):
        b.displacements(csrbf.fit(moved, moved, 0.35))


def test_a_rebind_is_a_new_binding():
    """rebind makes the binding anew (other starts, other points of another
    count and dtype) in place: it then equals a new binding of them, and
    refuses the starts it was made for before."""
    starts, points, rng = scene()
    b = csrbf.Binding(csrbf.fit(starts, starts, 0.35), points)
    other = starts + rng.normal(0, 0.02, starts.shape)
    d = csrbf.fit(other, other + 0.01, 0.35)
    more = np.concatenate([points, points[:500] * 0.9]).astype(np.float64)
    assert b.rebind(d, more) is None
    assert len(b) == len(more) and repr(b).endswith("float64)")
    fresh = csrbf.Binding(d, more)
    got = b.displacements(d)
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, fresh.displacements(d))
    assert b.nbytes == fresh.nbytes
    with pytest.raises(csrbf.Error, match="start"):
        b.displacements(csrbf.fit(starts, starts, 0.35))
    with pytest.raises(ValueError, match="points"):
        b.rebind(d, np.zeros((4, 2)))


def test_solve_many_and_displacements_many():
    starts, points, rng = scene()
    s = csrbf.System(starts, radius=0.35)
    sets = variants(starts, rng, 5)
    ds = s.solve_many(sets)
    assert [d == s.solve(t) for d, t in zip(ds, sets)] == [True] * 5
    many = s.bind(points).displacements_many(ds)
    assert many.shape == (5, len(points), 3) and many.dtype == np.float32
    for k, d in enumerate(ds):
        assert_close(many[k], d.displacements(points), DIAGONAL, 1e-6)


def test_deform_many_gives_every_variant_in_one_call():
    starts, points, rng = scene()
    sets = variants(starts, rng, 4)
    out = csrbf.deform_many(points, starts, sets, radius=0.35, phase=0.5)
    assert out.shape == (4, len(points), 3) and out.dtype == np.float32
    for k, t in enumerate(sets):
        assert_close(out[k], csrbf.fit(starts, t, 0.35).deform(points, phase=0.5), 1.0, 1e-6)
    again = np.empty_like(out)
    assert csrbf.deform_many(points, starts, sets, 0.35, phase=0.5, out=again) is again
    assert np.array_equal(again, out)
    f64 = csrbf.deform_many(points.astype(np.float64), starts, sets, 0.35)
    assert f64.dtype == np.float64
    with pytest.raises(ValueError, match=r"targets must be \(K, 60, 3\), one row per start: got 59"):
        csrbf.deform_many(points, starts, sets[:, 1:], 0.35)
    with pytest.raises(ValueError, match=r"targets must be an \(K, M, 3\) array, got shape \(60, 3\)"):
        csrbf.deform_many(points, starts, sets[0], 0.35)
    with pytest.raises(csrbf.Error, match="phase"):
        csrbf.deform_many(points, starts, sets, 0.35, phase=-1)


def test_heavy_calls_release_the_gil():
    """Another Python thread runs while an evaluation is in flight: with the
    GIL held for the whole call, no tick could fall inside one."""
    starts, _, rng = scene(m=400)
    d = csrbf.fit(starts, variants(starts, rng, 1)[0], 0.35)
    points = np.random.default_rng(4).uniform(0, 1, (400_000, 3))
    calls, ticks, done = [], [], threading.Event()

    def work():
        while not done.is_set():
            t0 = time.perf_counter()
            d.displacements(points)
            calls.append((t0, time.perf_counter()))

    worker = threading.Thread(target=work)
    worker.start()
    deadline = time.perf_counter() + 60
    try:
        while time.perf_counter() < deadline:
            ticks.append(time.perf_counter())
            inside = sum(any(a < t < b for a, b in calls) for t in ticks[-200:])
            if len(calls) >= 2 and inside >= 5:
                break
            time.sleep(0.001)
    finally:
        done.set()
        worker.join()
    inside = [t for t in ticks if any(a < t < b for a, b in calls)]
    assert len(inside) >= 5, f"{len(inside)} ticks of the other thread during {len(calls)} calls"


def test_starts_out_of_reach_equal_brute_force():
    """The starts farther than R from every point (what Blender's Live refuses,
    as Deform does) against measuring every point."""
    rng = np.random.default_rng(7)
    for n, k, radius in [(2000, 40, 0.05), (500, 30, 0.2), (50, 10, 1e-3), (1, 5, 0.5)]:
        points = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        starts = np.concatenate([points[rng.choice(n, k // 2)] + rng.normal(0, 0.3 * radius, (k // 2, 3)),
                                 rng.uniform(-1.5, 1.5, (k - k // 2, 3))])
        d = np.linalg.norm(points[None, :, :].astype(np.float64) - starts[:, None, :], axis=2).min(axis=1)
        want = [i for i in range(k) if d[i] >= radius]
        s = csrbf.System(starts, radius)
        assert s.starts_out_of_reach(points) == want, (n, k, radius)
        assert s.solve(starts).starts_out_of_reach(points) == want
        assert 0 < len(want) < k or n == 1
    # float64 points are measured as they are: rounded to float32, this
    # point would be 1.5e-9 nearer, within R of the start.
    p = np.array([[0.1, 0.0, 0.0]])
    s = csrbf.System(p + [[0.5 * (1 + 1e-12), 0.0, 0.0]], 0.5)
    assert s.starts_out_of_reach(p) == [0]
    assert s.starts_out_of_reach(p.astype(np.float32)) == []
