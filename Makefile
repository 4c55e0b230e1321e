# Quick start: `make demo` (set up + simulate the Jansen leg), `make test` (set up + run the suite).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin

.PHONY: demo test test-all bench schemas clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e '.[test]'
	touch $(VENV)/.installed $@

demo: $(VENV)/.installed
	$(BIN)/linkedit simulate examples/jansen.yaml -o out/jansen.h5 --svg out/jansen.svg
	@echo "linkedit is installed in $(VENV)/: run 'source $(VENV)/bin/activate' (or call $(BIN)/linkedit), then e.g. 'linkedit validate examples/klann.yaml'"

test: $(VENV)/.installed-test
	$(BIN)/python -m mypy linkedit tests/notebook_types.py
	$(BIN)/python -m pytest -q -n 2 --dist loadfile

test-all: $(VENV)/.installed-test
	$(BIN)/python -m mypy linkedit tests/notebook_types.py
	$(BIN)/python -m pytest -q -m ''

bench: $(VENV)/.installed
	$(BIN)/linkedit bench

schemas: $(VENV)/.installed
	$(BIN)/linkedit schemas specs/

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis
