"""The Python module on synthetic volumes: the C API's calls, strides, dtypes
and every refusal as ffseg.Error."""
import numpy as np
import pytest

from conftest import affine, ball

import ffseg


def grow(e, max_steps=100):
    for s in range(max_steps):
        if e.step():
            return s + 1
    return max_steps


def binary_run(vol, A, centre, radius, n=8):
    return ffseg.segment(vol, A, [(centre, radius)], target_mode="binary", mesh_resolution=n)[0]


def test_version_and_library():
    assert ffseg.version()[0] == 0
    assert ffseg.library_path.endswith(".so.0") or "libffseg" in ffseg.library_path


def test_binary_ball_grows_to_its_border_and_steps_report_stage_times():
    vol = ball()
    truth = ball(inside=1, outside=0)
    with ffseg.Engine(max_objects=1, mesh_resolution=10) as e:
        e.set_params(target_mode="binary", step_size=0.5)
        assert e.params["target_mode"] == ffseg.TARGET_BINARY and e.params["step_size"] == 0.5
        e.set_volume(vol, affine())
        e.init_sphere(0, (20.0, 17.0, 15.5), 3.0)
        assert not e.step()
        info = e.last_step_info
        assert info.step_index == 1
        assert set(info.stage_us) == set(ffseg.STAGE_NAMES)
        assert sum(info.stage_us.values()) > 0
        assert info.mean_displacement_mm[0] > 0.1 and info.vertices_with_target[0] > 0
        steps = 1 + grow(e)
        assert e.last_step_info.step_index == steps
        verts, tris = e.extract_mesh(0)
        assert verts.dtype == np.float32 and verts.shape[1] == 3 and len(verts) > 500
        assert tris.dtype == np.uint32 and tris.shape[1] == 3 and tris.max() < len(verts)
        r = np.linalg.norm(verts - np.array([20.0, 17.0, 15.5], np.float32), axis=1)
        assert abs(r.mean() - 9.0) < 1.0
        mask = e.rasterize(0)
    assert mask.shape == vol.shape and mask.dtype == np.uint8
    inter = np.logical_and(mask, truth).sum()
    dice = 2 * inter / (mask.sum() + truth.sum())
    assert dice > 0.9


def test_every_dtype_and_layout_gives_the_same_mask():
    base = ball()
    A = affine((1.0, 1.1, 0.9), (-5.0, 3.0, 2.0))
    centre = tuple((A @ np.array([20.0, 17.0, 15.5, 1.0]))[:3])
    ref = binary_run(base, A, centre, 3.0)
    assert 2000 < ref.sum() < 4500  # the ball: 4/3 pi 9^3 = 3054 voxels
    for dt in (np.int16, np.uint16, np.int32, np.float32, np.float64):
        assert np.array_equal(binary_run(base.astype(dt), A, centre, 3.0), ref), dt
    # Fortran order, a padded (sliced) view, a transposed copy read back in i, j, k order.
    assert np.array_equal(binary_run(np.asfortranarray(base), A, centre, 3.0), ref)
    padded = np.zeros((base.shape[0] * 2, base.shape[1], base.shape[2] + 3), np.uint8)
    padded[::2, :, 1:-2] = base
    assert np.array_equal(binary_run(padded[::2, :, 1:-2], A, centre, 3.0), ref)
    # Unaligned: int16 voxels at an odd byte address.
    raw = np.zeros(base.size * 2 + 1, np.uint8)
    odd = np.ndarray(base.shape, np.int16, raw, 1,
                     (2 * base.shape[1] * base.shape[2], 2 * base.shape[2], 2))
    odd[...] = base
    assert not odd.flags.aligned
    assert np.array_equal(binary_run(odd, A, centre, 3.0), ref)


def test_negative_strides_are_read_through_their_affine():
    vol = ball(centre=(12.0, 17.0, 15.5))
    A = affine()
    ref = binary_run(vol, A, (12.0, 17.0, 15.5), 3.0)
    # The same voxels with i reversed: a view (negative stride) and an affine
    # that maps the new index i' = 39 - i to the same place.
    flipped = vol[::-1]
    assert flipped.strides[0] < 0
    B = A.copy()
    B[0, 0], B[0, 3] = -1.0, 39.0
    got = binary_run(flipped, B, (12.0, 17.0, 15.5), 3.0)
    assert np.array_equal(got[::-1], ref)
    # A copy in memory gives the same too.
    assert np.array_equal(binary_run(np.ascontiguousarray(flipped), B, (12.0, 17.0, 15.5), 3.0), got)


def test_the_engine_keeps_the_array_alive():
    with ffseg.Engine(mesh_resolution=6) as e:
        e.set_params(target_mode="binary")
        e.set_volume(ball(), affine())  # no other reference to the array
        import gc
        gc.collect()
        e.init_sphere(0, (20, 17, 15.5), 3)
        grow(e)
        assert e.rasterize(0).sum() > 1000


def test_rasterize_into_a_strided_output():
    vol = ball()
    with ffseg.Engine(mesh_resolution=8) as e:
        e.set_params(target_mode="binary")
        e.set_volume(vol, affine())
        e.init_sphere(0, (20, 17, 15.5), 3)
        grow(e)
        ref = e.rasterize(0)
        out = np.zeros(vol.shape[::-1], np.uint8).T  # Fortran-like strides
        assert e.rasterize(0, out=out) is out
        assert np.array_equal(out, ref)
        with pytest.raises(ffseg.Error, match="uint8"):
            e.rasterize(0, out=np.zeros(vol.shape, np.int16))


def test_refusals_raise_ffseg_error_with_status_and_message():
    vol = ball()
    e = ffseg.Engine(mesh_resolution=6)
    with pytest.raises(ffseg.Error) as ex:
        e.init_sphere(0, (1, 2, 3), 2.0)  # no volume yet
    assert ex.value.status == -8 and ex.value.name == "MISUSE" and ex.value.message
    with pytest.raises(ffseg.Error) as ex:
        e.set_params(step_size=2.0)
    assert ex.value.status == -1 and "step_size" in str(ex.value)
    assert e.params["step_size"] == 0.5  # unchanged
    with pytest.raises(ffseg.Error, match="unknown parameter 'stepsize'"):
        e.set_params(stepsize=0.3)
    with pytest.raises(ffseg.Error, match="target_mode"):
        e.set_params(target_mode="levelset")
    with pytest.raises(ffseg.Error, match="diffusion_iterations"):
        e.set_params(diffusion_iterations=2.5)
    # grey_respacing: 0 (automatic, the default since 0.8.0), 1 always, 2
    # never; 3 refused by name.
    assert e.params["grey_respacing"] == 0
    e.set_params(grey_respacing=1)
    assert e.params["grey_respacing"] == 1
    e.set_params(grey_respacing=2)
    assert e.params["grey_respacing"] == 2
    with pytest.raises(ffseg.Error, match="grey_respacing"):
        e.set_params(grey_respacing=3)
    with pytest.raises(ValueError, match="unsupported voxel dtype int8"):
        e.set_volume(vol.astype(np.int8), affine())
    with pytest.raises(ValueError, match="unsupported voxel dtype bool"):
        e.set_volume(vol > 0, affine())
    with pytest.raises(ValueError, match="native byte order"):
        e.set_volume(vol.astype(">i2"), affine())
    with pytest.raises(ValueError, match="3-D"):
        e.set_volume(vol[:, :, 0], affine())
    with pytest.raises(ValueError, match="4x4"):
        e.set_volume(vol, np.eye(3))
    with pytest.raises(ffseg.VolumeError, match="numpy.ndarray") as ex:
        e.set_volume(vol.tolist(), affine())
    assert ex.value.status == -5 and isinstance(ex.value, ffseg.Error)
    # Overlapping voxels (a broadcast view) and a singular affine: the engine's checks.
    with pytest.raises(ffseg.Error) as ex:
        e.set_volume(np.broadcast_to(vol[:1], vol.shape), affine())
    assert ex.value.status == -5 and isinstance(ex.value, ffseg.VolumeError)
    with pytest.raises(ffseg.Error) as ex:
        e.set_volume(vol, np.diag([1.0, 0.0, 1.0, 1.0]))
    assert ex.value.status == -5 and ex.value.message
    with pytest.raises(ffseg.Error) as ex:
        e.set_volume(vol, affine(), rescale_slope=0.0)
    assert ex.value.status == -5
    e.set_volume(vol, affine())
    with pytest.raises(ffseg.Error) as ex:
        e.init_sphere(0, (500, 500, 500), 2.0)
    assert ex.value.name == "SPHERE_OUTSIDE"
    with pytest.raises(ffseg.Error) as ex:
        e.init_sphere(1, (20, 17, 15), 2.0)
    assert ex.value.name == "OBJECT_OUT_OF_RANGE"
    with pytest.raises(ffseg.Error) as ex:
        e.step()  # no object placed
    assert ex.value.name == "MISUSE"
    with pytest.raises(ffseg.Error) as ex:
        ffseg.Engine(mesh_resolution=1)
    assert ex.value.status == -1 and "mesh_resolution" in ex.value.message
    e.close()
    with pytest.raises(ffseg.Error, match="closed"):
        e.step()


def test_segment_several_objects_and_intensity_target():
    vol = ball(shape=(48, 32, 32), centre=(12.0, 16.0, 16.0), radius=7.0, outside=20, noise=4.0)
    second = ball(shape=(48, 32, 32), centre=(35.0, 16.0, 16.0), radius=6.0, inside=140, outside=0)
    vol = np.maximum(vol, second)
    masks, meshes = ffseg.segment(vol, affine(), [((12, 16, 16), 3.0), ((35, 16, 16), 3.0)],
                                  target_mode="intensity", mesh_resolution=8, max_steps=80,
                                  return_meshes=True)
    assert len(masks) == 2 and len(meshes) == 2
    for m, c, r in zip(masks, (12, 35), (7.0, 6.0)):
        vox = m.sum()
        assert 0.6 * (4 / 3) * np.pi * r ** 3 < vox < 1.4 * (4 / 3) * np.pi * r ** 3
        ii = np.nonzero(m)[0]
        assert abs(ii.mean() - c) < 1.0
    assert not np.logical_and(*masks).any()


def test_a_run_that_finds_nothing_is_degenerate_not_converged():
    empty = np.zeros((24, 24, 24), dtype=np.uint8)
    with ffseg.Engine(max_objects=1, mesh_resolution=6) as e:
        e.set_params(target_mode="binary")
        e.set_volume(empty, affine())
        e.init_sphere(0, (12.0, 12.0, 12.0), 4.0)
        grow(e)
        assert e.last_status == ffseg.DEGENERATE
        assert e.last_step_info.object_flags == [ffseg.OBJECT_NO_BOUNDARY]
        assert e.last_step_info.flags_all == ffseg.OBJECT_NO_BOUNDARY
    with pytest.warns(RuntimeWarning, match="no segmentation"):
        binary_run(empty, affine(), (12, 12, 12), 4.0, n=6)
    # The ball from inside: converged, no flag, no warning.
    with ffseg.Engine(max_objects=1, mesh_resolution=8) as e:
        e.set_params(target_mode="binary")
        e.set_volume(ball(), affine())
        e.init_sphere(0, (20.0, 17.0, 15.5), 3.0)
        grow(e)
        assert e.last_status == ffseg.CONVERGED
        assert e.last_step_info.flags_all == 0


@pytest.mark.parametrize("max_region_voxels", [None, 256])
def test_region_mask_of_two_objects_in_one_bar(max_region_voxels):
    # A binary bar along i with one sphere near each end: after a step the two
    # bounding regions split the bar, never share a voxel, and each holds its
    # own mesh's voxels; on voxels, and on cells of 3 voxels when 256 cannot
    # hold a region's box (max_region_voxels, 0.6.0).
    vol = np.zeros((40, 12, 12), np.uint8)
    vol[4:36, 3:9, 3:9] = 1
    with ffseg.Engine(max_objects=2, mesh_resolution=6, max_region_voxels=max_region_voxels) as e:
        assert e.config["max_region_voxels"] == (max_region_voxels or 0)
        e.set_params(target_mode="binary")
        e.set_volume(vol, affine())
        e.init_sphere(0, (10.0, 5.5, 5.5), 2.0)
        e.init_sphere(1, (29.0, 5.5, 5.5), 2.0)
        with pytest.raises(ffseg.Error) as err:
            e.region_mask(0)  # no step yet: no region
        assert err.value.status == -8 and "no bounding region yet" in str(err.value)
        for _ in range(3):
            e.step()
        r0, r1 = e.region_mask(0), e.region_mask(1)
        m0, m1 = e.rasterize(0), e.rasterize(1)
        out = np.zeros((12, 12, 40), np.uint8).transpose(2, 1, 0)
        assert e.region_mask(1, out=out) is out and np.array_equal(out, r1)
    assert r0.shape == vol.shape and r0.dtype == np.uint8
    assert r0.sum() > 0 and r1.sum() > 0
    assert not np.logical_and(r0, r1).any()
    assert np.all(r0[m0 > 0]) and np.all(r1[m1 > 0])
    with ffseg.Engine(max_objects=1, mesh_resolution=6) as e:
        e.set_volume(vol, affine())
        e.init_sphere(0, (10.0, 5.5, 5.5), 2.0)
        e.step()
        with pytest.raises(ffseg.Error) as err:
            e.region_mask(0)
        assert err.value.status == -8 and "one-object engine" in str(err.value)


def _dice(a, b):
    return 2 * np.logical_and(a, b).sum() / (a.sum() + b.sum())


def test_a_mesh_grown_at_12_goes_on_at_24_through_init_mesh():
    # The Rust and C# bindings' coarse-to-fine test, through ctypes: the fine
    # engine starts on the coarse surface and neither Dice nor the voxel
    # count drops (measured Dice 0.9948 -> 0.9998, 11392 -> 11503 of 11507).
    centre, r = (24.3, 23.8, 24.2), 14.0
    truth = ball((48, 48, 48), centre, r, inside=1)
    with ffseg.Engine(max_objects=1, mesh_resolution=12) as e:
        e.set_params(target_mode="binary")
        e.set_volume(truth, affine())
        e.init_sphere(0, centre, 5.0)
        grow(e, 300)
        assert e.last_status == ffseg.CONVERGED
        m12 = e.rasterize(0)
        v12, _ = e.extract_mesh(0)
    assert v12.shape == (6 * 12 * 12, 3)
    with ffseg.Engine(max_objects=1, mesh_resolution=24) as e:
        e.set_params(target_mode="binary")
        e.set_volume(truth, affine())
        e.init_mesh(0, centre, 5.0, v12)
        start, _ = e.extract_mesh(0)
        assert start.shape == (6 * 24 * 24, 3)
        assert np.linalg.norm(start - np.array(centre, np.float32), axis=1).min() > r - 2
        # One vertex short of 6 n^2: refused by the library, the mesh kept.
        with pytest.raises(ffseg.Error, match="6 n"):
            e.init_mesh(0, centre, 5.0, v12[1:])
        assert np.array_equal(e.extract_mesh(0)[0], start)
        with pytest.raises(ffseg.Error):
            e.init_mesh(0, centre, 5.0, v12.reshape(-1)[:-1].reshape(-1, 1))  # not (N, 3)
        grow(e, 300)
        assert e.last_status == ffseg.CONVERGED and e.last_step_info.flags_all == 0
        m24 = e.rasterize(0)
    d12, d24 = _dice(m12, truth), _dice(m24, truth)
    assert d24 >= d12 and d24 > 0.99, (d12, d24)
    assert m24.sum() >= m12.sum()


def test_a_forced_stall_is_degenerate_and_flagged_stalled():
    # A Laplacian weight a million times the positional one holds a 5 mm
    # sphere nearly still inside a ball of 20: at rest with every target far
    # outward, which is no convergence. Default weights converge unflagged.
    centre = (32.0, 32.0, 32.0)
    b = ball((64, 64, 64), centre, 20.0, inside=1)
    nv = 6 * 12 * 12
    for held in (True, False):
        with ffseg.Engine(max_objects=1, mesh_resolution=12) as e:
            if held:
                e.set_params(target_mode="binary", lambda_position=1e-6, lambda_laplacian=1e6)
            else:
                e.set_params(target_mode="binary")
            e.set_volume(b, affine())
            e.init_sphere(0, centre, 5.0)
            grow(e, 200)
            info, mask = e.last_step_info, e.rasterize(0)
            if held:
                assert e.last_status == ffseg.DEGENERATE
                assert info.object_flags == [ffseg.OBJECT_STALLED]
                assert info.flags_all == ffseg.OBJECT_STALLED
                assert info.far_outward[0] > 0.9 * nv
                assert mask.sum() < b.sum() / 10
            else:
                assert e.last_status == ffseg.CONVERGED
                assert info.object_flags == [0]
                assert info.far_outward[0] + info.far_inward[0] < 0.05 * nv


def test_a_small_ball_of_its_own_contrast_grows_freely_by_default_and_the_step_says_so():
    # Grey levels: the ball's boundary is in view of the box around the
    # sphere (its level is rare there and no other class overlaps it), so by
    # default its loops are re-spaced while it grows; never with 2, always
    # with 1 (a ball filling its box, below, is not in view).
    centre = (32.0, 32.0, 32.0)
    small = ball((64, 64, 64), centre, 6.0, dtype=np.float32, inside=100, outside=0, noise=10.0)
    filled = ball((64, 64, 64), centre, 40.0, dtype=np.float32, inside=100, outside=0, noise=10.0)
    for vol, mode, expect in ((small, 0, 1), (small, 2, 0), (filled, 0, 0), (filled, 1, 1)):
        with ffseg.Engine(max_objects=1, mesh_resolution=12) as e:
            e.set_params(target_mode="intensity", grey_respacing=mode)
            e.set_volume(vol, affine())
            e.init_sphere(0, centre, 3.0)
            e.step()
            assert e.last_step_info.respaced == [expect], (vol is small, mode)


def test_workspace_sizing_follows_the_tool():
    # Issue 30: five organs on the abdominal CT resampled to 1 mm fit the
    # tool's 400 MB (2.4 GB with every crop and region the whole scan); the
    # 3 mm scan keeps crops and regions of the whole scan.
    fine, coarse = 366 * 303 * 336, 122 * 101 * 112
    roi, region, nbytes = ffseg.workspace_sizing(5, 49, fine)
    assert nbytes <= 400 * 10**6
    assert roi >= 7766280 and region * 8 >= 3741390  # the liver's largest crop and region box there
    with ffseg.Engine(max_objects=5, mesh_resolution=12, max_roi_voxels=1 << 16, max_region_voxels=1 << 12) as e:
        assert e.config["max_region_voxels"] == 1 << 12
    assert ffseg.workspace_sizing(5, 23, coarse) [:2] == (coarse, coarse)
    roi, region, nbytes = ffseg.workspace_sizing(5, 49, fine, max_roi_voxels=fine, max_region_voxels=fine)
    assert (roi, region) == (fine, fine) and nbytes > 400 * 10**6
