# mfid: one-command entry points. Each target creates .venv when it is absent or stale.
#   make demo    set up and run the main job on the bundled sample data
#   make test    set up and run the test suite (what CI runs)
#   make bench   run the benchmark scripts in bench/
#   make realdata  judge the pipeline on the real sets beside the project (bench/realdata.py)
#   make fits    fit every folder under measurements/ that has a tyre.toml (make -j safe)
.DELETE_ON_ERROR:
.PHONY: demo test test-all trials bench clean venv fits realdata

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
	$(BIN)/python -m pip install --quiet -e '.[test,fast]'
	touch $@

venv: $(STAMP)

DEMO_FOLDER := measurements/sample-225-50R17

# the main job on the bundled sample: fits/<sample>/<sample>.tir, fit.json, reports/<sample>.pdf
demo: $(STAMP)
	$(BIN)/mfid fit $(DEMO_FOLDER)

# ----- batch fits -------------------------------------------------------------------------------
# One rule per folder of $(MEASUREMENTS) that holds a tyre.toml (measurements/reference has none
# and is left out); the folder name must be its tyre id. Each rule depends on the folder's files
# (found with find, not the directory's timestamp) and makes the .tir and the report in one
# recipe (grouped targets), so a second `make fits` does nothing and touching one input refits
# that folder only. Overridable: MEASUREMENTS, FITS, REPORTS, FIT_FLAGS (e.g. "--mcmc"),
# FIT_NEEDS (order-only prerequisite, the venv by default). File names must not hold spaces.
MEASUREMENTS ?= measurements
FITS         ?= fits
REPORTS      ?= reports
FIT_FLAGS    ?=
FIT_NEEDS    ?= $(STAMP)
FIT_IDS      := $(patsubst $(MEASUREMENTS)/%/tyre.toml,%,$(wildcard $(MEASUREMENTS)/*/tyre.toml))
fit_inputs    = $(shell find $(MEASUREMENTS)/$(1) -type f ! -name '.*' | LC_ALL=C sort)

define FIT_RULE
$(FITS)/$(1)/$(1).tir $(REPORTS)/$(1).pdf &: $(call fit_inputs,$(1)) | $(FIT_NEEDS)
	$(BIN)/mfid fit $(MEASUREMENTS)/$(1) --out $(FITS) --reports $(REPORTS) $(FIT_FLAGS)
	@test -f $(FITS)/$(1)/$(1).tir || { echo "make fits: the tyre id in $(MEASUREMENTS)/$(1)/tyre.toml must be the folder name '$(1)'" >&2; exit 1; }
endef
$(foreach id,$(FIT_IDS),$(eval $(call FIT_RULE,$(id))))

fits: $(foreach id,$(FIT_IDS),$(FITS)/$(id)/$(id).tir $(REPORTS)/$(id).pdf)

# lint (ruff), the layers contract (import-linter), then the default suite on every core
test: $(STAMP)
	$(BIN)/ruff check identify
	$(BIN)/lint-imports
	$(BIN)/python -m pytest -q -n auto

trials: $(STAMP)
	$(BIN)/python -m pytest -q -m trials

bench: $(STAMP)
	$(BIN)/python bench/forward.py

# the default pipeline and its variants on every real set under ../shared/realdata: import, fit,
# error on all samples and held-out error (bench/results/realdata.md); REALDATA_FLAGS e.g. --quick
REALDATA_FLAGS ?=
realdata: $(STAMP)
	nice $(BIN)/python bench/realdata.py $(REALDATA_FLAGS)

clean:
	rm -rf fits/demo .pytest_cache .hypothesis
