# Entry point. `make help` lists the targets. The pipeline is a DAG of files:
#   results/<D>/dem/*.h5 -> results/<D>/fit/params.json -> results/<D>/compare/metrics.json -> results/<D>/report.md
#   (<D>: the folder of the data set, see DATA_CHOICE below)
# and each step reruns only when what it reads has changed.
SHELL := /bin/bash
.DEFAULT_GOAL := help
.DELETE_ON_ERROR:

PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
VENV_STAMP := $(VENV)/.installed
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
APT_INSTALL := DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends
MODEL_THETAS := 030 060 090 120 150 180
MODEL_DIR := results/model

# ---------------------------------------------------------------- the user's variables, checked before any shell sees them
# make dem THETA=90 [PRESET=quick] [ROTATE_AT=0.1] [SET="key=value ..."] [FRESH=1] [THREADS=1] [ALLOW_INERTIAL=1]
#          [ENGINE=yade|lammps] [RANKS=1: MPI ranks of a LAMMPS run]
THETA ?= 180
ENGINE_GIVEN := $(if $(filter undefined,$(origin ENGINE)),,$(ENGINE))
ENGINE ?= yade
RANKS ?= 1
ROTATE_AT ?=
SET ?=
FRESH ?=
THREADS ?= 1
BOOT ?= 100
OVER ?= seeds
ALLOW_INERTIAL ?=
# make profile-dem [PRESETS=reduced,paper] [THREADS=1]; make bench-dem [PRESETS=quick,reduced,paper] [ENGINES=yade,lammps]
ENGINES ?= yade
PRESETS ?=
# make fit [FIT_FROM=0.005]: the model restarted from the DEM's state that far past each change of direction
FIT_FROM ?=
# make fit-angles ANGLES="180 90 60 30": the fit on the data set's runs at these angles only
ANGLES ?=
# make fit-profile [STRAIN=nominal|bulk] [PHI=gap|central]
STRAIN ?= nominal
PHI ?= gap
# make sweep PRESET=... THETAS="30 60 90" [ROTATE_ATS="0.1 0.2"] [SEEDS="1 2 3"] [SET=...] [LAUNCH=local|slurm]
#            [SLURM="partition=... time_limit=HH:MM:SS ..."] [JOBS=2] [RANKS=1: MPI ranks per LAMMPS run]
#            [MANY=1: more than 200 runs]
THETAS ?=
ROTATE_ATS ?=
SEEDS ?=
LAUNCH ?= local
SLURM ?=
JOBS ?=
MANY ?=
SWEEP ?=
LOWER := a b c d e f g h i j k l m n o p q r s t u v w x y z
UPPER := A B C D E F G H I J K L M N O P Q R S T U V W X Y Z
DIGITS := 0 1 2 3 4 5 6 7 8 9
NUMBER_CHARS := $(DIGITS) . - + e E
NAME_CHARS := $(LOWER) $(UPPER) $(DIGITS) _ . -
# what is left of $(1) once every character of the list $(2) is removed
strip_chars = $(if $(2),$(call strip_chars,$(subst $(firstword $(2)),,$(1)),$(wordlist 2,$(words $(2)),$(2))),$(1))
# $(call check,NAME,allowed characters,what they may be): reads the variable's text unexpanded ($(value ...)),
# so a value such as $(shell ...) is refused as text and never runs
check = $(if $(strip $(call strip_chars,$(subst $(space),,$(value $(1))),$(2))),$(error $(1)='$(value $(1))' is not $(3)))
space := $(subst ,, )
comma := ,
$(call check,THETA,$(NUMBER_CHARS),a number)
$(call check,ROTATE_AT,$(NUMBER_CHARS),a number)
$(call check,FIT_FROM,$(NUMBER_CHARS),a number)
$(call check,ANGLES,$(NUMBER_CHARS),a list of angles in degrees)
$(call check,STRESS,$(LOWER),shear or all)
$(call check,THREADS,$(DIGITS),a whole number)
$(call check,ENGINE,$(LOWER),yade or lammps)
$(call check,RANKS,$(DIGITS),a whole number)
$(call check,ENGINES,$(LOWER) $(comma),yade or yade$(comma)lammps)
$(call check,BOOT,$(DIGITS),a whole number)
$(call check,OVER,$(LOWER),seeds or angles)
$(call check,STRAIN,$(LOWER),bulk or nominal)
$(call check,PRESETS,$(NAME_CHARS) $(comma),a comma-separated list of presets)
$(call check,PHI,$(LOWER),central or gap)
$(call check,FRESH,$(NAME_CHARS),1 or empty)
$(call check,ALLOW_INERTIAL,$(NAME_CHARS),1 or empty)
$(call check,MANY,$(NAME_CHARS),1 or empty)
$(call check,THETAS,$(NUMBER_CHARS),a list of numbers)
$(call check,ROTATE_ATS,$(NUMBER_CHARS),a list of numbers)
$(call check,SEEDS,$(DIGITS),a list of whole numbers)
$(call check,LAUNCH,$(LOWER),local or slurm)
$(call check,SLURM,$(NAME_CHARS) = : +,a list of key=value)
$(call check,JOBS,$(DIGITS),a whole number)
$(call check,SWEEP,$(NAME_CHARS),a sweep id)
$(call check,SET,$(NAME_CHARS) = +,a list of key=value)
# make versus A=preset/engine/key=value B=...; make bench-lammps-settings RUN_DIR=... A="LAMMPS commands; ..." B=...
# (checked only for these targets: A and B are short names that a shell's environment may hold for other uses)
RUN_DIR ?=
ifneq ($(filter versus bench-lammps-settings,$(MAKECMDGOALS)),)
$(call check,A,$(NAME_CHARS) / = ;,a data set (preset/engine/key=value) or LAMMPS commands separated by ;)
$(call check,B,$(NAME_CHARS) / = ;,a data set (preset/engine/key=value) or LAMMPS commands separated by ;)
$(call check,RUN_DIR,$(NAME_CHARS) /,a run folder (letters, digits, _ . - /))
endif
ifneq ($(filter compare-seed,$(MAKECMDGOALS)),)
$(if $(strip $(SEED)),,$(error SEED is empty: give the seed whose runs to compare, e.g. SEED=2))
$(call check,SEED,$(DIGITS),a whole number)
endif
ifneq ($(origin PRESET),undefined)
$(call check,PRESET,$(NAME_CHARS),a preset name (letters, digits, _ . -))
endif

# `make dem` defaults to the small `quick` preset. fit, compare and figures read a data set
# (pipeline/dataset/selection.py): the most faithful preset with a reversal run in results/ or the committed data
# (paper, then reduced, then quick) unless PRESET is given, in the engine and with the overrides config/datasets.toml
# declares for it unless ENGINE or SET is given; their outputs go to results/<the data set's folder>/.
DATA_CHOICE := $(shell $(PYTHON) -m pipeline.dataset.selection $(if $(filter undefined,$(origin PRESET)),,--preset $(PRESET)) \
	$(if $(ENGINE_GIVEN),--engine $(ENGINE_GIVEN)) $(foreach s,$(SET),--set $(s)) 2>/dev/null)
DATA_PRESET := $(or $(word 1,$(DATA_CHOICE)),$(PRESET),quick)
PRESET_GIVEN := $(if $(filter undefined,$(origin PRESET)),,$(PRESET))
DATA_SET := $(or $(word 2,$(DATA_CHOICE)),$(DATA_PRESET))
DATA_ARGS := --preset $(DATA_PRESET) $(if $(DATA_CHOICE),--engine $(word 3,$(DATA_CHOICE)) \
	$(foreach s,$(wordlist 4,$(words $(DATA_CHOICE)),$(DATA_CHOICE)),--set $(s)),$(if $(ENGINE_GIVEN),--engine $(ENGINE_GIVEN)) \
	$(foreach s,$(SET),--set $(s)))
SAY_PRESET := @echo "data set $(DATA_SET) (preset $(DATA_PRESET)$(if $(filter undefined,$(origin PRESET)),$(comma) \
	the most faithful one with a reversal run; PRESET=... to choose))"
PRESET ?= quick
DEM_ARGS = --preset $(PRESET) --engine $(ENGINE) $(if $(ROTATE_AT),--rotate-at $(ROTATE_AT)) $(foreach s,$(SET),--set $(s)) \
	$(if $(filter 1 yes true,$(FRESH)),--fresh) $(if $(filter 1 yes true,$(ALLOW_INERTIAL)),--allow-inertial) \
	--threads $(THREADS) $(if $(filter-out 1,$(RANKS)),--ranks $(RANKS))

RUN_FILES = $(wildcard $(foreach r,results data/reference,$(r)/$(1)/dem/*.h5 $(r)/$(1)-*/dem/*.h5))
FIT_DIR := results/$(DATA_SET)/fit
COMPARE_DIR := results/$(DATA_SET)/compare
# every writer renames its outputs into place when they are complete: an interrupted step keeps the previous set,
# which Make must not delete either
.PRECIOUS: $(FIT_DIR)/params.json $(FIT_DIR)/fit.json $(FIT_DIR)/fit.h5 $(COMPARE_DIR)/metrics.json \
	$(COMPARE_DIR)/compare.h5 results/$(DATA_SET)/report.md
DATASET_CODE := $(wildcard pipeline/*.py pipeline/dataset/*.py model/*.py config/raw_schema.toml)

FORCE:
.PHONY: FORCE help demo test test-unit test-yade test-cluster lint bench venv system system-venv system-lammps system-slurm model-cycles \
	dem runs sweep sweep-status sweep-collect fit fit-bootstrap fit-jackknife fit-angles fit-definitions fit-from fit-profile fidelity fidelity-table engines versus data-card cells jump stability profile-dem bench-dem bench-lammps-settings compare compare-seed figures demo-dem clean

help: ## list the targets
	@grep -E '^[a-zA-Z_-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN{FS=":.*## "}{printf "  make %-14s %s\n", $$1, $$2}'

demo: system venv model-cycles demo-dem ## set up everything, then run the pipeline on the small default
	$(MAKE) --no-print-directory figures PRESET=quick
	@echo "demo done: model cycles in $(MODEL_DIR)/, DEM runs in results/quick/dem/, fit in results/quick/fit/, figures and report.md in results/quick/"

# ---------------------------------------------------------------- tests and lint
test: system system-lammps system-slurm venv lint ## lint, then every test (the real Yade and LAMMPS, a real one-node SLURM): what CI runs
	$(PY) -m pytest -q --durations=25

test-unit: venv ## the fast unit tests (no Yade, LAMMPS or SLURM, nothing marked slow): under a minute of CPU
	$(PY) -m pytest -q tests/unit -m "not slow and not yade and not lammps and not slurm"

test-yade: system system-lammps venv ## the tests that run the real Yade (and LAMMPS)
	$(PY) -m pytest -q tests/integration

test-cluster: system system-slurm venv ## a sweep on a real one-node SLURM cluster started on this machine
	$(PY) -m pytest -q tests/cluster

lint: venv ## ruff over the whole project
	$(PY) -m ruff check .

bench: system venv ## benchmarks: model numerics, the material-point update, DEM steps/s per preset and the cost of our Python, in results/bench/
	$(PY) -m pipeline.studies.bench_model --out results/bench
	$(PY) -m pipeline.studies.bench_update --out results/bench
	$(PY) -m pipeline.studies.bench_dem --out results/bench

bench-dem: system $(if $(findstring lammps,$(ENGINES)),system-lammps) venv ## DEM steps/s, bare and production loop (PRESETS=quick,reduced,paper; ENGINES=yade,lammps) -> results/bench/
	$(PY) -m pipeline.studies.bench_dem --presets $(or $(PRESETS),quick$(comma)reduced$(comma)paper) --engines $(ENGINES) \
	  --out results/bench

bench-lammps-settings: system-lammps venv ## LAMMPS steps/s, two settings side by side from a run's checkpoint (RUN_DIR=...run A=... B=...) -> results/bench/
	$(if $(RUN_DIR),,$(error make bench-lammps-settings needs RUN_DIR=results/<data set>/dem/<run>.run, a LAMMPS run \
	  with a checkpoint (one in progress, or stopped by Ctrl-C)))
	$(PY) -m pipeline.studies.bench_lammps_settings --run-dir $(RUN_DIR) --a "$(or $(A),atom_modify sort 0 0.0)" \
	  --b "$(or $(B),atom_modify sort 1000 0.0)" --out results/bench

# ---------------------------------------------------------------- set-up
venv: $(VENV_STAMP) ## the project virtualenv from pyproject.toml

$(VENV_STAMP): pyproject.toml | system-venv
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $@

system-venv: ## Debian's python3-venv, for the project's virtualenv (apt-get; a fresh Debian has no ensurepip)
	@if $(PYTHON) -c 'import ensurepip' 2>/dev/null; then echo "venv support present"; else \
	  $(SUDO) apt-get update -qq && $(APT_INSTALL) python3-venv; fi

system-lammps: ## Debian's LAMMPS for Debian's python3 (apt-get: lammps, python3-lammps, liblammps-dev, OpenMPI, mpi4py)
	@if /usr/bin/python3 -c 'import mpi4py, lammps; lammps.lammps(cmdargs=["-log", "none", "-screen", "none"]).close()' \
	  2>/dev/null; then echo "lammps present"; else \
	  $(SUDO) apt-get update -qq && $(APT_INSTALL) lammps python3-lammps liblammps-dev openmpi-bin python3-mpi4py; fi

system-slurm: ## Debian's slurm-wlm and munge, for the cluster test (apt-get)
	@if command -v slurmctld >/dev/null && command -v munged >/dev/null; then echo "slurm and munge present"; else \
	  $(SUDO) apt-get update -qq && $(APT_INSTALL) slurm-wlm munge; fi

system: system-venv ## Debian's Yade (apt-get); the scenes need only numpy and yade in Debian's python3
	@if command -v yade >/dev/null; then \
	  echo "yade present"; \
	else \
	  $(SUDO) apt-get update -qq && $(APT_INSTALL) yade; \
	fi

# ---------------------------------------------------------------- the pipeline
model-cycles: $(foreach t,$(MODEL_THETAS),$(MODEL_DIR)/theta$(t).csv) ## model cycles for the paper's six angles (Table 2)

$(MODEL_DIR)/theta%.csv: $(VENV_STAMP) model/*.py
	$(PY) -m model predict --theta $* --out $@

dem: system $(if $(filter lammps,$(ENGINE)),system-lammps) venv ## one DEM run -> results/<preset>/dem/theta<THETA>.h5 (resumes from its checkpoint; see README)
	$(PY) -m pipeline.runs run --theta $(THETA) $(DEM_ARGS)

sweep: system $(if $(filter lammps,$(ENGINE)),system-lammps) venv ## a sweep of runs (THETAS, ROTATE_ATS, SEEDS), LAUNCH=local (make -j) or slurm (a job array)
	$(PY) -m pipeline.runs.sweep run --preset $(PRESET) --thetas "$(THETAS)" \
	  $(if $(ROTATE_ATS),--rotate-ats "$(ROTATE_ATS)") $(if $(SEEDS),--seeds "$(SEEDS)") $(foreach s,$(SET),--set $(s)) \
	  --launch $(LAUNCH) $(foreach s,$(SLURM),--slurm $(s)) $(if $(JOBS),--jobs $(JOBS)) \
	  $(if $(filter-out 1,$(RANKS)),--ranks $(RANKS)) \
	  $(if $(filter 1 yes true,$(MANY)),--allow-many) --engine $(ENGINE)

runs: venv ## every DEM run here and committed: its folder, overrides, state (done, running, stopped, failed) and summary
	$(PY) -m pipeline.runs.listing

sweep-status: venv ## every run of the latest sweep (or SWEEP=<id>): done, running, queued, failed, stopped
	$(PY) -m pipeline.runs.sweep status $(if $(SWEEP),--sweep $(SWEEP))

sweep-collect: venv ## make fit, compare and figures on the data set of the latest sweep (or SWEEP=<id>)
	words="$$($(PY) -m pipeline.runs.sweep preset $(if $(SWEEP),--sweep $(SWEEP)))" && set -- $$words && \
	  preset=$$1 engine=$$2 && shift 2 && $(MAKE) --no-print-directory figures PRESET=$$preset ENGINE=$$engine SET="$$*"

demo-dem: system venv ## the quick-preset DEM runs of the demo: theta = 180 and 90, both at once
	$(MAKE) --no-print-directory -j2 demo-dem-180 demo-dem-90

# one demo run (the launcher itself skips a run that is done and resumes one that was stopped)
demo-dem-%: | $(VENV_STAMP)
	$(PY) -m pipeline.runs run --theta $* --preset quick

fit: $(FIT_DIR)/params.json ## calibrate on the preset's runs [FIT_FROM=0.005] [STRESS=all] [WEIGHT=angles] -> results/<data set>/fit/params.json, fit.json, fit.h5

WEIGHT_OPTION := $(if $(WEIGHT),--weight $(WEIGHT))
FIT_OPTIONS := $(if $(FIT_FROM),--fit-from $(FIT_FROM)) $(if $(STRESS),--stress $(STRESS)) $(WEIGHT_OPTION)
# the options of the last fit: a fit with other options is a new fit
$(FIT_DIR)/options.txt: FORCE
	@mkdir -p $(@D); echo '$(FIT_OPTIONS)' | cmp -s - $@ || echo '$(FIT_OPTIONS)' > $@

$(FIT_DIR)/params.json $(FIT_DIR)/fit.json $(FIT_DIR)/fit.h5 &: $(call RUN_FILES,$(DATA_PRESET)) $(VENV_STAMP) \
		$(DATASET_CODE) $(wildcard pipeline/calibration/*.py) $(FIT_DIR)/options.txt
	$(SAY_PRESET)
	$(PY) -m pipeline.calibration $(DATA_ARGS) $(FIT_OPTIONS)

fit-bootstrap: venv ## the fit plus a bootstrap of the DEM's noise (BOOT=100 refits, minutes) -> results/<data set>/fit-bootstrap/
	$(SAY_PRESET)
	$(PY) -m pipeline.calibration $(DATA_ARGS) --bootstrap $(BOOT) --out results/$(DATA_SET)/fit-bootstrap

fit-jackknife: venv ## the fit plus a refit leaving out each reversal seed (OVER=seeds) or each angle (OVER=angles) [FIT_FROM] [STRESS] [WEIGHT] -> results/<data set>/fit-jackknife-<OVER>[-from<FIT_FROM>][-<STRESS>][-per-angle]/
	$(SAY_PRESET)
	$(PY) -m pipeline.calibration $(DATA_ARGS) $(FIT_OPTIONS) --jackknife $(OVER)

fit-angles: venv ## the fit on the runs at some angles only (ANGLES="180 90 60 30", 180 among them) [FIT_FROM] [STRESS] [WEIGHT] -> results/<data set>/fit-angles-<ANGLES>[-from<FIT_FROM>][-<STRESS>][-per-angle]/
	$(if $(strip $(ANGLES)),,$(error ANGLES is empty: give the angles to fit, e.g. ANGLES="180 90 60 30"))
	$(SAY_PRESET)
	$(PY) -m pipeline.calibration $(DATA_ARGS) $(FIT_OPTIONS) --angles $(ANGLES)

fit-definitions: venv ## the global fit under each definition of strain, Phi and p [WEIGHT=angles] -> results/<data set>/fit/definitions.md
	$(SAY_PRESET)
	$(PY) -m pipeline.calibration.definitions $(DATA_ARGS) $(WEIGHT_OPTION)

fit-from: venv ## the fit past the reversal jump: gamma0 = 0, 0.005, 0.01 and a profile of k [WEIGHT=angles] -> fit/fit_from.md
	$(SAY_PRESET)
	$(PY) -m pipeline.calibration.restart $(DATA_ARGS) $(WEIGHT_OPTION)

fit-profile: venv ## the profile likelihood of every fitted parameter [STRAIN=bulk PHI=central] [WEIGHT=angles] (minutes) -> fit/profiles*.json
	$(SAY_PRESET)
	$(PY) -m pipeline.calibration.profile $(DATA_ARGS) --strain $(STRAIN) --phi $(PHI) $(WEIGHT_OPTION)

fidelity: venv ## the fidelity ladder (config/fidelity.toml): make its missing DEM runs (JOBS=2), then results/fidelity/
	$(PY) -m pipeline.studies.fidelity --run --jobs $(or $(JOBS),2) --engine $(ENGINE)
	$(PY) -m pipeline.figures.fidelity --table results/fidelity$(if $(filter-out yade,$(ENGINE)),-$(ENGINE))/table.json

fidelity-table: venv ## results/fidelity/ from the committed summaries and the runs present, no DEM (under a minute)
	$(PY) -m pipeline.studies.fidelity --engine $(ENGINE)
	$(PY) -m pipeline.figures.fidelity --table results/fidelity$(if $(filter-out yade,$(ENGINE)),-$(ENGINE))/table.json

profile-dem: venv ## where Yade's time goes, per engine (PRESETS=reduced,paper; THREADS=1) -> results/bench/dem_profile.md
	$(PY) -m pipeline.studies.profile_dem --presets $(or $(PRESETS),reduced$(comma)paper) --threads $(THREADS)

engines: venv ## Yade against LAMMPS on one preset (PRESET=reduced), seeds of each -> results/engines/engines.md
	$(PY) -m pipeline.studies.versus --a $(or $(PRESET_GIVEN),reduced)/yade --b $(or $(PRESET_GIVEN),reduced)/lammps \
	  --out results/engines

data-card: venv ## the data card's table of every committed run, from the files -> data/reference/README.md
	$(PY) -m pipeline.dataset.card

versus: venv ## any two data sets, seed against seed: A=preset[/engine][/key=value...] B=... -> results/versus/versus.md
	$(if $(and $(A),$(B)),,$(error make versus needs A=preset[/engine][/key=value...] and B=...; e.g. \
	  A=paper/yade/inertial_number=0.001/n_cycles=2 B=paper/lammps/inertial_number=0.001))
	$(PY) -m pipeline.studies.versus --a $(A) --b $(B) --out results/versus

cells: venv ## the reduced cell against the paper's (its data set, config/datasets.toml), seed against seed -> results/cells/cells.md
	$(PY) -m pipeline.studies.versus --a reduced --b paper --out results/cells

jump: venv ## the reversal jump: fabric and wall stress right after each change of direction, every run -> results/jump/
	$(PY) -m pipeline.studies.jump

stability: venv ## the DEM on stiff and extreme cases, small cells (about 15 min) -> results/fidelity/stability.md
	$(PY) -m pipeline.studies.stability

compare: $(COMPARE_DIR)/metrics.json ## the model against the preset's runs -> results/<data set>/compare/

$(COMPARE_DIR)/metrics.json $(COMPARE_DIR)/compare.h5 &: $(FIT_DIR)/params.json $(FIT_DIR)/fit.h5 \
		$(call RUN_FILES,$(DATA_PRESET)) $(DATASET_CODE) $(wildcard pipeline/comparison/*.py)
	$(PY) -m pipeline.comparison $(DATA_ARGS)

compare-seed: $(FIT_DIR)/params.json ## another seed's runs against the model, drawn: SEED=N -> results/<data set>/compare-seed<N>/ (figures, report.md)
	$(PY) -m pipeline.comparison $(DATA_ARGS) --seed $(SEED)
	$(PY) -m pipeline.figures $(DATA_ARGS) --compare results/$(DATA_SET)/compare-seed$(SEED)

figures: results/$(DATA_SET)/report.md ## Figs. 3-9 and report.md -> results/<data set>/figures/, report.md

results/$(DATA_SET)/report.md: $(COMPARE_DIR)/metrics.json $(COMPARE_DIR)/compare.h5 $(FIT_DIR)/fit.json \
		$(FIT_DIR)/fit.h5 $(wildcard pipeline/figures/*.py $(FIT_DIR)/fit_from.json)
	$(PY) -m pipeline.figures $(DATA_ARGS)

clean: ## remove generated results (keeps the venv and the DEM runs under results/<preset>/dem/)
	rm -rf results/model results/bench results/fidelity results/jump results/engines results/versus results/cells results/*/fit results/*/fit-* results/*/compare results/*/compare-* results/*/figures results/*/report.md
