# Two commands do all the set-up on a fresh machine: `make run` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# The exact versions, with their hashes, that .venv is made of (`make lock` makes it anew).
LOCK := requirements.lock
# uv makes the lock: one file for every platform and Python from 3.10 that pip installs.
UV_VERSION := 0.13.9

CHROMIUM ?= /usr/bin/chromium

.PHONY: run test test-latest test-pyyaml lock bench fuzz mutation docs clean chromium vendor pictures

# .venv is made anew whenever the lock or pyproject.toml changes, so that it holds the lock and nothing else.
$(STAMP): $(LOCK) pyproject.toml
	$(PYTHON) -m venv --clear $(VENV)
	$(BIN)/python -m pip install --quiet --require-hashes -r $(LOCK)
	$(BIN)/python -m pip install --quiet --no-deps --no-build-isolation -e .
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

## test-latest: the same checks against the newest releases pyproject.toml allows, in .venv-latest: run it before `make lock`
test-latest: chromium
	$(PYTHON) -m venv --clear .venv-latest
	.venv-latest/bin/python -m pip install --quiet --upgrade pip setuptools
	.venv-latest/bin/python -m pip install --quiet --upgrade -e '.[test]'
	.venv-latest/bin/python -m tests.lockfile
	.venv-latest/bin/ruff check .
	.venv-latest/bin/ruff format --check .
	AUTONOMY_CHROMIUM="$(CHROMIUM)" .venv-latest/bin/python -m pytest -q -n 2

## test-pyyaml: the YAML reader's tests on each PyYAML release from 6.0 with a wheel for this Python, libyaml and not
test-pyyaml: $(STAMP)
	for version in 6.0 6.0.1 6.0.2 6.0.3 6.0.4; do \
		$(BIN)/python -m pip install --quiet --upgrade --no-deps --only-binary :all: --target .pyyaml/$$version \
			"pyyaml==$$version" 2>/dev/null || { echo "PyYAML $$version: no wheel for this Python, skipped"; continue; }; \
		export PYTHONPATH="$(CURDIR)/.pyyaml/$$version" && \
		$(BIN)/python -c "import yaml; assert yaml.__version__ == '$$version'; print('PyYAML', yaml.__version__)" && \
		$(BIN)/python -m pytest -q -p no:cacheprovider tests/mission/test_parsers.py tests/mission/test_hostile.py \
		|| exit 1; \
	done

## lock: requirements.lock anew, with the newest releases pyproject.toml allows (check them first with `make test-latest`)
lock:
	$(PYTHON) -m venv .venv-lock
	.venv-lock/bin/python -m pip install --quiet uv==$(UV_VERSION)
	printf 'pip\nsetuptools>=68\n' | .venv-lock/bin/uv pip compile --quiet pyproject.toml - --extra test --extra cluster --extra calibrate --extra lms --universal \
		--python-version 3.10 --generate-hashes --upgrade --custom-compile-command 'make lock' --output-file $(LOCK)

## fuzz: the fuzz tests run long: 100,000 mutants, texts and reply byte strings, 10,000 YAML documents
fuzz: $(STAMP)
	AUTONOMY_FUZZ_CASES=100000 $(BIN)/python -m pytest -q tests/fuzz

## mutation: mutation testing of the five modules where a change shows (mutmut; hours on 2 cores), then the score
mutation:
	$(PYTHON) -m venv --clear .venv-mutation
	.venv-mutation/bin/python -m pip install --quiet --require-hashes -r $(LOCK)
	.venv-mutation/bin/python -m pip install --quiet --no-build-isolation -e '.[test,mutation]'
	-.venv-mutation/bin/mutmut run
	.venv-mutation/bin/python benchmarks/mutation.py

## bench: every benchmark (the latest figures go in the README, their history in docs/performance.md)
bench: $(STAMP)
	$(BIN)/python benchmarks/link.py
	$(BIN)/python benchmarks/missions.py
	$(BIN)/python benchmarks/views.py
	$(BIN)/python benchmarks/hostile.py
	$(BIN)/python benchmarks/groot.py
	$(BIN)/python benchmarks/crowd.py
	$(BIN)/python benchmarks/grading.py
	$(BIN)/python benchmarks/scenarios.py
	$(BIN)/python benchmarks/fixed_plans.py
	$(BIN)/python benchmarks/feedback.py
	$(BIN)/python benchmarks/cluster.py
	$(BIN)/python benchmarks/work.py
	$(BIN)/python benchmarks/liveclass.py
	$(BIN)/python benchmarks/runcost.py
	$(BIN)/python benchmarks/attacks.py
	$(BIN)/python benchmarks/overview.py
	$(BIN)/python benchmarks/blocks.py
	$(BIN)/python benchmarks/calibration.py
	$(BIN)/python benchmarks/lms.py

## vendor: the built browser libraries the package ships (Blockly, CodeMirror), anew from package-lock.json; needs node and npm
vendor:
	npm ci --ignore-scripts --no-audit --no-fund
	node tools/vendor.cjs

## pictures: take the docs' pictures of the blocks and the text anew (docs/images), in Chromium
pictures: .venv/.installed
	AUTONOMY_PICTURES=docs/images AUTONOMY_CHROMIUM="$(CHROMIUM)" $(BIN)/python -m pytest -q tests/views/test_docs_pictures.py -k taken

## docs: make the node reference in docs/missions.md anew from the registry
docs: $(STAMP)
	$(BIN)/python -c "from autonomy.mission.catalogue import update_reference; update_reference('docs/missions.md')"

clean:
	rm -rf $(VENV) .venv-latest .venv-lock .venv-mutation .pyyaml build *.egg-info .pytest_cache .ruff_cache .hypothesis mutants node_modules
