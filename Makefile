# Two commands on a fresh clone:  `make demo`  and  `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint demo-data linear-motor-data bench calibration blind study control \
	fibre-models control-ankle clean

# setuptools' "Editable installation" warning is about folders named like the package in the
# working directory: none here, and a user can do nothing about it
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	PYTHONWARNINGS="ignore:Editable installation" \
	  $(BIN)/python -m pip install --quiet -c constraints.txt -e '.[dev]'
	touch $(STAMP)

## demo: set up .venv and run the main job on the shipped demo data
demo: $(STAMP)
	$(BIN)/hmid run configs/demo.yaml

## test: set up .venv, lint, type-check, and run the test suite
test: $(STAMP)
	$(BIN)/ruff check hmid tests benchmarks pipelines
	$(BIN)/mypy
	$(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check hmid tests benchmarks pipelines
	$(BIN)/ruff format --check hmid tests benchmarks pipelines
	$(BIN)/mypy

## demo-data: regenerate data/demo/ from configs/simulate/demo.yaml (fixed seeds)
demo-data: $(STAMP)
	$(BIN)/hmid simulate configs/simulate/demo.yaml --out data/demo --replace

## linear-motor-data: regenerate data/linear-motor/ (the linear-motor stage's simulated logs)
linear-motor-data: $(STAMP)
	$(BIN)/hmid simulate configs/simulate/linear-motor.yaml --out data/linear-motor --replace

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

## calibration: every family's interval coverage against known truth (issues 15, 30; tens of minutes)
calibration: $(STAMP)
	$(BIN)/python benchmarks/bench_calibration_polynomial.py --replications 200
	$(BIN)/python benchmarks/bench_calibration_polynomial.py --replications 120 --seconds 3
	$(BIN)/python benchmarks/bench_calibration_polynomial.py --replications 120 --seconds 3 --trajectory sines
	$(BIN)/python benchmarks/bench_calibration_sindy.py --replications 100
	$(BIN)/python benchmarks/bench_calibration_balance.py --replications 200
	$(BIN)/python benchmarks/bench_calibration_friction.py --replications 300
	$(BIN)/python benchmarks/bench_sls_calibration.py --posterior exact --datasets 120
	$(BIN)/python benchmarks/bench_sls_calibration.py --posterior exact --datasets 40 --samples 32000 \
	  --skip-speed --case smoothed:iid+sandwich

## blind: the full blind suite of the loop (about half an hour on 2 cores)
blind: $(STAMP)
	$(BIN)/hmid blind configs/blind/full.yaml --workers 2

## control: model-based control of the simulated Ch. 4 rig with the demo's model (after make demo)
control: $(STAMP)
	$(BIN)/hmid control configs/control/muscle.yaml

## fibre-models: the ankle's fibre models: each fibre type simulated on the Ch. 4 rig, identified
fibre-models: $(STAMP)
	$(BIN)/hmid simulate configs/simulate/fibre-gastrocnemius.yaml --out data/fibre-gastrocnemius --replace
	$(BIN)/hmid simulate configs/simulate/fibre-soleus.yaml --out data/fibre-soleus --replace
	$(BIN)/hmid run configs/fibre-gastrocnemius.yaml
	$(BIN)/hmid run configs/fibre-soleus.yaml

## control-ankle: model-based control of the simulated Ch. 6 ankle with the fibre models
control-ankle: fibre-models
	$(BIN)/hmid control configs/control/ankle.yaml

## study: the pneumatic cylinder's three seals on the measured logs (skips if ../shared is absent)
study: $(STAMP)
	@if [ -d ../shared/data/pneumatic-friction ]; then \
	  $(BIN)/hmid sweep configs/sweeps/pneumatic-seals.yaml; \
	else echo "study skipped: ../shared/data/pneumatic-friction is absent (see docs/logs.md, Real data)"; fi

clean:
	rm -rf $(VENV)
