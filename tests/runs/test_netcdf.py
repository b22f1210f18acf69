"""posterior.nc written by h5netcdf directly (runs/netcdf.py) holds what ArviZ writes."""

from __future__ import annotations

import numpy as np
import xarray as xr

from bayes_dnlr.runs.netcdf import PosteriorDraws
from bayes_dnlr.runs.outputs import _netcdf_bytes, build_datatree


def test_same_content_as_the_arviz_file(tmp_path) -> None:
    rng = np.random.default_rng(0)
    names = ["E", "G", "tau_max", "sigma0[a]"]
    draws = rng.normal(size=(40, 12, 4))
    draws[3, 2, 1] = np.nan
    lp = rng.normal(size=(40, 12))
    attrs = {"burn_in": 43, "stop_reason": "converged", "walkers": 12, "moves": "de",
             "sampling_coordinates": '{"E": "linear"}', "layout": {"a": [1, 2]}, "skipped": None}
    (tmp_path / "ours.nc").write_bytes(PosteriorDraws(names, draws, lp, attrs).to_netcdf())
    (tmp_path / "arviz.nc").write_bytes(_netcdf_bytes(build_datatree(names, draws, lp, attrs)))
    ours = xr.open_datatree(tmp_path / "ours.nc").load()
    ref = xr.open_datatree(tmp_path / "arviz.nc").load()
    assert set(ours.children) == set(ref.children) == {"posterior", "sample_stats"}
    for g in ("posterior", "sample_stats"):
        a, b = ours[g].to_dataset(), ref[g].to_dataset()
        xr.testing.assert_identical(a.drop_attrs(), b.drop_attrs())   # values, dims, coords
        for v in b.variables:
            assert a[v].attrs == b[v].attrs, v                         # units
            fill = [np.isnan(x[v].encoding.get("_FillValue", 0.0)) for x in (a, b)]
            assert fill[0] == fill[1], v                               # NaN fill on the floats
        for k, v in b.attrs.items():
            if k not in ("created_at", "creation_library", "creation_library_version"):
                assert np.all(np.asarray(a.attrs[k]) == np.asarray(v)), k
        assert set(a.attrs) == set(b.attrs)
    assert ours["posterior"]["E"].dims == ("chain", "draw")
    assert ours["posterior"]["tau_max"].attrs["units"] == "s"
    np.testing.assert_array_equal(ours["posterior"]["G"].values, draws[:, :, 1].T)
