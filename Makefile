# Two commands do all set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo showcase test generate bench lint clean

# The main job on the embedded default: generate (or reuse) the small synthetic dataset, train the
# CPU-sized SSPINNpose configuration (≤ 13 min; rerunning continues an unfinished run) and evaluate
# it on the held-out test subject.
SYNTH := data/synth_default
DEMO  := results/demo

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m predictive synth --config configs/synth/default.yaml --out $(SYNTH)
	$(BIN)/python -m sspinn train --config configs/sspinn/demo.yaml --data $(SYNTH) --out $(DEMO)/run --auto-resume
	$(BIN)/python -m sspinn evaluate --model $(DEMO)/run/model.pt --data $(SYNTH) --split test --out $(DEMO)/test

showcase: $(STAMP)
	$(BIN)/python -m sspinn showcase --out results/showcase

test: $(STAMP)
	$(BIN)/python -m pytest -q

generate: $(STAMP)
	$(BIN)/python -m sspinn.codegen

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_dynamics.py

lint: $(STAMP)
	$(BIN)/ruff check .

clean:
	rm -rf $(VENV) results .pytest_cache
