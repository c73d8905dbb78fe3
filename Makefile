# Quick start: `make demo` (set up, build, run the main job), `make test` (the whole suite).
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
VENV45 := .venv45
VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' blender_manifest.toml)
ZIP := dist/bo2_lighting-$(VERSION).zip

.PHONY: demo test venv venv45 build lint clean

venv: $(VENV)/.installed
$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -e '.[dev,blender50]'
	touch $@

venv45: $(VENV45)/.installed
$(VENV45)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV45)
	$(VENV45)/bin/pip install --quiet --upgrade pip
	$(VENV45)/bin/pip install --quiet -e '.[dev,blender45]'
	touch $@

build: venv
	$(VENV)/bin/python tools/build_extension.py

demo: venv build
	$(VENV)/bin/python tools/demo.py

lint: venv
	$(VENV)/bin/ruff check .

test: venv venv45 build lint
	$(VENV)/bin/pytest tests/core tests/cli tests/blender
	$(VENV45)/bin/pytest tests/blender

clean:
	rm -rf dist out build wheels *.egg-info
