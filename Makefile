# Two commands for a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: install demo test test-fast bench chromium clean

# torch is pinned and installed first: the CPU wheel of 2.13.0 is small, any other
# resolution pulls several GB of CUDA packages.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e ".[test,ray]"
	touch $(STAMP)

# Headless Chromium renders the Meshcat HTML replays in the evaluation tests (Debian package).
chromium:
	@test -x /usr/bin/chromium || (apt-get update -qq && apt-get install -y -qq chromium)

install: $(STAMP)

demo: $(STAMP)
	$(PY) -m evaluation.demo

test: $(STAMP) chromium
	$(PY) -m pytest -n 2 --dist loadgroup

test-fast: $(STAMP) chromium
	$(PY) -m pytest -n 2 -m "not slow"

bench: $(STAMP)
	$(PY) -m evaluation.benchmark

clean:
	rm -rf $(VENV) build *.egg-info
