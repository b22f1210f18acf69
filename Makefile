# bayes_dnlr: `make demo` (install + main job on the shipped example), `make test` (install + tests).
# `make demo` again samples nothing and keeps a current report; `make demo FORCE=1` rebuilds the report.
VENV   ?= .venv
PY     := $(VENV)/bin/python
EXAMPLE ?= runs/hdpe-a-5e-3/config.yaml
export PYTHON

.PHONY: install bytecode demo test test-slow bench lint mutants clean-runs

install: $(VENV)/.installed

# The dependencies' bytecode is written by compileall, not by pip: pip compiles every file it
# installs, and 2800 of the 7100 are the dependencies' own test suites, which nothing imports
# (install 73 -> 44 s of CPU). The rest is compiled once here: where PYTHONDONTWRITEBYTECODE is set,
# a module without it would be compiled again by every process that imports it.
$(VENV)/.installed: pyproject.toml scripts/find-python
	@py=$$(sh scripts/find-python) || exit 1; \
	echo "using $$py ($$($$py --version 2>&1))"; \
	[ -x $(PY) ] || $$py -m venv $(VENV) || exit 1; \
	$(PY) -m pip install --quiet --upgrade pip && \
	$(PY) -m pip install --quiet --no-compile -e '.[test]' && \
	$(PY) -m compileall -qq -x '/tests?/' "$$($(PY) -c 'import sysconfig; print(sysconfig.get_path("purelib"))')" && \
	touch $@

# The package's bytecode, brought up to date before each command (0.1 s when it is): pip writes it
# for an installed package but not for this editable one, and where PYTHONDONTWRITEBYTECODE is set
# every process would compile the modules it imports again (0.2-0.5 s of every command).
bytecode: install
	@$(PY) -m compileall -q bayes_dnlr

RUN_DIR = $(patsubst %/,%,$(dir $(EXAMPLE)))

# The example's residuals are white: its run compiles the model but not the discrepancy's kernels,
# which every real curve needs; warm.py compiles them ahead (once per clone), so that the first real
# `sample` does not wait 10-30 s for them (docs/performance.md).
demo: bytecode
	$(PY) -m bayes_dnlr sample $(EXAMPLE) $(if $(FORCE),,--report)
	$(if $(FORCE),$(PY) -m bayes_dnlr report $(RUN_DIR) --force)
	@$(PY) -m bayes_dnlr.workflows.warm
	@echo "open $(RUN_DIR)/report.html"

test: bytecode
	$(PY) -m pytest -q

test-slow: bytecode
	$(PY) -m pytest -q -m slow

bench: bytecode
	$(PY) benchmarks/forward.py
	$(PY) benchmarks/fit.py
	$(PY) benchmarks/sample.py

lint: install
	$(PY) -m ruff check .

# Mutation testing of the modules that decide what a user is told (docs/mutation-testing.md): not
# part of `make test`. mutmut keeps its results in mutants/ and goes on where it stopped; `make
# mutants MUTANTS='bayes_dnlr.standards*'` runs a subset, `$(PY) -m mutmut results` lists survivors.
MUTANTS ?=
mutants: bytecode
	$(PY) -m pip install --quiet 'mutmut>=3.3,<4'
	nice -n 10 $(PY) -m mutmut run --max-children 1 $(MUTANTS)
	$(PY) scripts/mutation_score.py

clean-runs:
	git clean -fdX runs/
