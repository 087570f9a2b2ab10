# Two commands do all the set-up on a fresh machine: `make run` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

CHROMIUM ?= /usr/bin/chromium

.PHONY: run test bench fuzz mutation docs clean chromium

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

## run: drive the default job on the built-in emulator, in real time
run: $(STAMP)
	$(BIN)/autonomy run missions/square.yaml

## chromium: the browser tests' headless Chromium (Debian's package), installed when root can
chromium:
	@if [ -x "$(CHROMIUM)" ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing Debian's chromium for the browser tests"; \
		(apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium) >/dev/null \
		|| { echo "make test: apt-get could not install chromium; install it, or set CHROMIUM=/path/to/chromium"; exit 1; }; \
	else echo "make test: the browser tests need Chromium: run 'sudo apt-get install chromium' or set CHROMIUM=/path/to/chromium"; exit 1; fi

## test: lint and the whole test suite, browser tests in headless Chromium included
test: $(STAMP) chromium
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	AUTONOMY_CHROMIUM="$(CHROMIUM)" $(BIN)/python -m pytest -q -n 2

## fuzz: the fuzz tests run long: 100,000 mutants, texts and reply byte strings, 10,000 YAML documents
fuzz: $(STAMP)
	AUTONOMY_FUZZ_CASES=100000 $(BIN)/python -m pytest -q tests/fuzz

## mutation: mutation testing of the five modules where a change shows (mutmut; hours on 2 cores), then the score
mutation: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[test,mutation]'
	-$(BIN)/mutmut run
	$(BIN)/python benchmarks/mutation.py

## bench: every benchmark (the latest figures go in the README, their history in docs/performance.md)
bench: $(STAMP)
	$(BIN)/python benchmarks/link.py
	$(BIN)/python benchmarks/missions.py
	$(BIN)/python benchmarks/views.py
	$(BIN)/python benchmarks/hostile.py
	$(BIN)/python benchmarks/groot.py
	$(BIN)/python benchmarks/grading.py
	$(BIN)/python benchmarks/work.py

## docs: make the node reference in docs/missions.md anew from the registry
docs: $(STAMP)
	$(BIN)/python -c "from autonomy.mission.catalogue import update_reference; update_reference('docs/missions.md')"

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache .hypothesis mutants
