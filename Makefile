# Two commands do all set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo demo-smoke intervals showcase test generate bench lint clean clean-numba robustness docs

# The main job on the embedded default: generate (or reuse) the synthetic dataset, train the
# CPU-sized SSPINNpose configuration (five 500-step starts, then the chosen one to 12,000 steps;
# rerunning continues an unfinished run), calibrate its quality score (training split) and its
# 90 % intervals (validation split), evaluate it on the six held-out test subjects (walking
# and running; test/), then adapt it, self-supervised, to their unlabeled IMU recordings (1,000
# steps; labels never read) and evaluate again (test_adapted/). The variables let CI run the
# same recipe on a tiny configuration (demo-smoke).
SYNTH_CONFIG ?= configs/synth/default.yaml
TRAIN_CONFIG ?= configs/sspinn/demo.yaml
SYNTH        ?= data/synth_default
DEMO         ?= results/demo
ADAPT_FLAGS  ?=
CACHE        ?=
# labelled split, not trained on, that the 90 % intervals are calibrated on (empty: none)
UNCERTAINTY_SPLIT ?= val

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m predictive synth --config $(SYNTH_CONFIG) --out $(SYNTH) $(if $(CACHE),--cache-dir $(CACHE))
	$(BIN)/python -m sspinn train --config $(TRAIN_CONFIG) --data $(SYNTH) --out $(DEMO)/run --auto-resume
	$(BIN)/python -m sspinn calibrate-quality --model $(DEMO)/run/model.pt --data $(SYNTH) --split train
	$(if $(UNCERTAINTY_SPLIT),$(BIN)/python -m sspinn calibrate-uncertainty --model $(DEMO)/run/model.pt --data $(SYNTH) --split $(UNCERTAINTY_SPLIT) --check test)
	$(BIN)/python -m sspinn evaluate --model $(DEMO)/run/model.pt --data $(SYNTH) --split test --out $(DEMO)/test --overwrite
	$(BIN)/python -m sspinn adapt --model $(DEMO)/run/model.pt --data $(SYNTH) --split test --out $(DEMO)/adapted --auto-resume $(ADAPT_FLAGS)
	$(BIN)/python -m sspinn evaluate --model $(DEMO)/adapted/model.pt --data $(SYNTH) --split test --out $(DEMO)/test_adapted --overwrite

# After `make demo`: the demo model's 90 % intervals calibrated on 16 calibration subjects of
# their own (configs/synth/calibration.yaml) instead of the 2 validation subjects, written beside
# the model as model.calibration_subjects.uncertainty.json, and the test split evaluated with them
# (test_intervals/). Use the file with `sspinn infer/evaluate --uncertainty FILE`.
CALIBRATION_CONFIG ?= configs/synth/calibration.yaml
CALIBRATION        ?= data/synth_calibration
intervals: $(STAMP)
	$(BIN)/python -m predictive synth --config $(CALIBRATION_CONFIG) --out $(CALIBRATION) $(if $(CACHE),--cache-dir $(CACHE))
	$(BIN)/python -m sspinn calibrate-uncertainty --model $(DEMO)/run/model.pt --data $(CALIBRATION) --split val \
		--out $(DEMO)/run/model.calibration_subjects.uncertainty.json
	$(BIN)/python -m sspinn evaluate --model $(DEMO)/run/model.pt --data $(SYNTH) --split test --out $(DEMO)/test_intervals \
		--uncertainty $(DEMO)/run/model.calibration_subjects.uncertainty.json --overwrite

# CI: the main job's path end to end from a cold start (tiny dataset generated into a fresh cache,
# 20 training steps, evaluation, report), so that a broken `make demo` cannot land.
demo-smoke: $(STAMP)
	rm -rf results/demo_smoke
	$(MAKE) demo SYNTH_CONFIG=configs/synth/smoke.yaml TRAIN_CONFIG=configs/sspinn/smoke.yaml \
		SYNTH=results/demo_smoke/data DEMO=results/demo_smoke CACHE=results/demo_smoke/cache ADAPT_FLAGS="--steps 5" \
		UNCERTAINTY_SPLIT=
	test -s results/demo_smoke/test/report.md
	test -s results/demo_smoke/test_adapted/report.md

showcase: $(STAMP)
	$(BIN)/python -m sspinn showcase --out results/showcase

test: $(STAMP)
	$(BIN)/python -m pytest -q

generate: $(STAMP)
	$(BIN)/python -m sspinn.model.codegen

bench: $(STAMP)
	$(BIN)/python -m benchmarks.speed.bench_dynamics

# Optimisation tests + the default synthetic dataset (cold) under 12 simulated other machines.
robustness: $(STAMP)
	$(BIN)/python scripts/check_robustness.py --out results/robustness --jobs 2

# The API reference from the docstrings (pdoc, the `docs` extra) into docs/api/ (not committed).
docs: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	$(BIN)/python scripts/build_api_docs.py --out docs/api

lint: $(STAMP)
	$(BIN)/ruff check .

# numba caches each compiled function under __pycache__ keyed on its own file only: after an update
# that changes a kernel another file's kernels call, `make clean-numba` drops the stale copies.
clean-numba:
	find . -path ./$(VENV) -prune -o \( -name '*.nbi' -o -name '*.nbc' \) -print -exec rm -f {} +

clean: clean-numba
	rm -rf $(VENV) results .pytest_cache
