# Entry point. `make help` lists the targets; every target is a file or a short phony alias.
SHELL := /bin/bash
.DEFAULT_GOAL := help

PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
VENV_STAMP := $(VENV)/.installed
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
THETAS := 030 060 090 120 150 180
MODEL_DIR := results/model

# DEM runs: make dem THETA=90 [PRESET=quick] [ROTATE_AT=0.1] [SET="key=value ..."] [FRESH=1] [THREADS=1]
THETA ?= 180
PRESET ?= quick
ROTATE_AT ?=
SET ?=
FRESH ?=
RESUME ?=
THREADS ?= 1
DEM_ARGS = --preset $(PRESET) $(if $(ROTATE_AT),--rotate-at $(ROTATE_AT)) $(foreach s,$(SET),--set $(s)) \
	$(if $(filter 1 yes true,$(FRESH)),--fresh) --threads $(THREADS)

.PHONY: help demo test bench venv system model-cycles dem fit fit-bootstrap figures demo-dem clean

help: ## list the targets
	@grep -E '^[a-zA-Z_-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN{FS=":.*## "}{printf "  make %-14s %s\n", $$1, $$2}'

demo: system venv model-cycles demo-dem ## set up everything, then run the pipeline on the small default
	$(PY) -m pipeline.fit --preset quick
	$(PY) -m pipeline.figures --preset quick
	@echo "demo done: model cycles in $(MODEL_DIR)/, DEM runs in results/quick/dem/, fit in results/quick/fit/, figures and report.md in results/quick/"

test: system venv ## run the test suite (the DEM tests run the real Yade)
	$(PY) -m pytest -q

bench: system venv ## benchmarks: model numerics and DEM control/measurement cost, in results/bench/
	$(PY) -m pipeline.bench_model --out results/bench
	$(PY) -m pipeline.bench_dem --out results/bench

venv: $(VENV_STAMP) ## the project virtualenv from pyproject.toml

$(VENV_STAMP): pyproject.toml | system
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $@

system: ## Debian packages: Yade, h5py for Yade's python3, and venv for the project's virtualenv (apt-get)
	@if command -v yade >/dev/null && /usr/bin/python3 -c 'import h5py, ensurepip' 2>/dev/null; then \
	  echo "yade, python3-h5py and python3-venv present"; \
	else \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends \
	    yade python3-h5py python3-venv; \
	fi

model-cycles: $(foreach t,$(THETAS),$(MODEL_DIR)/theta$(t).csv) ## model cycles for the paper's six angles (Table 2)

$(MODEL_DIR)/theta%.csv: $(VENV_STAMP) model/*.py
	$(PY) -m model predict --theta $* --out $@

dem: system venv ## one DEM run -> results/<preset>/dem/theta<THETA>.h5 (resumes from its checkpoint; see README)
	$(PY) -m pipeline.dem run --theta $(THETA) $(DEM_ARGS)

fit: venv ## stepwise calibration from the theta = 180 runs -> results/<PRESET>/fit/params.json, fit.json
	$(PY) -m pipeline.fit --preset $(PRESET)

fit-bootstrap: venv ## the fit plus a bootstrap over cycles (BOOT=100 refits) -> fit.json
	$(PY) -m pipeline.fit --preset $(PRESET) --bootstrap $(or $(BOOT),100)

figures: venv ## Figs. 5-7 and report.md -> results/<PRESET>/figures/, results/<PRESET>/report.md
	$(PY) -m pipeline.figures --preset $(PRESET)

demo-dem: system venv ## the quick-preset DEM runs of the demo: theta = 180 and 90, both at once
	$(MAKE) --no-print-directory -j2 demo-dem-180 demo-dem-90

demo-dem-%:
	$(PY) -m pipeline.dem run --theta $* --preset quick

clean: ## remove generated results (keeps the venv)
	rm -rf results/model results/bench results/quick results/tiny
