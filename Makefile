# Two commands do all the set-up on a fresh machine: `make run` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test bench docs clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

## run: drive the default job on the built-in emulator, in real time
run: $(STAMP)
	$(BIN)/autonomy run missions/square.yaml

## test: lint and the whole test suite
test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/python -m pytest -q

## bench: the link, emulator and mission benchmarks (figures for the README)
bench: $(STAMP)
	$(BIN)/python benchmarks/link.py
	$(BIN)/python benchmarks/missions.py

## docs: make the node reference in docs/missions.md anew from the registry
docs: $(STAMP)
	$(BIN)/python -c "from autonomy.mission.catalogue import update_reference; update_reference('docs/missions.md')"

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache .hypothesis
