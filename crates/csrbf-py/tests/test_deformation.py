"""fit and Deformation: numbers in and out, as the README shows them."""

import os
import pickle

import numpy as np
import pytest

import csrbf
from conftest import HEAD, SMILE, assert_close, controls_of, diagonal

pytestmark = pytest.mark.smoke

STARTS = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TARGETS = STARTS + [[0.0, 0.1, 0.0], [0.0, 0.0, 0.0], [0.05, 0.0, 0.0], [0.0, 0.0, -0.1]]


def cloud(n=500, seed=1, dtype=np.float64):
    return np.random.default_rng(seed).uniform(-0.5, 1.5, (n, 3)).astype(dtype)


def test_the_module_says_which_build_it_is():
    # Benchmarks print it: a dev build (the test scripts') is slower than
    # users' release build. scripts/test_python.sh says which it installed.
    assert csrbf.build_profile in ("release", "dev")
    expected = os.environ.get("CSRBF_EXPECT_BUILD_PROFILE")
    if expected:
        assert csrbf.build_profile == expected
    assert csrbf.__version__.count(".") == 2


def test_fit_carries_every_start_to_its_destination_and_stays_local():
    d = csrbf.fit(STARTS, TARGETS, radius=0.8)
    assert_close(d.deform(STARTS), TARGETS, 1.0, 1e-9)
    far = d.displacements([[5.0, 5.0, 5.0]])
    assert far.tolist() == [[0.0, 0.0, 0.0]]
    assert repr(d) == "Deformation(c2, R=0.8, 4 controls)"
    assert (d.kernel, d.radius, d.polynomial, len(d)) == ("c2", 0.8, "none", 4)
    assert d.starts.shape == (4, 3) and d.coefficients.shape == (4, 3)
    assert "linear" in repr(csrbf.fit(STARTS, TARGETS, 0.8, kernel="c4", polynomial="linear"))


def test_the_dtype_given_is_kept():
    d = csrbf.fit(STARTS, TARGETS, radius=0.8)
    p64 = cloud()
    assert d.displacements(p64).dtype == np.float64
    assert d.displacements(p64.astype(np.float32)).dtype == np.float32
    assert d.deform(p64.astype(np.float32)).dtype == np.float32
    ints = np.array([[0, 0, 0], [1, 0, 0]], dtype=np.int32)
    assert d.displacements(ints).dtype == np.float64
    assert d.displacements([[0, 0, 0]]).dtype == np.float64  # a list
    assert_close(d.displacements(p64.astype(np.float32)), d.displacements(p64), 2.0, 1e-6)


def test_non_contiguous_views_are_read():
    d = csrbf.fit(STARTS, TARGETS, radius=0.8)
    wide = cloud(400, dtype=np.float32).reshape(200, 6)
    view = wide[:, 1:4]  # strided rows
    assert not view.flags.c_contiguous
    assert_close(d.displacements(view), d.displacements(np.ascontiguousarray(view)), 1.0, 0)
    fortran = np.asfortranarray(cloud())
    assert_close(d.deform(fortran), d.deform(np.ascontiguousarray(fortran)), 1.0, 0)
    every_other = cloud()[::2]
    assert_close(d.displacements(every_other), d.displacements(every_other.copy()), 1.0, 0)


def test_out_is_filled_in_place_without_a_copy():
    d = csrbf.fit(STARTS, TARGETS, radius=0.8)
    points = cloud(dtype=np.float32)
    expected = points + d.displacements(points)
    out = np.empty_like(points)
    got = d.displacements(points, out=out)
    assert got is out
    moved = d.deform(points, phase=1.0, out=out)
    assert moved is out and np.shares_memory(moved, out)
    assert_close(out, expected, 1.0, 1e-6)
    # out= the points themselves: moved in place, the same buffer.
    before = points.__array_interface__["data"][0]
    back = d.deform(points, phase=1.0, out=points)
    assert back is points and points.__array_interface__["data"][0] == before
    assert_close(points, expected, 1.0, 1e-6)


def test_phase_scales_the_displacement():
    d = csrbf.fit(STARTS, TARGETS, radius=0.8)
    p = cloud()
    assert_close(d.deform(p, phase=0.0), p, 1.0, 0)
    assert_close(d.deform(p, phase=0.5), p + 0.5 * d.displacements(p), 1.0, 1e-12)
    with pytest.raises(csrbf.Error, match="phase"):
        d.deform(p, phase=1.5)


def test_pickle_and_bytes_round_trip_bit_exact(tmp_path):
    d = csrbf.fit(STARTS, TARGETS, radius=0.8, polynomial="linear")
    back = pickle.loads(pickle.dumps(d))
    assert back == d and back is not d
    p = cloud()
    assert np.array_equal(back.displacements(p), d.displacements(p))
    assert csrbf.Deformation.from_bytes(d.to_bytes()) == d
    d.save(tmp_path / "edit.csrbf")
    assert csrbf.Deformation.load(tmp_path / "edit.csrbf") == d
    assert csrbf.Deformation.load(str(tmp_path / "edit.csrbf")) == d


def test_the_bundled_head_smiles_like_its_control_file():
    mesh = csrbf.read_mesh(HEAD)
    starts, targets, radius, kernel, poly = controls_of(SMILE)
    d = csrbf.fit(starts, targets, radius, kernel=kernel, polynomial=poly)
    moved = d.deform(mesh.vertices)
    out, report = csrbf.deform_mesh(mesh, SMILE)
    assert_close(moved, out.vertices, diagonal(mesh.vertices))
    assert report.moved > 100


# Bad input: each with its message, none crashes or hangs.


def test_bad_arrays_name_the_argument_and_shape():
    d = csrbf.fit(STARTS, TARGETS, radius=0.8)
    with pytest.raises(ValueError, match=r"points must be an \(N, 3\) array, got shape \(5, 2\)"):
        d.displacements(np.zeros((5, 2)))
    with pytest.raises(ValueError, match=r"points must be an \(N, 3\) array, got shape \(3,\)"):
        d.displacements(np.zeros(3))
    with pytest.raises(ValueError, match=r"starts must be an \(N, 3\) array, got shape \(4, 2\)"):
        csrbf.fit(STARTS[:, :2], TARGETS, 0.8)
    with pytest.raises(ValueError, match="starts has 4 rows, targets 3"):
        csrbf.fit(STARTS, TARGETS[:3], 0.8)
    with pytest.raises(TypeError, match="points must be an array of real numbers, got dtype <U1"):
        d.displacements([["a", "b", "c"]])
    with pytest.raises(TypeError, match="starts must be an array of real numbers"):
        csrbf.fit([[0, None, 0]], [[0, 0, 0]], 0.8)
    with pytest.raises(TypeError, match="complex"):
        d.displacements(np.zeros((2, 3), dtype=complex))
    with pytest.raises(ValueError, match="points"):
        d.displacements([[0, 0, 0], [1, 2]])  # ragged
    with pytest.raises(ValueError, match=r"out must have shape \(500, 3\), got shape \(499, 3\)"):
        d.displacements(cloud(), out=np.zeros((499, 3)))
    with pytest.raises(TypeError, match="out must be a float64 array"):
        d.displacements(cloud(), out=np.zeros((500, 3), dtype=np.float32))
    with pytest.raises(ValueError, match="C order"):
        d.displacements(cloud(), out=np.zeros((3, 500)).T)
    points = cloud()
    with pytest.raises(ValueError, match="out shares memory with points"):
        d.displacements(points, out=points)
    with pytest.raises(ValueError, match="out shares memory with points"):
        d.deform(points, out=points[:])  # another view of the same memory
    ints = np.zeros((4, 3), dtype=np.int64)
    with pytest.raises(TypeError, match="out must be a float64 array"):
        d.deform(ints, out=np.zeros((4, 3), dtype=np.int64))
    with pytest.raises(TypeError, match="deform in place needs points to be a float32 or float64"):
        d.deform(ints, out=ints)


def test_engine_refusals_are_csrbf_errors_with_the_engine_message():
    assert issubclass(csrbf.Error, ValueError)
    nan = STARTS.copy()
    nan[2, 1] = np.nan
    with pytest.raises(csrbf.Error, match="control 2: start has a coordinate that is not finite"):
        csrbf.fit(nan, TARGETS, 0.8)
    with pytest.raises(csrbf.Error, match="no control vectors"):
        csrbf.fit(np.empty((0, 3)), np.empty((0, 3)), 0.8)
    dup = STARTS.copy()
    dup[3] = dup[1]
    with pytest.raises(csrbf.Error, match="controls 1 and 3 start at the same point"):
        csrbf.fit(dup, TARGETS, 0.8)
    for r in (0.0, -1.0, float("nan")):
        with pytest.raises(csrbf.Error, match="radius of support must be a finite number > 0"):
            csrbf.fit(STARTS, TARGETS, r)
    with pytest.raises(csrbf.Error, match='unknown kernel "c3"'):
        csrbf.fit(STARTS, TARGETS, 0.8, kernel="c3")
    with pytest.raises(csrbf.Error, match="linear"):
        csrbf.fit(STARTS, TARGETS, 0.8, polynomial="quadratic")
    with pytest.raises(csrbf.Error):
        csrbf.Deformation.from_bytes(b"CSRBF\0 not really")


def test_empty_points_and_nan_points():
    d = csrbf.fit(STARTS, TARGETS, radius=0.8)
    assert d.displacements(np.empty((0, 3))).shape == (0, 3)
    assert d.deform(np.empty((0, 3), dtype=np.float32)).dtype == np.float32
    for dtype in (np.float64, np.float32):
        got = d.displacements(np.array([[np.nan, 0.0, 0.0], [0.0, 0.0, 0.0], [9.0, 9.0, np.inf]], dtype=dtype))
        assert np.isnan(got[0]).all() and np.isnan(got[2]).all()  # NaN in, NaN out
        assert np.allclose(got[1], [0.0, 0.1, 0.0])  # the other points are unharmed
