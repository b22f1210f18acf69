"""`fit` and `sample` import no plotting and none of the heavy modules they do not use, `report`
not the fitting code: each command runs in a fresh process, then the process lists what it
imported."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from support.sampling import write_case

HEAVY = ("matplotlib", "arviz", "arviz_plots", "arviz_stats", "scipy.stats", "distributed", "corner",
         "xarray", "pandas", "scipy.optimize", "scipy.special")
FIT_NEEDS = ("scipy.optimize", "scipy.special")     # the fit optimises; sample reads fit.json
# what a report of a finished run does not use: the fitting code, the sampler, ArviZ
NOT_IN_REPORT = ("bayes_dnlr.inference.lsq.run_fit", "bayes_dnlr.inference.lsq.optimize",
                 "scipy.optimize", "emcee", "arviz", "xarray")
RUN = ("import json, sys\n"
       "from bayes_dnlr.cli import main\n"
       "status = main(sys.argv[1:])\n"
       "print(json.dumps({'status': status, 'emcee': 'emcee' in sys.modules,\n"
       "                  'heavy': sorted(m for m in HEAVY if m in sys.modules)}))\n")


def _run(*args: str, heavy: tuple[str, ...] = HEAVY) -> dict:
    out = subprocess.run([sys.executable, "-c", f"HEAVY = {heavy!r}\n" + RUN, *args],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("discrepancy", ["none", "default"])
def test_fit_and_sample_import_no_plotting(tmp_path, discrepancy) -> None:
    error = ("exp", 0.5, 20.0) if discrepancy == "default" else None
    cfg = write_case(tmp_path, n=400, discrepancy=discrepancy, error=error,
                     sampler={"max_steps": 60, "target_ess": 50, "checkpoint_every": 30})
    fit = _run("fit", str(cfg), "--quiet")
    assert fit["status"] == 0 and set(fit["heavy"]) <= set(FIT_NEEDS)
    sample = _run("sample", str(cfg), "--quiet")
    assert sample["status"] == 0 and sample["emcee"]     # it did sample
    assert sample["heavy"] == []
    assert (cfg.parent / "posterior.nc").is_file()
    summary = json.loads((cfg.parent / "summary.json").read_text())
    assert summary["noise"]["model"] == ("white" if discrepancy == "none" else "discrepancy")
    report = _run("report", str(cfg.parent), heavy=NOT_IN_REPORT)
    assert report["status"] == 0 and (cfg.parent / "report.html").is_file()
    assert report["heavy"] == []


def test_emcee_without_scipy_stats_keeps_every_move() -> None:
    code = ("import sys\n"
            "from bayes_dnlr.inference.mcmc.emcee_import import load_emcee\n"
            "emcee = load_emcee()\n"
            "assert 'scipy.stats' not in sys.modules\n"
            "emcee.moves.DEMove(); emcee.moves.StretchMove()\n"
            "from emcee.moves import KDEMove\n"
            "assert 'scipy.stats' in sys.modules and KDEMove.__module__ == 'emcee.moves.kde'\n"
            "import emcee.moves.kde as kde\n"
            "assert kde.KDEMove is KDEMove is emcee.moves.KDEMove\n"
            "KDEMove()\n"
            "print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "ok", out.stderr
