"""The command line: help is instant, user errors print one clear line and exit with 2."""

from __future__ import annotations

import subprocess
import sys

import pytest
from support import REPO

from bayes_dnlr import __version__
from bayes_dnlr.cli import main


def test_help_lists_every_command_without_heavy_imports():
    code = ("import sys; from bayes_dnlr.cli import build_parser; build_parser().format_help(); "
            "print(sorted(m for m in ('emcee', 'arviz', 'matplotlib', 'numba', 'scipy') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    help_text = subprocess.run([sys.executable, "-m", "bayes_dnlr", "--help"], capture_output=True,
                               text=True, check=True).stdout
    for command in ("simulate", "fit", "sample", "report", "compare", "batch"):
        assert command in help_text


def test_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert __version__ in capsys.readouterr().out


@pytest.mark.parametrize("command", ["simulate", "fit", "sample"])
def test_missing_config_is_one_clear_line(tmp_path, capsys, command):
    missing = tmp_path / "nope.yaml"
    assert main([command, str(missing)]) == 2
    err = capsys.readouterr().err
    assert err == (f"error: {missing}: config file not found ({command} takes the config file, e.g. "
                   "runs/hdpe-a-5e-3/config.yaml)\n")


def test_bad_key_names_file_and_key(tmp_path, capsys):
    cfg = tmp_path / "config.yaml"
    cfg.write_text((REPO / "runs/hdpe-a-5e-3/config.yaml").read_text().replace("walkers: 32", "walker: 32"))
    assert main(["fit", str(cfg)]) == 2
    err = capsys.readouterr().err
    assert f"{cfg.resolve()}: sampler.walker: unknown key" in err
    assert not (tmp_path / "hdpe-a-5e-3").exists()          # nothing written


def test_report_on_a_folder_without_results(tmp_path, capsys):
    code = main(["report", str(tmp_path)])
    assert code == 2
    assert str(tmp_path) in capsys.readouterr().err


def test_fit_reports_the_detected_relaxation_start(tmp_path, capsys):
    import shutil

    run = tmp_path / "hdpe-b-relax-5e-3"
    shutil.copytree(REPO / "runs/hdpe-b-relax-5e-3", run)
    cfg = run / "config.yaml"
    cfg.write_text(cfg.read_text().replace("relaxation_start: 400.0", "relaxation_start: auto"))
    assert main(["fit", str(cfg)]) == 0
    out = capsys.readouterr().out
    assert "data: relaxation_start: auto -> 400 s (detected)" in out
    fit = __import__("json").loads((run / "fit.json").read_text())
    assert fit["relaxation_start"] == 400.0
    assert any("detected" in n for n in fit["data_notes"])


def test_every_subcommand_help_describes_its_arguments_and_names_its_docs_page():
    import re

    from bayes_dnlr.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    assert len(sub.choices) >= 8
    for name, p in sub.choices.items():
        positionals = [a for a in p._actions if not a.option_strings]
        assert positionals, name
        for a in positionals:
            assert a.help and len(a.help) > 15, f"{name} {a.dest}: no description"
        text = p.format_help().rstrip()
        assert text.endswith("every command: docs/cli.md."), name
        for page in re.findall(r"docs/[a-z-]+\.md", p.epilog):
            assert (REPO / page).is_file(), f"{name}: {page} does not exist"


def test_fast_exit_flushes_runs_atexit_and_keeps_the_status(tmp_path):
    marker = tmp_path / "atexit.txt"
    code = ("import atexit, sys, threading, time\n"
            "from bayes_dnlr.cli import exit_now\n"
            f"atexit.register(lambda: open({str(marker)!r}, 'w').write('ran'))\n"
            "if len(sys.argv) > 1:\n"
            "    threading.Thread(target=lambda: (time.sleep(0.3), print('thread done'))).start()\n"
            "print('x' * 200000)\n"
            "sys.stderr.write('err line')\n"
            "exit_now(3)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 3
    assert out.stdout == "x" * 200000 + "\n" and out.stderr == "err line"
    assert marker.read_text() == "ran"
    # a running non-daemon thread: the normal exit, which waits for it
    out = subprocess.run([sys.executable, "-c", code, "thread"], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 3 and out.stdout.endswith("thread done\n")
