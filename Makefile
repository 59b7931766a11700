# grasptask: `make demo` sets everything up and runs the bundled pipeline; `make test` runs the checks.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
INSTALLED := $(VENV)/.installed
CYIPOPT := $(VENV)/.cyipopt
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: demo paper test test-slow docs install setup-cyipopt setup-browser lint format typecheck bench screenshot clean

demo: $(INSTALLED)
	$(BIN)/grasptask pipeline run pipelines/demo.yaml

# the paper reproduction: 3 x 126 synthesis starts, their physics check and export, report checked in Chromium
# (the runner prints the time it took at the end; README: Two commands)
paper: $(INSTALLED) setup-browser
	$(BIN)/grasptask pipeline run pipelines/paper.yaml

# pytest in two processes (the suite is CPU-bound, 2 cores); --dist loadfile keeps each module's fixtures in one
test: $(INSTALLED) $(CYIPOPT) setup-browser
	$(BIN)/ruff check grasptask tests benchmarks tools
	$(BIN)/ruff format --check grasptask tests benchmarks tools
	$(BIN)/mypy
	$(BIN)/lint-imports
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet
	$(BIN)/python -m pytest -n 2 --dist loadfile

# the long end-to-end runs that `make test` leaves out to keep CI short (GP objects, Dask, every hand x task, ...)
test-slow: $(INSTALLED) $(CYIPOPT) setup-browser
	$(BIN)/python -m pytest -n 2 --dist loadfile -m slow

# the docs site, built offline into site/ (open site/index.html); its tables come from benchmarks/results/
docs: $(INSTALLED)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

install: $(INSTALLED)

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(INSTALLED): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

# the second solver backend: cyipopt built against the IPOPT that CasADi's wheel ships (pip only)
setup-cyipopt: $(CYIPOPT)

$(CYIPOPT): $(INSTALLED) tools/setup_cyipopt.sh
	tools/setup_cyipopt.sh $(BIN)/python
	touch $@

# Debian's chromium + chromium-driver for the report's browser check (apt-get; skipped without root)
setup-browser:
	tools/setup_browser.sh

lint: $(INSTALLED)
	$(BIN)/ruff check grasptask tests benchmarks tools

format: $(INSTALLED)
	$(BIN)/ruff format grasptask tests benchmarks tools

typecheck: $(INSTALLED)
	$(BIN)/mypy

# the README's picture of the report, made anew from the demo
screenshot: $(INSTALLED) setup-browser
	tools/screenshot.sh $(BIN)

bench: $(INSTALLED) $(CYIPOPT)
	$(BIN)/python benchmarks/task_modelling.py
	$(BIN)/python benchmarks/mechanics.py
	$(BIN)/python benchmarks/synthesis.py

clean:
	rm -rf results $(VENV) *.egg-info
