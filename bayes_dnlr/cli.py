"""The command line: parse, call, print. No logic lives here.

    python -m bayes_dnlr simulate runs/hdpe-a-5e-3/config.yaml
    python -m bayes_dnlr fit      runs/hdpe-a-5e-3/config.yaml
    python -m bayes_dnlr sample   runs/hdpe-a-5e-3/config.yaml
    python -m bayes_dnlr report   runs/hdpe-a-5e-3
    python -m bayes_dnlr compare  runs/hdpe-a-*
    python -m bayes_dnlr design   design.yaml
    python -m bayes_dnlr export   runs/hdpe-a-5e-3 --format abaqus --nu 0.45
    python -m bayes_dnlr batch    runs/*/config.yaml [--scheduler tcp://host:8786]

Heavy modules are imported inside each command so that ``--help`` stays instant.
"""

from __future__ import annotations

import argparse
import atexit
import os
import sys
import threading
from pathlib import Path
from typing import NoReturn

from bayes_dnlr import __version__
from bayes_dnlr.errors import BayesDnlrError


def _positive_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return n


def _config(path: str):
    from bayes_dnlr.config import load_config

    return load_config(path)


def cmd_simulate(args: argparse.Namespace) -> None:
    from bayes_dnlr.synthetic import simulate_test

    print(simulate_test(_config(args.config), overwrite=args.force).summary())


def cmd_fit(args: argparse.Namespace) -> None:
    from bayes_dnlr.pipeline.fit import fit

    result = fit(_config(args.config), overwrite=args.force)
    if not args.quiet:
        print(result.table())


def cmd_sample(args: argparse.Namespace) -> None:
    from bayes_dnlr.pipeline.sample import sample

    post = sample(_config(args.config), restart=args.restart, progress=not args.quiet,
                  threads=args.threads)
    print(post.table())


def cmd_report(args: argparse.Namespace) -> None:
    from bayes_dnlr.report import build_report

    for run_dir in args.run_dirs:
        print(build_report(Path(run_dir)))


def cmd_compare(args: argparse.Namespace) -> None:
    from bayes_dnlr.report.compare import compare_runs

    table = compare_runs([Path(d) for d in args.run_dirs], out_dir=args.out)
    print(table.markdown())


def cmd_design(args: argparse.Namespace) -> None:
    from bayes_dnlr.design.config import load_design
    from bayes_dnlr.report.design import design_with_figure

    print(design_with_figure(load_design(args.design), overwrite=args.force).table(top=args.top))


def cmd_export(args: argparse.Namespace) -> None:
    from bayes_dnlr.export.run import export

    result = export(args.run_dir, args.format, terms=args.terms, draws=args.draws, nu=args.nu,
                    density=args.density, out=args.out, material=args.material, seed=args.seed,
                    force=args.force)
    print(result.table())


def cmd_batch(args: argparse.Namespace) -> int:
    from bayes_dnlr.report.batch import run_campaign

    result = run_campaign(args.inputs, manifest=args.manifest, out=args.out, n_jobs=args.jobs,
                          scheduler=args.scheduler, report=args.report, progress=not args.quiet)
    print(result.summary())
    return 1 if result.failed else 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m bayes_dnlr",
        description="True elastic modulus of polymers from tensile tests (DNLR model, "
                    "least squares and emcee posterior).")
    parser.add_argument("--version", action="version", version=f"bayes_dnlr {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("simulate", help="write a synthetic test CSV from the config's truth: section")
    p.add_argument("config", help="YAML config with a truth: section")
    p.add_argument("--force", action="store_true", help="replace an existing data file")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("fit", help="least squares (LM / Gauss-Newton) and the paper's stochastic "
                                   "analysis; writes fit.json")
    p.add_argument("config")
    p.add_argument("--force", action="store_true",
                   help="replace a fit.json made from another config or data")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=cmd_fit)

    p = sub.add_parser("sample", help="emcee posterior (runs fit first when needed); resumable")
    p.add_argument("config")
    p.add_argument("--restart", action="store_true",
                   help="discard an existing chain (from another config or data) and start again")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--threads", type=_positive_int, default=None, metavar="N",
                   help="threads for the likelihood (default: config sampler.threads, else "
                        "NUMBA_NUM_THREADS / OMP_NUM_THREADS, which also cap N); the chain does "
                        "not depend on it")
    p.set_defaults(func=cmd_sample)

    p = sub.add_parser("report", help="report.html and figures/*.png for a finished run")
    p.add_argument("run_dirs", nargs="+", metavar="run_dir")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("compare", help="Table 3/5-style table across runs (Markdown and CSV)")
    p.add_argument("run_dirs", nargs="+", metavar="run_dir")
    p.add_argument("--out", type=Path, default=None,
                   help="folder for compare.md and compare.csv (default: the folder that holds the runs)")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("design", help="experiment design: predicted sd, Err and correlations of planned "
                                      "tests, and the recommended one")
    p.add_argument("design", help="design.yaml (docs/design.md)")
    p.add_argument("--force", action="store_true", help="replace a design.json made from another design")
    p.add_argument("--top", type=int, default=10, help="candidates shown on the console (default 10)")
    p.set_defaults(func=cmd_design)

    from bayes_dnlr.export import FORMAT_NAMES

    p = sub.add_parser("export", help="FE material cards (the small-strain Prony series) at the posterior "
                                      "median and 5 %%/95 %% quantiles of E, from a finished run")
    p.add_argument("run_dir", help="a finished run directory (summary.json and posterior.nc)")
    p.add_argument("--format", required=True, choices=FORMAT_NAMES)
    p.add_argument("--terms", type=int, default=None,
                   help="refit a shorter series over the test's time range (default: the model's "
                        "N modes; LS-DYNA takes at most 17 plus the long-term term)")
    p.add_argument("--draws", type=int, default=0, help="also K cards from posterior draws (FE ensemble)")
    p.add_argument("--nu", type=float, default=None,
                   help="Poisson's ratio (default: from the data's transverse strain when there is one)")
    p.add_argument("--density", type=float, default=None, help="mass density, kg/m³ (needed by LS-DYNA)")
    p.add_argument("--out", type=Path, default=None, help="folder (default: RUN_DIR/export/FORMAT)")
    p.add_argument("--material", default=None, help="material name in the cards (default: the run's)")
    p.add_argument("--seed", type=int, default=0, help="seed of the --draws choice")
    p.add_argument("--force", action="store_true", help="replace existing, different card files")
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("batch", help="fit, sample and report many tests on all cores or a Dask "
                                     "cluster; resumable; results table and batch page")
    p.add_argument("inputs", nargs="+", metavar="config",
                   help="config files or glob patterns; with --manifest, one template config")
    p.add_argument("--manifest", type=Path, default=None,
                   help="CSV, one row per test; columns are dotted config keys (data.file, "
                        "data.area0, data.window.strain_max, ...) overriding the template")
    p.add_argument("--out", type=Path, default=None,
                   help="folder for results.csv/.parquet, batch.html (and the runs of a manifest); "
                        "default: <configs' common folder>/batch or <manifest folder>/batch-<stem>")
    p.add_argument("--jobs", type=int, default=-1,
                   help="local worker processes, one test each (default: all cores)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster: tcp://host:8786, a scheduler file, or 'config' "
                        "(the Dask config's scheduler-address)")
    p.add_argument("--no-report", dest="report", action="store_false",
                   help="skip the per-test report.html (the batch page is still written)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_batch)
    return parser


def exit_now(status: int) -> NoReturn:
    """End the process with ``status`` once a command has finished, skipping the interpreter's
    finalization: with numba and LLVM loaded, tearing the modules down took 0.2-0.9 s and does
    nothing a finished command needs. The handlers registered with ``atexit`` still run and the
    standard streams are flushed. A normal exit when a non-daemon thread is still running."""
    others = [t for t in threading.enumerate()
              if t is not threading.main_thread() and t.is_alive() and not t.daemon]
    if others:
        sys.exit(status)
    try:
        atexit._run_exitfuncs()
        sys.stdout.flush()
        sys.stderr.flush()
    except BaseException:            # e.g. a closed pipe: leave it to the normal exit
        sys.exit(status)
    os._exit(status)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        status = args.func(args)
    except BayesDnlrError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return status or 0
