# Entry points (`make help`) and the DAG of files results/<D>/dem/*.h5 -> fit/params.json -> compare/metrics.json ->
# report.md (<D>: the data set's folder, results/.make/goals/); a step reruns only when what it reads changed.
# The variables a user may set (each becomes text, checked in Python); this list and the guards are `override`.
override USER_VARIABLES := THETA PRESET ENGINE RANKS ROTATE_AT SET FRESH THREADS ALLOW_INERTIAL PRESETS ENGINES FIT_FROM STRESS \
	WEIGHT ANGLES OVER BOOT STRAIN PHI THETAS ROTATE_ATS SEEDS LAUNCH SLURM JOBS MANY SWEEP SEED A B RUN_DIR VARIANT ACROSS \
	LAWS SKIP_CYCLES CASES POINTS LADDER NAMES
# any other variable on the command line (PY, FIT_DIR, ...: its value would run as Make text) is refused by its name
# before Make expands anything, and so is -e (MAKEFLAGS=e: the environment would replace the Makefile's own values)
override NOT_USER_VARIABLES := $(strip $(foreach v,$(.VARIABLES),$(if $(filter command line,$(origin $(v))),$(if \
	$(filter $(v),$(USER_VARIABLES)),,$(v)))))
$(if $(NOT_USER_VARIABLES),$(error $(NOT_USER_VARIABLES): not a variable a user sets (those are: $(USER_VARIABLES))))
override MAKE_LETTERS := $(if $(filter -%,$(firstword $(MAKEFLAGS))),,$(firstword $(MAKEFLAGS)))
$(if $(findstring e,$(MAKE_LETTERS)),$(error make -e (or MAKEFLAGS=e) would let the environment replace the \
	Makefile's own variables: run make without it))
SHELL := /bin/bash
.DEFAULT_GOAL := help
.DELETE_ON_ERROR:

VENV := .venv
PY := $(VENV)/bin/python
VENV_STAMP := $(VENV)/.installed
SUDO := $$([ "$$(id -u)" = 0 ] || echo sudo)
APT_INSTALL := DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends
MODEL_THETAS := 030 060 090 120 150 180
MODEL_DIR := results/model

# ---------------------------------------------------------------- the user's variables: text, checked in Python
# Each is exported as text Make never expands and no recipe holds; `python -m pipeline.targets` checks and uses them.
$(foreach v,$(USER_VARIABLES),$(eval override $(v) := $$(value $(v))))
export $(USER_VARIABLES)
TARGETS := $(PY) -m pipeline.targets
comma := ,
# LAMMPS is installed only for a LAMMPS target, Yade only for a Yade one ($(filter) reads the text; nothing expands it)
LAMMPS_IF_ASKED := $(if $(filter lammps,$(ENGINE) $(subst $(comma), ,$(ENGINES))),system-lammps)
ENGINE_SYSTEM := $(if $(filter lammps,$(ENGINE)),system-lammps,system)
STAGES := bench dem sweep runs sweep-status sweep-collect fit-bootstrap fit-jackknife fit-angles fit-definitions fit-from \
	fit-profile fidelity fidelity-table profile-dem bench-dem bench-lammps-settings engines data-card versus cells jump \
	stability models budget
CHECKED_GOALS := $(filter $(STAGES) fit compare compare-seed figures,$(MAKECMDGOALS))
# a checked goal's values (results/.make/goals/, read as text: $(file <) never expands) and their stamp, which Make
# includes (it reads itself again where the values changed); empty otherwise, never from the environment
CHECK_ERROR :=
DATA_SET :=
FIT_SUFFIX :=
ifneq ($(CHECKED_GOALS),)
include results/.make/goals.stamp
CHECK_ERROR := $(file <results/.make/goals/CHECK_ERROR)
DATA_SET := $(file <results/.make/goals/DATA_SET)
FIT_SUFFIX := $(file <results/.make/goals/FIT_SUFFIX)
endif
results/.make/goals.stamp: FORCE
	@python3 -m pipeline.targets makefile $@ $(CHECKED_GOALS)
check:
	$(if $(CHECK_ERROR),$(error $(CHECK_ERROR)))
$(CHECKED_GOALS): check
system-venv system system-lammps system-slurm $(VENV_STAMP): | check

# a fit and its comparison are named by the options that set their numbers (pipeline/calibration/naming.py)
FIT_DIR := results/$(DATA_SET)/fit$(FIT_SUFFIX)
COMPARE_DIR := results/$(DATA_SET)/compare$(FIT_SUFFIX)
REPORT := $(if $(FIT_SUFFIX),$(COMPARE_DIR),results/$(DATA_SET))/report.md
# every writer renames its complete outputs into place: an interrupted step keeps the previous set, Make too
.PRECIOUS: $(FIT_DIR)/params.json $(FIT_DIR)/fit.json $(FIT_DIR)/fit.h5 $(COMPARE_DIR)/metrics.json \
	$(COMPARE_DIR)/compare.h5 $(REPORT)
DATASET_CODE := $(filter-out pipeline/variables.py,$(wildcard pipeline/*.py pipeline/dataset/*.py model/*.py \
	config/raw_schema.toml))

FORCE:
.PHONY: FORCE help demo test test-unit test-yade test-cluster lint bench venv system system-venv system-lammps \
	system-slurm model-cycles demo-dem clean check $(STAGES)

help: ## list the targets
	@grep -E '^[a-zA-Z_-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN{FS=":.*## "}{printf "  make %-14s %s\n", $$1, $$2}'

demo: system venv model-cycles demo-dem ## set up everything, then run the pipeline on the small default [PRESET=quick] [SET=...]
	PRESET=$${PRESET:-quick} $(MAKE) --no-print-directory figures
	@echo "demo done: model cycles in $(MODEL_DIR)/, DEM runs, fit, figures and report.md in the data set's folder (results/quick/ by default)"

# ---------------------------------------------------------------- tests and lint
test: system system-lammps system-slurm venv lint ## lint, then every test (the real Yade and LAMMPS, a real one-node SLURM): what CI runs
	$(PY) -m pytest -q -n 2 --dist loadfile --durations=40
test-unit: venv ## the fast unit tests (no Yade, LAMMPS or SLURM, nothing marked slow): under a minute of CPU
	$(PY) -m pytest -q tests/unit -m "not slow and not yade and not lammps and not slurm"
test-yade: system system-lammps venv ## the tests that run the real Yade (and LAMMPS)
	$(PY) -m pytest -q tests/integration
test-cluster: system system-slurm venv ## a sweep on a real one-node SLURM cluster started on this machine
	$(PY) -m pytest -q tests/cluster
lint: venv ## ruff over the whole project
	$(PY) -m ruff check .

bench: system $(LAMMPS_IF_ASKED) venv ## benchmarks: model numerics, the material-point update (POINTS=100000), DEM steps/s (as bench-dem) and the cost of our Python, in results/bench/

# ---------------------------------------------------------------- set-up
venv: $(VENV_STAMP) ## the project virtualenv from pyproject.toml
$(VENV_STAMP): pyproject.toml | system-venv
	python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $@
system-venv: ## Debian's python3-venv, for the project's virtualenv (apt-get; a fresh Debian has no ensurepip)
	@if python3 -c 'import ensurepip' 2>/dev/null; then echo "venv support present"; else \
	  $(SUDO) apt-get update -qq && $(APT_INSTALL) python3-venv; fi
system-lammps: ## Debian's LAMMPS for Debian's python3 (apt-get: lammps, python3-lammps, liblammps-dev, OpenMPI, mpi4py, scipy, iproute2)
	@if /usr/bin/python3 -c 'import mpi4py, scipy, lammps; lammps.lammps(cmdargs=["-log", "none", "-screen", "none"]).close()' \
	  2>/dev/null && command -v ip >/dev/null && command -v unshare >/dev/null; then echo "lammps present"; else \
	  $(SUDO) apt-get update -qq && $(APT_INSTALL) lammps python3-lammps liblammps-dev openmpi-bin python3-mpi4py \
	  python3-scipy iproute2 util-linux; fi
system-slurm: ## Debian's slurm-wlm and munge, for the cluster test (apt-get)
	@if command -v slurmctld >/dev/null && command -v munged >/dev/null; then echo "slurm and munge present"; else \
	  $(SUDO) apt-get update -qq && $(APT_INSTALL) slurm-wlm munge; fi
system: system-venv ## Debian's Yade and scipy (apt-get); the scenes need numpy, scipy and yade in Debian's python3
	@if command -v yade >/dev/null && /usr/bin/python3 -c 'import scipy' 2>/dev/null; then echo "yade present"; else \
	  $(SUDO) apt-get update -qq && $(APT_INSTALL) yade python3-scipy; fi

# ---------------------------------------------------------------- the user's targets: checked, then run by Python
dem: $(ENGINE_SYSTEM) venv ## one DEM run THETA=90 [PRESET=quick] [ENGINE=lammps] [SET=...] -> results/<preset>/dem/theta<THETA>.h5 (resumes; see README)
sweep: $(ENGINE_SYSTEM) venv ## a sweep of runs (THETAS, ROTATE_ATS, SEEDS), LAUNCH=local (make -j) or slurm (a job array)
runs: venv ## every DEM run here and committed: its folder, overrides, state (done, running, stopped, failed) and summary
sweep-status: venv ## every run of the latest sweep (or SWEEP=<id>): done, running, queued, failed, stopped
sweep-collect: venv ## make fit, compare and figures on the data set of the latest sweep (or SWEEP=<id>)
fit-bootstrap: venv ## the fit plus a bootstrap of the DEM's noise (BOOT=100 refits, minutes) -> results/<data set>/fit-bootstrap/
fit-jackknife: venv ## the fit plus a refit leaving out each reversal seed (OVER=seeds) or each angle (OVER=angles) [FIT_FROM] [STRESS] [WEIGHT] -> results/<data set>/fit-jackknife-<OVER>[...]/
fit-angles: venv ## the fit on the runs at some angles only (ANGLES="180 90 60 30", 180 among them) [FIT_FROM] [STRESS] [WEIGHT] -> results/<data set>/fit-angles-<ANGLES>[...]/
fit-definitions: venv ## the global fit under each definition of strain, Phi and p [WEIGHT=angles] -> results/<data set>/fit[-per-angle][-skip<K>]/definitions.md
fit-from: venv ## the fit past the reversal jump: gamma0 = 0, 0.005, 0.01 and a profile of k [WEIGHT=angles] -> fit/fit_from.md
fit-profile: venv ## the profile likelihood of every fitted parameter [STRAIN=bulk PHI=central] [WEIGHT=angles] [POINTS=9 per parameter] [NAMES=C,b2: those only] (minutes) -> fit/profiles*.json
fidelity: venv ## the fidelity ladder (LADDER=config/fidelity.toml): make its missing DEM runs (JOBS=2), then results/fidelity[-<ladder>]/
fidelity-table: venv ## results/fidelity[-<ladder>]/ from the committed summaries and the runs present, no DEM [LADDER] (under a minute)
profile-dem: system venv ## where Yade's time goes, per engine (PRESETS=reduced,paper; THREADS=1) -> results/bench/dem_profile.md
bench-dem: system $(LAMMPS_IF_ASKED) venv ## DEM steps/s, bare and production loop (PRESETS=quick,reduced,paper; ENGINES=yade,lammps) -> results/bench/
bench-lammps-settings: system-lammps venv ## LAMMPS steps/s, two settings side by side from a run's checkpoint (RUN_DIR=...run A=... B=...) -> results/bench/
engines: venv ## Yade against LAMMPS on one preset (PRESET=reduced), seeds of each -> results/engines/engines.md
data-card: venv ## the data card's table of every committed run, from the files -> data/reference/README.md
versus: venv ## any two data sets, seed against seed and cycle by cycle: A=preset[/engine][/key=value...] B=... -> results/versus/versus.md
cells: venv ## the reduced cell against the paper's (its data set, config/datasets.toml), seed against seed -> results/cells/cells.md
jump: venv ## the reversal jump: fabric and wall stress right after each change of direction, every run -> results/jump/
stability: system venv ## the DEM on stiff and extreme cases, small cells (about 15 min; CASES=baseline,dt0.5 for some) -> results/fidelity/stability.md
budget: venv ## what the contacts do after each change of direction (made, lost, kept; networks; persistence) against Eq. 13 and make models' laws [PRESET] [ENGINE] -> results/<data set>/budget/
models: venv ## every fabric law fitted and judged on runs it was not fitted on [PRESET] [ACROSS=reduced, or none] [LAWS=rk2025,elastic] -> results/<data set>/models/
$(STAGES): check
	$(TARGETS) $@

model-cycles: $(foreach t,$(MODEL_THETAS),$(MODEL_DIR)/theta$(t).csv) ## model cycles for the paper's six angles (Table 2)
$(MODEL_DIR)/theta%.csv: $(VENV_STAMP) model/*.py
	$(PY) -m model predict --theta $* --out $@

demo-dem: $(ENGINE_SYSTEM) venv ## the demo's DEM runs, theta = 180 and 90 at once [PRESET=quick] [ENGINE=...] [SET=...]
	$(MAKE) --no-print-directory -j2 demo-dem-180 demo-dem-90

# one demo run, as `make dem THETA=<stem>` (the launcher skips a run that is done and resumes one that was stopped)
demo-dem-%: | $(VENV_STAMP)
	THETA=$* $(TARGETS) dem

# ---------------------------------------------------------------- the data set's files: fit -> compare -> figures
fit: $(FIT_DIR)/params.json ## calibrate on the data set's runs [PRESET=...] [FIT_FROM=0.005] [STRESS=all] [WEIGHT=angles] [VARIANT=loading] [SKIP_CYCLES=1] -> results/<data set>/fit[-<options>]/
# the fit's options and its runs' SHA-256: other options or a changed, added or removed run remake fit and comparison
$(FIT_DIR)/options.txt: FORCE
	@python3 -m pipeline.targets fit-options $@

$(FIT_DIR)/params.json $(FIT_DIR)/fit.json $(FIT_DIR)/fit.h5 &: $(VENV_STAMP) $(DATASET_CODE) \
		$(wildcard pipeline/calibration/*.py) $(FIT_DIR)/options.txt
	$(TARGETS) fit

compare: $(COMPARE_DIR)/metrics.json ## the model against the data set's runs -> results/<data set>/compare/
$(COMPARE_DIR)/metrics.json $(COMPARE_DIR)/compare.h5 &: $(FIT_DIR)/params.json $(FIT_DIR)/fit.h5 \
		$(FIT_DIR)/options.txt $(DATASET_CODE) $(wildcard pipeline/comparison/*.py)
	$(TARGETS) compare

compare-seed: check $(FIT_DIR)/params.json ## another seed's runs against the model, drawn: SEED=N -> results/<data set>/compare-seed<N>/
	$(TARGETS) $@

figures: $(REPORT) ## Figs. 3-9 and report.md -> results/<data set>/figures/, report.md (another law's or option's: in its compare-<...>/)
$(REPORT): $(COMPARE_DIR)/metrics.json $(COMPARE_DIR)/compare.h5 $(FIT_DIR)/fit.json \
		$(FIT_DIR)/fit.h5 $(wildcard pipeline/figures/*.py $(FIT_DIR)/fit_from.json)
	$(TARGETS) figures

clean: ## remove generated results (keeps the venv and the DEM runs under results/<preset>/dem/)
	rm -rf results/.make results/model results/bench results/fidelity results/jump results/engines results/versus \
	  results/cells results/*/fit results/*/fit-* results/*/compare results/*/compare-* results/*/figures \
	  results/*/report.md
