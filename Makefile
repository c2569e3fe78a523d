# The one entry point for humans and CI. `make caseA` and `make test` do all the set-up.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
CLI    := $(BIN)/pavement-mcmc
# BLAS threads fight the compiled solver kernel for the two cores
export OMP_NUM_THREADS ?= 1
export OPENBLAS_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1

.PHONY: help install chromium test validate bench caseA caseB caseC cases lint clean

help:
	@echo "make caseA|caseB|caseC  run the paper's cases on the shipped data -> runs/caseX/"
	@echo "make test               set up .venv and run the fast test suite"
	@echo "make validate           slow validation runs (coverage, calibration, hidden effects)"
	@echo "make bench              solver and sampler benchmarks (figures and ratios)"
	@echo "make lint               ruff"
	@echo "make chromium           headless chromium for the report's browser test (apt-get, as root)"

# No stamp: the venv is missing or its set-up never finished (one interrupted during pip's own
# upgrade cannot install any more), so it is made afresh. A stamp older than pyproject.toml:
# the venv is kept and updated, the stamp removed first, so an interrupted update counts as
# unfinished on the next run.
$(STAMP): pyproject.toml
	test -f $(STAMP) && rm -f $(STAMP) || $(PYTHON) -m venv --clear $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e ".[test]"
	touch $(STAMP)

install: $(STAMP)

# the report's browser test (tests/report/test_report_browser.py) needs a headless chromium: Debian's
# is installed where apt-get can (as root); elsewhere that test skips, saying why
chromium:
	@command -v chromium >/dev/null 2>&1 || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
	  && apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium; } \
	  || echo "chromium not installed: the browser test of the HTML report will skip"

# one pytest worker per core (pytest-xdist): 7 min 19 s against 11 min 03 s on one, 2 cores
test: $(STAMP) chromium
	$(BIN)/python -m pytest -q -n auto

validate: $(STAMP)
	$(BIN)/python -m pytest -q -m slow -o addopts="" -s

bench: $(STAMP)
	$(BIN)/python benchmarks/run_all.py

caseA caseB caseC: $(STAMP)
	$(CLI) fit runs/$@.toml --out runs/$@ --overwrite
	$(CLI) report runs/$@

cases: caseA caseB caseC

lint: $(STAMP)
	$(BIN)/ruff check pavement_mcmc tests benchmarks

clean:
	rm -rf runs/caseA runs/caseB runs/caseC .pytest_cache
