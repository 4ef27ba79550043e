# Entry points: `make demo` (the main job), `make test` and `make bench` (the benchmarks). All
# build .venv from scratch with nothing but python3, so they work on a clean clone and in CI:
# the package editable with its test and benchmarks extras (tests/test_bench.py runs the
# benchmarks).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test bench bench-scale wheel-check clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,benchmarks]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/rsp-inertia demo

test: $(STAMP)
	$(BIN)/python -m pytest -q

# Accuracy and speed sweep -> benchmarks/results/ (cases/*.json made by the same code are reused;
# options through BENCH_ARGS, e.g. make bench BENCH_ARGS='--quick --out /tmp/bq'); the other
# benchmarks: python -m benchmarks.<name> (benchmarks/__init__.py lists them).
BENCH_ARGS ?=
bench: $(STAMP)
	$(BIN)/python -m benchmarks.sweep $(BENCH_ARGS)

# Wall time and peak memory of simulate, program, identify and calibrate against braking
# length and sample rate -> benchmarks/results/scale.md, scale.json, scale.png (tens of
# minutes; options through SCALE_ARGS, e.g. make bench-scale SCALE_ARGS='--quick --out
# /tmp/scale.md').
SCALE_ARGS ?=
bench-scale: $(STAMP)
	$(BIN)/python -m benchmarks.scale $(SCALE_ARGS)

# The wheel as users install it, in a fresh venv outside the checkout: builds without
# warnings, holds only rsp_inertia, runs `rsp-inertia --version` and the demo (CI runs it).
wheel-check:
	PYTHON=$(PYTHON) .ci/wheel-check

clean:
	rm -rf $(VENV) build dist *.egg-info
