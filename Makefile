# Two commands for a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: install constraints demo lint test test-fast bench docs chromium clean

# torch is installed first and on its own: the CPU wheel of 2.13.0 is small, any other resolution
# pulls several GB of CUDA packages. Everything else comes at the tested versions of constraints.txt.
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -c constraints.txt -e ".[all,test]" --group dev
	touch $(STAMP)

# Re-pin constraints.txt to the versions installed in .venv (after a deliberate upgrade).
constraints: $(STAMP)
	{ sed -n '1,2p' constraints.txt; $(PY) -m pip freeze --exclude-editable | grep -iv '^torch==\|^sphere.env'; } > constraints.txt.tmp
	mv constraints.txt.tmp constraints.txt

# Headless Chromium renders the Meshcat HTML replays in the evaluation tests (Debian package). An
# explicit step (it installs a system package, as root): `make test` never runs it, and without a
# browser the replay test is skipped, saying why.
chromium:
	@test -x /usr/bin/chromium || (apt-get update -qq && apt-get install -y -qq chromium)

install: $(STAMP)

demo: $(STAMP)
	$(PY) -m evaluation.demo

# Lint first (seconds): pyflakes, import order, bugbear and the format check (ruff) and dead code
# (vulture), as configured in pyproject.toml; then the suite.
lint: $(STAMP)
	$(VENV)/bin/ruff check sphere_env training evaluation tests
	$(VENV)/bin/ruff format --check sphere_env training evaluation tests
	$(PY) -m vulture

test: $(STAMP) lint
	$(PY) -m pytest -n 2

test-fast: $(STAMP)
	$(PY) -m pytest -n 2 -m "not slow"

bench: $(STAMP)
	$(PY) -m evaluation.experiments.benchmark

# The measured numbers of README.md and docs/ (their <!-- generated: NAME --> blocks), rendered from the
# committed results files in evaluation/results; nothing is simulated.
docs: $(STAMP)
	$(PY) -m evaluation.experiments.docs

clean:
	rm -rf $(VENV) build *.egg-info
