"""posterior.nc written by h5py directly (runs/netcdf.py) holds what ArviZ writes, and both files
read back by netCDF-4's conventions (runs/results.py), without xarray."""

from __future__ import annotations

import numpy as np
import xarray as xr

from bayes_dnlr.runs import results
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


# ---------------------------------------------------------------- read back (runs/results.py)

def _draws(seed: int = 1) -> tuple[list[str], np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    draws = rng.normal(size=(30, 6, 3))
    draws[4, 1, 2] = np.nan
    return ["E", "G", "sigma0[b]"], draws, rng.normal(size=(30, 6))


def _h5_only(monkeypatch) -> None:
    """read_draws may not fall back on xarray."""
    def refused(*args, **kwargs):
        raise AssertionError("read through xarray")

    monkeypatch.setattr(results, "_read_draws_xarray", refused)


def test_ours_and_arvizs_file_read_back_by_netcdf_conventions(tmp_path, monkeypatch) -> None:
    names, draws, lp = _draws()
    (tmp_path / "ours.nc").write_bytes(PosteriorDraws(names, draws, lp, {"burn_in": 3}).to_netcdf())
    (tmp_path / "arviz.nc").write_bytes(_netcdf_bytes(build_datatree(names, draws, lp)))
    _h5_only(monkeypatch)
    for file in ("ours.nc", "arviz.nc"):
        got = results.read_draws(tmp_path / file)
        assert list(got) == names, file                        # in the file's order, no coordinate
        for j, k in enumerate(names):
            np.testing.assert_array_equal(got[k], draws[:, :, j].T)   # (chain, draw), NaN kept
        assert list(results.read_draws(tmp_path / file, ["G"])) == ["G"]


def test_draw_chain_order_and_a_finite_fill_value(tmp_path, monkeypatch) -> None:
    names, draws, lp = _draws(2)
    tree = build_datatree(names, draws, lp)
    post = tree["posterior"].to_dataset().transpose("draw", "chain")
    post["E"].encoding["_FillValue"] = -999.0
    data = draws[:, :, 0].copy()
    post["E"].values[:] = data                  # (draw, chain), a NaN written as -999
    post.to_netcdf(tmp_path / "t.nc", group="posterior", engine="h5netcdf")
    _h5_only(monkeypatch)
    got = results.read_draws(tmp_path / "t.nc")
    np.testing.assert_array_equal(got["E"], data.T)
    assert np.isnan(got["sigma0[b]"][1, 4])


def test_a_packed_variable_goes_through_xarray(tmp_path) -> None:
    names, draws, lp = _draws(3)
    post = build_datatree(names, draws, lp)["posterior"].to_dataset()
    post["G"].encoding.update(scale_factor=0.5, dtype="int32", _FillValue=-32768)
    post.to_netcdf(tmp_path / "t.nc", group="posterior", engine="h5netcdf")
    assert results._read_draws_h5(tmp_path / "t.nc", None) == {}
    got = results.read_draws(tmp_path / "t.nc")
    np.testing.assert_allclose(got["G"], np.round(draws[:, :, 1].T / 0.5) * 0.5, equal_nan=True)


def test_a_boolean_attribute_is_written_as_0_or_1(tmp_path) -> None:
    """netCDF has no boolean type (h5netcdf refused one): True is written as the integer 1."""
    names, draws, lp = _draws(4)
    (tmp_path / "t.nc").write_bytes(PosteriorDraws(names, draws, lp, {"converged": True,
                                                                      "stopped": False}).to_netcdf())
    attrs = xr.open_datatree(tmp_path / "t.nc")["posterior"].attrs
    assert (int(np.ravel(attrs["converged"])[0]), int(np.ravel(attrs["stopped"])[0])) == (1, 0)
