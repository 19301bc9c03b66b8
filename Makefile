# longprofile — the two set-up commands are `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
STAMP_TEST := $(VENV)/.installed-test

# Small LAPACK calls are much slower with threaded BLAS on 2 cores; the engine is single-threaded by design.
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1

.PHONY: demo test bench bench-quick clean

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(VENV)/bin/python
	$(PY) -m pip install --quiet -e ".[serve]"
	touch $@

$(STAMP_TEST): pyproject.toml | $(VENV)/bin/python
	$(PY) -m pip install --quiet -e ".[test]"
	touch $@ $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/longprofile demo --output out

# the suite on PYTEST_WORKERS processes (pytest-xdist), one test file per process at a time
PYTEST_WORKERS ?= 2

test: $(STAMP_TEST)
	$(PY) -m pytest -q --durations=15 -n $(PYTEST_WORKERS) --dist loadfile

bench: $(STAMP_TEST)
	$(PY) -m benchmarks

bench-quick: $(STAMP_TEST)
	$(PY) -m benchmarks --quick

clean:
	rm -rf $(VENV) out .pytest_cache
