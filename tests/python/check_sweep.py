"""Checks a `stickslip sweep` HDF5 file with h5py and xarray (engine h5netcdf).

Usage: python3 check_sweep.py FILE.h5 DIM1,DIM2,... N1,N2,...
Exits non-zero on any mismatch.
"""
import sys

import h5py
import numpy as np
import xarray as xr

path, dims, sizes = sys.argv[1], sys.argv[2].split(","), [int(x) for x in sys.argv[3].split(",")]
shape = tuple(sizes)
with h5py.File(path, "r") as f:
    assert f.attrs["sweep_status"] == "complete", f.attrs["sweep_status"]
    assert int(f.attrs["complete"]) == 1
    assert "[[axis]]" in f.attrs["sweep_file"]
    assert f.attrs["program"].startswith("stickslip")
    for key in ("started", "finished"):
        assert len(f.attrs[key]) == 20 and f.attrs[key].endswith("Z"), f.attrs[key]
    assert f.attrs["dims"] == ",".join(dims)
    names = ["r", "r_stderr", "dF", "dF_stderr", "dF_reference", "mean_force", "stick_fraction", "period",
             "peak_force", "trough_force", "cycles", "status", "steps", "rejected", "rhs_evals", "jac_evals",
             "lu_decomps", "wall_time", "u0_grid", "v_a_grid"]
    units = {"r": "1", "dF": "N", "mean_force": "N", "period": "s", "wall_time": "s", "u0_grid": "m", "v_a_grid": "m/s"}
    for n in names:
        ds = f[n]
        assert ds.shape == shape, (n, ds.shape, shape)
        if n in units:
            assert ds.attrs["units"] == units[n], (n, ds.attrs["units"])
        # Every dimension carries its coordinate as a dimension scale.
        for k, d in enumerate(dims):
            assert ds.dims[k][0].name == "/" + d, (n, k, ds.dims[k][0].name)
    for d, n in zip(dims, sizes):
        assert f[d].shape == (n,), (d, f[d].shape)
        assert np.all(np.isfinite(f[d][:]))
    status = f["status"][:]
    r = f["r"][:]
    computed = f["computed"][:]
    assert f["computed"].shape == shape
    if "refine_measure" in f.attrs:
        # A refinement runs some points of its dense grid: the others are NaN and not run.
        done = computed == 1
        assert 0 < done.sum() < done.size, done.sum()
        assert np.all(status[done] >= 0) and np.all(status[~done] == -1)
        assert np.all(np.isnan(r[~done])) and np.all(np.isnan(f["dF"][:][~done]))
        # The coarse grid, every 2^levels-th value along the refined axis, is complete.
        along = dims.index(f.attrs["refine_along"])
        stride = 2 ** int(f.attrs["refine_levels"])
        coarse = np.take(done, np.arange(0, shape[along], stride), axis=along)
        assert coarse.all() and coarse.shape[along] == int(f.attrs["refine_coarse"])
    else:
        assert np.all(status >= 0), "every point ran"
        assert np.all(computed == 1)
    ok = status == 0
    assert np.all(np.isfinite(r[ok])) and np.all(r[ok] >= 0), r
    # r is dF over the reference's dF wherever both ran.
    assert np.allclose(r[ok], (f["dF"][:] / f["dF_reference"][:])[ok], rtol=1e-12)
    # u0 and v_a per point agree: v_a = 2 pi f u0.
    if "f" in dims:
        fk = dims.index("f")
        fv = f["f"][:].reshape([-1 if k == fk else 1 for k in range(len(dims))])
        assert np.allclose(f["v_a_grid"][:], 2 * np.pi * fv * f["u0_grid"][:], rtol=1e-12)

ds = xr.open_dataset(path, engine="h5netcdf")
assert tuple(ds["r"].dims) == tuple(dims), ds["r"].dims
for d, n in zip(dims, sizes):
    assert d in ds.coords and ds.coords[d].size == n, (d, list(ds.coords))
assert ds["r"].shape == shape
sel = ds["r"].isel({d: 0 for d in dims})
assert float(sel) == float(ds["r"].values[(0,) * len(dims)])
print("ok", path, ds["r"].dims, ds["r"].shape)
