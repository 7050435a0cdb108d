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

.PHONY: help demo test bench venv system model-cycles clean

help: ## list the targets
	@grep -E '^[a-zA-Z_-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN{FS=":.*## "}{printf "  make %-14s %s\n", $$1, $$2}'

demo: system venv model-cycles ## set up everything, then run the pipeline on the small default
	@echo "demo done: model cycles in $(MODEL_DIR)/"

test: venv ## run the test suite
	$(PY) -m pytest -q

bench: venv ## numerics report: work-precision table and plot in results/bench/
	$(PY) -m pipeline.bench_model --out results/bench

venv: $(VENV_STAMP) ## the project virtualenv from pyproject.toml

$(VENV_STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $@

system: ## Debian packages: Yade and h5py for Yade's python3 (apt-get)
	@if command -v yade >/dev/null && /usr/bin/python3 -c 'import h5py' 2>/dev/null; then \
	  echo "yade and python3-h5py present"; \
	else \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends yade python3-h5py; \
	fi

model-cycles: $(foreach t,$(THETAS),$(MODEL_DIR)/theta$(t).csv) ## model cycles for the paper's six angles (Table 2)

$(MODEL_DIR)/theta%.csv: $(VENV_STAMP) model/*.py
	$(PY) -m model predict --theta $* --out $@

clean: ## remove generated results (keeps the venv)
	rm -rf results/model results/bench
