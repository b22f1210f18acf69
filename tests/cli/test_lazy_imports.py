"""`fit` and `sample` import no plotting and none of the heavy modules they do not use, `report`
neither the fitting code nor numba: each command runs in a fresh process (for both noise models, one after the
other), then the process lists what it imported."""

from __future__ import annotations

import json
import subprocess
import sys

from support.sampling import write_case

HEAVY = ("matplotlib", "arviz", "arviz_plots", "arviz_stats", "scipy.stats", "distributed", "corner",
         "xarray", "pandas", "scipy.optimize", "scipy.special")
FIT_NEEDS = ("scipy.optimize", "scipy.special")     # the fit optimises; sample reads fit.json
# what a report of a finished run does not use: the fitting code, the sampler, ArviZ, and no
# compiled code at all: `sample` keeps the curves the report draws (runs/curve_cache.py), and
# loading numba cost every report about a second
NOT_IN_REPORT = ("bayes_dnlr.inference.lsq.run_fit", "bayes_dnlr.inference.lsq.optimize",
                 "scipy.optimize", "emcee", "arviz", "xarray", "numba", "pandas")
# the commands given run one after the other in one fresh process, which then lists what it imported:
# the union of what each command imported
RUN = ("import json, sys\n"
       "from bayes_dnlr.cli import main\n"
       "status = [main(args) for args in json.loads(sys.argv[1])]\n"
       "print(json.dumps({'status': status, 'emcee': 'emcee' in sys.modules,\n"
       "                  'heavy': sorted(m for m in HEAVY if m in sys.modules)}))\n")


def _run(*commands: list[str], heavy: tuple[str, ...] = HEAVY) -> dict:
    out = subprocess.run([sys.executable, "-c", f"HEAVY = {heavy!r}\n" + RUN, json.dumps(commands)],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_fit_and_sample_import_no_plotting(tmp_path) -> None:
    """Both noise models, white (discrepancy: none) and the default discrepancy, in one fresh process
    per command (fit, sample, report), each command run for both configs there: what the process
    imported is what either did, so a heavy module imported by one of them is found (one process
    per command and config cost 6 more interpreters' imports, 13 s of CPU)."""
    configs = {}
    for discrepancy in ("none", "default"):
        error = ("exp", 0.5, 20.0) if discrepancy == "default" else None
        configs[discrepancy] = write_case(tmp_path, discrepancy, n=400, discrepancy=discrepancy,
                                          error=error, sampler={"max_steps": 60, "target_ess": 50,
                                                                "checkpoint_every": 30})
    fit = _run(*(["fit", str(cfg), "--quiet"] for cfg in configs.values()))
    assert fit["status"] == [0, 0] and set(fit["heavy"]) <= set(FIT_NEEDS)
    sample = _run(*(["sample", str(cfg), "--quiet"] for cfg in configs.values()))
    assert sample["status"] == [0, 0] and sample["emcee"]     # it did sample
    assert sample["heavy"] == []
    for discrepancy, cfg in configs.items():
        assert (cfg.parent / "posterior.nc").is_file()
        summary = json.loads((cfg.parent / "summary.json").read_text())
        assert summary["noise"]["model"] == ("white" if discrepancy == "none" else "discrepancy")
    report = _run(*(["report", str(cfg.parent)] for cfg in configs.values()), heavy=NOT_IN_REPORT)
    assert report["status"] == [0, 0]
    assert all((cfg.parent / "report.html").is_file() for cfg in configs.values())
    assert report["heavy"] == []


def test_a_config_error_is_printed_before_the_model_is_imported(tmp_path) -> None:
    """`simulate`, `fit` and `sample` read the config first: a mistake in it is a one-line error
    before numba, scipy's optimisers or the command's own modules are imported."""
    config = tmp_path / "config.yaml"
    config.write_text("name: t\ndata:\n  file: x.csv\n  columns: {time: t, force: F, eps11: e}\n"
                      "  area0: 24\n  strain_mx: 2\n")
    out = _run(*([command, str(config)] for command in ("simulate", "fit", "sample")),
               heavy=("numba", "scipy.optimize", "bayes_dnlr.workflows.simulate",
                      "bayes_dnlr.runs.fit", "bayes_dnlr.runs.sample"))
    assert out["status"] == [2, 2, 2] and not out["emcee"]
    assert out["heavy"] == []


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
