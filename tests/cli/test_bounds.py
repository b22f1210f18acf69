"""Bounds on every option that sizes work, and names escaped where they reach a file: `export
--terms/--draws/--material/--seed`, `batch --jobs`, a config listed twice in a batch. Each bad value
is one `error:` line with exit 2, before any work and with nothing written."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from support.batch import FEW
from support.finished_run import make_finished_run
from support.sampling import write_case

from bayes_dnlr import cli
from bayes_dnlr.workflows.export import abaqus, lsdyna
from bayes_dnlr.workflows.export.run import MAX_DRAWS, MAX_MATERIAL, export


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    return make_finished_run(tmp_path_factory.mktemp("runs"))


def _run(args: list[str], capsys) -> tuple[int, str]:
    try:
        code = cli.main(args)
    except SystemExit as exit_:        # argparse
        code = exit_.code
    out, err = capsys.readouterr()
    return int(code or 0), err


def _one_error(code: int, err: str, *names: str) -> None:
    assert code == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for n in names:
        assert n in lines[0], lines[0]


@pytest.mark.parametrize("fmt", ["csv", "abaqus", "json"])
def test_terms_beyond_the_models_series_refused_at_once(finished_run: Path, tmp_path: Path, capsys,
                                                        fmt: str) -> None:
    """`--terms 100000` never ended (a refit in 100000 dimensions)."""
    out = tmp_path / "out"
    t0 = time.monotonic()
    code, err = _run(["export", str(finished_run), "--format", fmt, "--nu", "0.45", "--terms", "100000",
                      "--out", str(out)], capsys)
    _one_error(code, err, "--terms 100000", "50")
    assert time.monotonic() - t0 < 30
    assert not out.exists()


@pytest.mark.parametrize("terms", ["0", "-3"])
def test_terms_below_one_refused(finished_run: Path, tmp_path: Path, capsys, terms: str) -> None:
    code, err = _run(["export", str(finished_run), "--format", "csv", "--terms", terms,
                      "--out", str(tmp_path / "o")], capsys)
    _one_error(code, err, f"--terms {terms}")


def test_terms_at_the_limits_of_each_solver(finished_run: Path, tmp_path: Path, capsys) -> None:
    code, err = _run(["export", str(finished_run), "--format", "ls-dyna", "--nu", "0.45", "--density",
                      "950", "--terms", "18", "--out", str(tmp_path / "k")], capsys)
    _one_error(code, err, "--terms", str(lsdyna.MAX_TERMS - 1))
    assert cli.main(["export", str(finished_run), "--format", "ls-dyna", "--nu", "0.45", "--density",
                     "950", "--terms", "17", "--out", str(tmp_path / "k")]) == 0
    capsys.readouterr()


def test_draws_bounded(finished_run: Path, tmp_path: Path, capsys) -> None:
    code, err = _run(["export", str(finished_run), "--format", "csv", "--draws", str(MAX_DRAWS + 1),
                      "--out", str(tmp_path / "o")], capsys)
    _one_error(code, err, "--draws", str(MAX_DRAWS))
    code, err = _run(["export", str(finished_run), "--format", "csv", "--draws", "-1",
                      "--out", str(tmp_path / "o")], capsys)
    _one_error(code, err, "--draws -1")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("length", [MAX_MATERIAL + 1, 200, 300])
def test_material_name_length_refused(finished_run: Path, tmp_path: Path, capsys, length: int) -> None:
    """200 characters went into the cards (Abaqus labels and LS-DYNA titles hold 80); 300 ended in an
    OS error with an empty --out folder left behind."""
    out = tmp_path / "out"
    code, err = _run(["export", str(finished_run), "--format", "abaqus", "--nu", "0.45",
                      "--material", "m" * length, "--out", str(out)], capsys)
    _one_error(code, err, "--material", str(MAX_MATERIAL), "80")
    assert not out.exists()


def test_material_name_at_the_limit_fits_every_label(finished_run: Path, tmp_path: Path) -> None:
    # two ensemble cards: their labels (draw001, draw002) are as long as those of any number up to
    # 999, and each LS-DYNA card is a Prony series refitted to 10 terms (0.2 s per card)
    res = export(finished_run, "abaqus", nu=0.45, draws=2, material="m" * MAX_MATERIAL,
                 out=tmp_path / "a")
    for p in res.files:
        if p.suffix == ".inp":
            name = abaqus.parse(p.read_text())["name"]
            assert len(name) <= abaqus.MAX_LABEL, name
    res = export(finished_run, "ls-dyna", nu=0.45, density=950, draws=2, terms=10,
                 material="m" * MAX_MATERIAL,
                 out=tmp_path / "k")
    for p in res.files:
        if p.suffix == ".k":
            lines = p.read_text().splitlines()
            title = lines[lines.index("*MAT_GENERAL_VISCOELASTIC_TITLE") + 1]
            assert len(title) <= 80
            assert all(len(x) <= 80 for x in lines if not x.startswith("$")), p


def test_default_material_from_a_long_run_name(tmp_path: Path, capsys) -> None:
    # a finished run of that name (the name is inside its outputs), a short one: the default
    # material is refused whatever the chain (the session's finished run made anew under this name
    # cost 0.8 s of CPU, this one 0.25 s)
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    config = write_case(tmp_path, "r" * (MAX_MATERIAL + 5), n=300, extra={"fit": {"multistart": 0}},
                        sampler=FEW)
    sample(load_config(config), progress=False)
    long_run = config.parent
    code, err = _run(["export", str(long_run), "--format", "abaqus", "--nu", "0.45"], capsys)
    _one_error(code, err, "--material", str(MAX_MATERIAL))


@pytest.mark.parametrize("seed", ["-1", str(2**64)])
def test_seed_bounded(finished_run: Path, tmp_path: Path, capsys, seed: str) -> None:
    code, err = _run(["export", str(finished_run), "--format", "csv", "--draws", "3", "--seed", seed,
                      "--out", str(tmp_path / "o")], capsys)
    _one_error(code, err, "--seed")


def test_run_path_with_a_newline_stays_in_the_comments(finished_run: Path, tmp_path: Path) -> None:
    """A run folder whose name holds a newline (or other control characters) must not end a comment
    line of a card: the rest would be read as a keyword."""
    import shutil

    odd = tmp_path / "we\nird\r\x1b[31mrun"
    shutil.copytree(finished_run, odd)
    for fmt, marker in (("abaqus", "**"), ("ls-dyna", "$"), ("ansys", "!"), ("csv", "#")):
        res = export(odd, fmt, nu=0.45, density=950, terms=10 if fmt == "ls-dyna" else None,
                     out=tmp_path / fmt)
        for p in res.files:
            if p.name == "cards.csv":
                assert all(ln.startswith("#") or ln[:1].isalnum() for ln in p.read_text().splitlines())
                continue
            text = p.read_text()
            assert "\r" not in text and "\x1b" not in text
            head = [ln for ln in text.splitlines() if "export of run" in ln]
            assert head and all(ln.startswith(marker) for ln in head)
            assert "we\\nird" in text
    assert abaqus.parse((tmp_path / "abaqus" / "tiny_median.inp").read_text())["E0"] > 0


# ---------------------------------------------------------------- batch

@pytest.mark.parametrize("jobs", ["0", "-5", "-1"])
def test_batch_jobs_below_one_refused(tmp_path: Path, capsys, jobs: str) -> None:
    config = tmp_path / "c.yaml"
    config.write_text("name: c\n")
    code, err = _run(["batch", str(config), "--jobs", jobs, "--out", str(tmp_path / "b")], capsys)
    assert code == 2 and "--jobs" in err and "Traceback" not in err, err
    assert not (tmp_path / "b").exists()


def test_batch_jobs_above_the_bound_refused(tmp_path: Path, capsys) -> None:
    from bayes_dnlr.workflows.batch.run import max_jobs

    config = tmp_path / "c.yaml"
    config.write_text("name: c\n")
    code, err = _run(["batch", str(config), "--jobs", str(max_jobs() + 1), "--out", str(tmp_path / "b")],
                     capsys)
    assert code == 2 and "--jobs" in err and str(max_jobs()) in err, err
    assert not (tmp_path / "b").exists()


def test_config_listed_twice_is_said(tmp_path: Path, capsys, monkeypatch) -> None:
    """The same config twice (as two spellings) ran once without a word."""
    (tmp_path / "a").mkdir()
    config = tmp_path / "a" / "config.yaml"
    config.write_text("name: a\n")
    monkeypatch.chdir(tmp_path)
    code, err = _run(["batch", "a/config.yaml", "./a/config.yaml", "--out", str(tmp_path / "b")], capsys)
    _one_error(code, err, "a/config.yaml", "twice")
    assert not (tmp_path / "b").exists()
    code, err = _run(["batch", "a/config.yaml", "a/*.yaml", "--out", str(tmp_path / "b")], capsys)
    _one_error(code, err, "twice", "a/*.yaml")
