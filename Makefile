# mfid: one-command entry points. Each target creates .venv when it is absent or stale.
#   make demo    set up and run the main job on the bundled sample data
#   make test    set up and run the test suite (what CI runs)
#   make bench   run the benchmark scripts in bench/
.DELETE_ON_ERROR:
.PHONY: demo test test-all trials bench clean venv

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

# one BLAS/OpenMP thread per process: batch runs parallelise with make -j instead
export OMP_NUM_THREADS := 1
export OPENBLAS_NUM_THREADS := 1
export MKL_NUM_THREADS := 1
export MPLBACKEND := Agg

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

venv: $(STAMP)

DEMO_TIR    := measurements/reference/mf61_testA.tir
DEMO_POINTS := measurements/reference/operating_points.csv

demo: $(STAMP)
	@mkdir -p fits/demo
	$(BIN)/mfid eval $(DEMO_TIR) --input $(DEMO_POINTS) --output fits/demo/eval_mf61.csv --mode 111

test: $(STAMP)
	$(BIN)/python -m pytest -q

trials: $(STAMP)
	$(BIN)/python -m pytest -q -m trials

bench: $(STAMP)
	$(BIN)/python bench/forward.py

clean:
	rm -rf fits/demo .pytest_cache .hypothesis
