# grasptask: `make demo` sets everything up and runs the bundled pipeline; `make test` runs the checks.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
INSTALLED := $(VENV)/.installed
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: demo test install lint format bench clean

demo: $(INSTALLED)
	$(BIN)/grasptask pipeline run pipelines/demo.yaml

test: $(INSTALLED)
	$(BIN)/ruff check grasptask tests benchmarks
	$(BIN)/ruff format --check grasptask tests benchmarks
	$(BIN)/python -m pytest

install: $(INSTALLED)

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(INSTALLED): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

lint: $(INSTALLED)
	$(BIN)/ruff check grasptask tests benchmarks

format: $(INSTALLED)
	$(BIN)/ruff format grasptask tests benchmarks

bench: $(INSTALLED)
	$(BIN)/python benchmarks/task_modelling.py

clean:
	rm -rf results $(VENV) *.egg-info
