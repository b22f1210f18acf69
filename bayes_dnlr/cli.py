"""The command line: parse, call, print. No logic lives here.

    python -m bayes_dnlr init     export.csv --out runs/my-test/config.yaml
    python -m bayes_dnlr simulate runs/hdpe-a-5e-3/config.yaml
    python -m bayes_dnlr fit      runs/hdpe-a-5e-3/config.yaml
    python -m bayes_dnlr sample   runs/hdpe-a-5e-3/config.yaml
    python -m bayes_dnlr report   runs/hdpe-a-5e-3
    python -m bayes_dnlr compare  runs/hdpe-a-*
    python -m bayes_dnlr population runs/population/spec-*
    python -m bayes_dnlr design   design.yaml
    python -m bayes_dnlr export   runs/hdpe-a-5e-3 --format abaqus --nu 0.45
    python -m bayes_dnlr batch    runs/*/config.yaml [--scheduler tcp://host:8786]

Heavy modules are imported inside each command so that ``--help`` stays instant.
"""

from __future__ import annotations

import argparse
import atexit
import errno
import gc
import os
import sys
import threading
import warnings
from pathlib import Path
from typing import NoReturn

from bayes_dnlr import __version__
from bayes_dnlr.errors import BayesDnlrError

INTERRUPTED = 130    # 128 + SIGINT, the shell's convention for Ctrl-C (docs/cli.md)
# file-system errors of the user's environment: one line and exit 2 (a bug raises something else)
USER_ERRNOS = {errno.ENOENT, errno.EISDIR, errno.ENOTDIR, errno.EEXIST, errno.EACCES, errno.EPERM,
               errno.EROFS, errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EFBIG, errno.ENAMETOOLONG,
               errno.ELOOP}



def _positive_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return n

def _shown(path: Path) -> str:
    """A path as the user would type it: relative to the current folder when inside it."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _config(path: str, command: str):
    """The config of a command that starts from one: a config file, or a run folder holding it."""
    from bayes_dnlr.arguments import config_file
    from bayes_dnlr.config import load_config

    return load_config(config_file(path, command))


def _run(path: str, command: str) -> Path:
    """The run folder of a command that reads a run: a run folder, or the config naming it."""
    from bayes_dnlr.arguments import run_folder

    return run_folder(path, command)


# The config is read before the command's own modules are imported: an error in it is printed
# before numba's and scipy's imports (0.55 s from a fresh process instead of 0.9 s).

def cmd_simulate(args: argparse.Namespace) -> None:
    cfg = _config(args.config, "simulate")
    from bayes_dnlr.workflows.simulate import simulate_tests
    from bayes_dnlr.workflows.sweeps import simulate_references

    print("\n".join(r.summary() for r in simulate_tests(cfg, overwrite=args.force)))
    lines = simulate_references(cfg, overwrite=args.force)
    if lines:
        print("\n".join(lines))


def _first_compile_note(quiet: bool) -> None:
    """Before a command that runs the model: say that this machine compiles it first (model/
    compiled.py), rather than leave a minute of silence."""
    if not quiet:
        from bayes_dnlr.model.compiled import announce_first_compile

        announce_first_compile()


def cmd_fit(args: argparse.Namespace) -> None:
    cfg = _config(args.config, "fit")
    from bayes_dnlr.runs.fit import fit, fit_table

    _first_compile_note(args.quiet)
    result = fit(cfg, overwrite=args.force)
    if not args.quiet:
        print(fit_table(result))


def cmd_sample(args: argparse.Namespace) -> None:
    cfg = _config(args.config, "sample")
    from bayes_dnlr.runs.sample import sample

    _first_compile_note(args.quiet)
    post = sample(cfg, restart=args.restart, progress=not args.quiet, threads=args.threads)
    print(post.table())
    if args.report:
        # in this process, as `report RUN_DIR` would: the interpreter, the imports and the
        # config are paid once for both commands (0.7-0.9 s of 8 on a real curve, docs/performance.md)
        if args.ends_process:
            gc.disable()        # one report, then the process ends (see cmd_report)
        _report(cfg.run_dir, cfg.source, force=False)


def _report(run_dir: Path, source: Path | str | None, force: bool) -> None:
    """Build ``run_dir``'s report unless it is current (``force``: build it anyway); print the
    page's path, or why it was not rebuilt."""
    from bayes_dnlr.report import build_report
    from bayes_dnlr.report.current import REPORT_FILE, stale_inputs
    from bayes_dnlr.runs.results import stale_notes

    def warn(note: str) -> None:
        print(f"warning: {note}", file=sys.stderr)

    if not force and stale_inputs(run_dir) == []:
        for note in stale_notes(run_dir, source):
            warn(note)
        print(f"{_shown(run_dir / REPORT_FILE)} is current (newer than its config, data and results): "
              "not rebuilt; report --force rebuilds it")
        return
    print(_shown(build_report(run_dir, source=source, on_stale=warn)))


def cmd_report(args: argparse.Namespace) -> None:
    if args.ends_process and len(args.run_dirs) == 1:
        # one report, then the process ends: the garbage collector's passes cost a first build
        # 0.4-0.5 s of CPU (its figures make millions of objects) to reclaim memory the exit
        # returns anyway (the same peak memory: 360 MB on a real curve). Each further report would
        # leave 77 MB of cycles: with several, or called from Python, the collector stays on.
        gc.disable()
    for arg in args.run_dirs:
        run_dir = _run(arg, "report")
        # the user's config, when given, or when the folder given is the one that holds it
        source = (arg if Path(arg).is_file() else
                  Path(arg) / "config.yaml" if run_dir != Path(arg) else None)
        _report(run_dir, source, force=args.force)


def cmd_compare(args: argparse.Namespace) -> None:
    from bayes_dnlr.report.compare import compare_runs

    table = compare_runs([_run(d, "compare") for d in args.run_dirs], out_dir=args.out)
    print(table.markdown())
    print("outputs: " + ", ".join(_shown(p) for p in table.written))


def cmd_init(args: argparse.Namespace) -> None:
    if args.all:
        from bayes_dnlr.workflows.init_all import init_all

        print(init_all(args.data, args.out).text())
        return
    from bayes_dnlr.workflows.init import init_config

    print(init_config(args.data, args.out).text())


def cmd_population(args: argparse.Namespace) -> None:
    from bayes_dnlr.workflows.population.page import markdown, population_report

    runs = [_run(d, "population") for d in args.run_dirs]
    pr = population_report(runs, parameter=args.parameter, out=args.out, force=args.force)
    print(markdown(pr) + "written: " + ", ".join(str(p) for p in pr.written))


def cmd_design(args: argparse.Namespace) -> None:
    from bayes_dnlr.workflows.design.config import load_design
    from bayes_dnlr.workflows.design.figure import design_with_figure

    print(design_with_figure(load_design(args.design), overwrite=args.force).table(top=args.top))


def cmd_export(args: argparse.Namespace) -> None:
    from bayes_dnlr.workflows.export.run import export

    result = export(_run(args.run_dir, "export"), args.format, terms=args.terms, draws=args.draws,
                    nu=args.nu, density=args.density, out=args.out, material=args.material, seed=args.seed,
                    force=args.force)
    print(result.table())


def cmd_batch(args: argparse.Namespace) -> int:
    from bayes_dnlr.workflows.batch.page import run_campaign
    from bayes_dnlr.workflows.batch.run import check_jobs

    if args.jobs is not None:
        check_jobs(args.jobs)
    result = run_campaign(args.inputs, manifest=args.manifest, out=args.out,
                          n_jobs=args.jobs if args.jobs is not None else -1,
                          scheduler=args.scheduler, report=args.report, progress=not args.quiet,
                          population=args.population, restart=args.restart)
    print(result.summary())
    return 1 if result.failed else 0


EXAMPLE = "runs/hdpe-a-5e-3"


def _command(sub, name: str, text: str, doc: str) -> argparse.ArgumentParser:
    """A subcommand whose help says what it does and ends with its docs page."""
    return sub.add_parser(name, help=text, description=text + ".",
                          epilog=f"More: {doc}; every command: docs/cli.md.")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m bayes_dnlr",
        description="True elastic modulus of polymers from tensile tests (DNLR model, "
                    "least squares and emcee posterior).")
    parser.add_argument("--version", action="version", version=f"bayes_dnlr {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = _command(sub, "init", "a starting config from a test export: columns guessed from the header "
                              "(or the values), units read, and the list of edits to make before fit",
                 "docs/data-input.md")
    p.add_argument("data", help="the test export (CSV or text), e.g. runs/bluehill-like/bluehill-like.csv")
    p.add_argument("--out", type=Path, default=None,
                   help="the config to write (default: runs/<file name>/config.yaml); with --all, the "
                        "folder (default: runs/<file name>); never overwritten")
    p.add_argument("--all", action="store_true",
                   help="a config for every specimen of a file that holds several side by side, and "
                        "the batch manifest that runs them all (specimens.csv), with the material and "
                        "test temperature the file states")
    p.set_defaults(func=cmd_init)

    p = _command(sub, "simulate", "write a synthetic test CSV from the config's truth: section",
                 "docs/config.md (truth:)")
    p.add_argument("config", help=f"the config file with a truth: section, e.g. {EXAMPLE}/config.yaml "
                                  "(or its run folder)")
    p.add_argument("--force", action="store_true", help="replace an existing data file")
    p.set_defaults(func=cmd_simulate)

    p = _command(sub, "fit", "least squares (LM / Gauss-Newton) and the paper's stochastic analysis; "
                             "writes fit.json", "docs/fit.md")
    p.add_argument("config", help=f"the config file, e.g. {EXAMPLE}/config.yaml (or the run folder "
                                  "holding it); docs/config.md")
    p.add_argument("--force", action="store_true",
                   help="replace a fit.json made from another config or data")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=cmd_fit)

    p = _command(sub, "sample", "emcee posterior to the target ESS (runs fit first when needed); "
                                "resumable", "docs/sampling.md")
    p.add_argument("config", help=f"the config file, e.g. {EXAMPLE}/config.yaml (or the run folder "
                                  "holding it)")
    p.add_argument("--restart", action="store_true",
                   help="discard an existing chain (from another config or data) and start again")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--threads", type=_positive_int, default=None, metavar="N",
                   help="threads for the likelihood (default: config sampler.threads, else "
                        "NUMBA_NUM_THREADS / OMP_NUM_THREADS, which also cap N); the chain does "
                        "not depend on it")
    p.add_argument("--report", action="store_true",
                   help="then write report.html in the same process, as `report RUN_DIR` would "
                        "(unless it is current); sooner than the two commands")
    p.set_defaults(func=cmd_sample)

    p = _command(sub, "report", "report.html and figures/*.png for a finished run", "docs/report.md")
    p.add_argument("run_dirs", nargs="+", metavar="run_dir",
                   help=f"one or more run folders, e.g. {EXAMPLE} (or their config files)")
    p.add_argument("--force", action="store_true",
                   help="rebuild a report that is current (newer than its config, data and results)")
    p.set_defaults(func=cmd_report)

    p = _command(sub, "compare", "Table 3/5-style table across runs (Markdown and CSV); is E the same "
                                 "at every strain rate?", "docs/report.md")
    p.add_argument("run_dirs", nargs="+", metavar="run_dir",
                   help="the run folders to compare, e.g. runs/hdpe-a-* (or their config files)")
    p.add_argument("--out", type=Path, default=None,
                   help="folder for compare.md and compare.csv (default: the folder that holds the runs)")
    p.set_defaults(func=cmd_compare)

    p = _command(sub, "population", "specimens of one material as a population: the material's mean E, "
                                    "the specimen-to-specimen sd and each specimen's shrunken E, from "
                                    "finished runs", "docs/population.md")
    p.add_argument("run_dirs", nargs="+", metavar="run_dir",
                   help="finished single-test runs (run folders or their configs), one per specimen, "
                        "e.g. runs/population/spec-*")
    p.add_argument("--parameter", default="E", choices=["E", "G"], help="the pooled parameter (default E)")
    p.add_argument("--out", type=Path, default=None,
                   help="folder for population.json/.md/.png (default: the folder that holds the runs)")
    p.add_argument("--force", action="store_true",
                   help="replace a population.json made from other runs")
    p.set_defaults(func=cmd_population)

    p = _command(sub, "design", "experiment design: predicted sd, Err and correlations of planned "
                                "tests, and the recommended one", "docs/design.md")
    p.add_argument("design", help="the design file, e.g. runs/design/a-par.yaml")
    p.add_argument("--force", action="store_true", help="replace a design.json made from another design")
    p.add_argument("--top", type=int, default=10, help="candidates shown on the console (default 10)")
    p.set_defaults(func=cmd_design)

    from bayes_dnlr.workflows.export import FORMAT_NAMES

    p = _command(sub, "export", "FE material cards (the small-strain Prony series) at the posterior "
                                "median and 5 %%/95 %% quantiles of E, from a finished run",
                 "docs/export.md")
    p.add_argument("run_dir", help=f"a finished run folder (summary.json and posterior.nc), e.g. "
                                   f"{EXAMPLE} (or its config file)")
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

    p = _command(sub, "batch", "fit, sample and report many tests on all cores or a Dask cluster; "
                               "resumable; results table and batch page", "docs/batch.md")
    p.add_argument("inputs", nargs="*", metavar="config",
                   help="config files or glob patterns, e.g. 'runs/hdpe-a-*/config.yaml'; with "
                        "--manifest, one template config, or none when the manifest has a config column")
    p.add_argument("--manifest", type=Path, default=None,
                   help="CSV, one row per test; columns are dotted config keys (data.file, "
                        "data.area0, data.window.strain_max, ...) overriding the template, or a config "
                        "column naming each row's own config (init FILE --all writes one)")
    p.add_argument("--out", type=Path, default=None,
                   help="folder for results.csv/.parquet, batch.html (and the runs of a manifest); "
                        "default: <configs' common folder>/batch or <manifest folder>/batch-<stem>")
    p.add_argument("--jobs", type=int, default=None,
                   help="local worker processes, one test each: 1 to 4 per core (default: one per core)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster: tcp://host:8786, a scheduler file, or 'config' "
                        "(the Dask config's scheduler-address)")
    p.add_argument("--no-report", dest="report", action="store_false",
                   help="skip the per-test report.html (the batch page is still written)")
    p.add_argument("--restart", action="store_true",
                   help="a test whose fit or chain was made from another config or data starts again "
                        "(its old fit and chain are discarded, as sample --restart); finished and "
                        "interrupted current tests are kept")
    p.add_argument("--no-population", dest="population", action="store_false",
                   help="skip the population of the tests (population.json/.md/.png and its section "
                        "of the batch page; docs/population.md)")
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


def main(argv: list[str] | None = None, *, ends_process: bool = False) -> int:
    """Run the command of ``argv`` (default: the command line); its exit status. ``ends_process``:
    the process ends after it (``python -m bayes_dnlr``), so a command may leave its memory to
    the exit."""
    args = build_parser().parse_args(argv)
    args.ends_process = ends_process
    try:
        with warnings.catch_warnings():
            # numpy's overflow/invalid-value warnings are not for the user: bad numbers are refused
            # with a named error, and a doubtful result comes with its own note
            warnings.simplefilter("ignore", RuntimeWarning)
            status = args.func(args)
    except BayesDnlrError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as err:    # Ctrl-C; sample's chain is kept (bayes_dnlr/interrupt.py)
        print(f"interrupted: {err}" if str(err) else "interrupted", file=sys.stderr)
        return INTERRUPTED
    except MemoryError:
        print("error: out of memory: lower sampler.walkers or max_steps, or use fewer data rows "
              "(data.rows)", file=sys.stderr)
        return 2
    except OSError as err:
        if err.errno not in USER_ERRNOS:
            raise
        print(f"error: {err.filename or ''}{': ' if err.filename else ''}{err.strerror or err}",
              file=sys.stderr)
        return 2
    return status or 0
