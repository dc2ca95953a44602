# crane_fem developer entry points. `make test` and `make demo` create the venv on first use.
SHELL := /bin/bash
VENV ?= .venv
BIN := $(VENV)/bin
NP ?= 2
# Python >= 3.12: an explicit PYTHON, else python3.12 on PATH, else pyenv's newest 3.12.
PYTHON ?= $(shell command -v python3.12 2>/dev/null || ls -d $$HOME/.pyenv/versions/3.12*/bin/python3.12 2>/dev/null | tail -n 1)

.PHONY: install test lint warm test-serial test-mpi test-no-kernels lint-then-no-kernels demo demo-bar bench bench-quick clean

# The venv installed by uv (pinned; from PyPI, into the venv itself): the same packages as pip
# installs, in about 10 s against pip's 37 s without a cache (benchmarks/RESULTS.md, "The
# kernels' first compilation").
UV_VERSION := 0.13.9
$(BIN)/.installed: pyproject.toml
	@test -n "$(PYTHON)" || { echo "make: no Python 3.12 found (set PYTHON=/path/to/python3.12)"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check uv==$(UV_VERSION)
	$(BIN)/uv pip install --quiet --python $(BIN)/python -e '.[dev]'
	touch $@

install: $(BIN)/.installed

lint: $(BIN)/.installed
	$(BIN)/ruff check crane_fem tests benchmarks demos
	$(BIN)/ruff format --check crane_fem tests benchmarks demos
	$(BIN)/mypy crane_fem

# pytest exits 5 when it collected no test: that is a failure here, as is any non-zero code.
# The serial pass runs on NP workers (pytest-xdist), a file per worker (a module's shared
# runs are made once), the files with the most `slow` tests handed out first
# (tests/conftest.py orders them; --no-loadscope-reorder keeps that order) so that the
# workers finish together. One BLAS/OpenMP thread per worker, as in the mpiexec pass: NP
# workers of threaded BLAS (and the `mpiexec -n 2` jobs some tests start) oversubscribe the
# cores.
test-serial: $(BIN)/.installed
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(BIN)/python -m pytest -q -n $(NP) --dist loadfile \
		--no-loadscope-reorder $(SERIAL_SELECT) tests

# The modules marked `no_kernels` (records, spectra, figures, docs, input checks: about a
# minute) need no compiled kernel: `make test` runs them serially on the core the lint leaves
# idle while `make warm` compiles, and its serial pass leaves them out.
test-no-kernels: $(BIN)/.installed
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(BIN)/python -m pytest -q -m no_kernels tests

lint-then-no-kernels: lint
	$(MAKE) --no-print-directory test-no-kernels

# One BLAS/OpenMP thread per rank: NP ranks of threaded BLAS oversubscribe the cores.
test-mpi: $(BIN)/.installed
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(BIN)/mpiexec -n $(NP) $(BIN)/python -m pytest -q tests

# The kernels compiled once, while the lint and the no_kernels tests run, before the tests'
# processes start (about 2 min of numba on a fresh clone; every process after it, pytest
# workers and mpiexec ranks, loads the cache instead of compiling the same kernels side by
# side).
warm: $(BIN)/.installed
	@d=$$(mktemp -d) && OMP_NUM_THREADS=1 $(BIN)/crane-fem run demos/bar_impact.toml -o $$d/bar \
		--no-progress > $$d/log 2>&1 || { cat $$d/log; rm -rf $$d; exit 1; }; rm -rf $$d
	@echo "make warm: the kernels are compiled and cached"

test: $(BIN)/.installed
	$(MAKE) --no-print-directory -j2 lint-then-no-kernels warm
	$(MAKE) --no-print-directory test-serial SERIAL_SELECT='-m "not no_kernels"'
	$(MAKE) --no-print-directory test-mpi

# The main job: the crane scene heterogeneous (gc-mean, m = 100, 10 at impacts) and fully
# explicit, side by side on the 2 cores, then the paper's figures and the comparison. Each
# run's report is printed when both are done. On a fresh clone the kernels' callees are first
# compiled in two halves side by side (crane_fem.warm: nothing to do once cached); the two runs
# then compile the step itself.
demo: $(BIN)/.installed
	@mkdir -p out/crane
	@OMP_NUM_THREADS=1 $(BIN)/python -m crane_fem.warm demos/crane.toml 0 > out/crane/warm0.log 2>&1 & w0=$$!; \
	OMP_NUM_THREADS=1 $(BIN)/python -m crane_fem.warm demos/crane.toml 1 > out/crane/warm1.log 2>&1 & w1=$$!; \
	wait $$w0; a=$$?; wait $$w1; b=$$?; cat out/crane/warm0.log out/crane/warm1.log; test $$a -eq 0 -a $$b -eq 0
	@echo "make demo: the heterogeneous and the fully explicit run side by side (out/crane/*.log)"
	@OMP_NUM_THREADS=1 $(BIN)/crane-fem run demos/crane.toml -o out/crane/heterogeneous \
		--no-progress > out/crane/heterogeneous.log 2>&1 & het=$$!; \
	OMP_NUM_THREADS=1 $(BIN)/crane-fem run demos/crane.toml -o out/crane/explicit --no-progress \
		--set coupling.method='"monolithic"' > out/crane/explicit.log 2>&1 & exp=$$!; \
	wait $$het; a=$$?; wait $$exp; b=$$?; \
	cat out/crane/heterogeneous.log out/crane/explicit.log; \
	test $$a -eq 0 -a $$b -eq 0
	$(BIN)/crane-fem plot out/crane
	@echo "make demo: outputs in out/crane/ (heterogeneous/ and explicit/: history.csv, summary.json, results.csv, spectra.csv, solution_*.xdmf for ParaView; figures/*.png; comparison.json)"

demo-bar: $(BIN)/.installed
	$(BIN)/crane-fem run demos/bar_impact.toml -o out/bar_impact

# Speed against accuracy: the stability map, the Pareto chart and the crane ensemble; tables
# into benchmarks/RESULTS.md, CSV and PNG into benchmarks/out/ (bench-quick: at most 10 min).
bench: $(BIN)/.installed
	OMP_NUM_THREADS=1 $(BIN)/crane-fem bench

bench-quick: $(BIN)/.installed
	OMP_NUM_THREADS=1 $(BIN)/crane-fem bench --quick

clean:
	rm -rf out .mypy_cache .ruff_cache
