# Every target sets itself up: a virtual environment in .venv, PyTorch (CPU), the package
# with its dev extras pinned by constraints.txt, and the MONA binary.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.noisybolt-installed
# Both cores of the 2-core machine the suite is sized for (serial, it takes ~16 min);
# PYTEST_ARGS= (empty) runs it in one process.
PYTEST_ARGS ?= -n 2

.PHONY: all setup mona test test-slow test-wheel demo walkthrough docs lint typecheck bench clean

all: test

$(STAMP): pyproject.toml constraints.txt
	@test -x $(PY) || $(PYTHON) -m venv $(VENV) || { \
	  echo "error: could not create $(VENV); on Debian/Ubuntu run: apt-get install python3-venv" >&2; exit 1; }
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q "torch==2.13.0" -c constraints.txt
	$(PY) -m pip install -q -e ".[dev]" -c constraints.txt
	@touch $(STAMP)

setup: $(STAMP) mona

mona:
	@sh scripts/ensure-mona.sh

# The suite, then the wheel test (built and installed in a fresh venv, ~2-5 min of its own,
# run apart so that xdist does not start it last beside an idle worker).
test: setup
	$(PY) -m pytest -q -m "not slow" $(PYTEST_ARGS)
	$(MAKE) --no-print-directory test-wheel

test-slow: setup
	$(PY) -m pytest -q -m slow $(PYTEST_ARGS)
	$(PY) scripts/mutate_bolt.py  # the bolt's mutation gate: every mutation caught

# The wheel in a fresh virtual environment (tests/test_wheel.py, a few minutes): a CI step
# of its own after `make test`, which it would otherwise lengthen by its whole time.
test-wheel: setup
	$(PY) -m pytest -q -m slow tests/test_wheel.py -n 0

demo: setup
	$(VENV)/bin/noisybolt demo

walkthrough: setup
	$(VENV)/bin/noisybolt demo --walkthrough

# The documentation site (docs/, mkdocs.yml) into build/site/, warnings as errors.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks
	$(VENV)/bin/ruff format --check src tests benchmarks

typecheck: $(STAMP)
	$(VENV)/bin/mypy

bench: setup
	$(PY) benchmarks/bolt_step.py
	$(PY) benchmarks/compile_time.py
	$(PY) benchmarks/perception_world.py
	$(PY) benchmarks/perception_classifiers.py
	$(PY) benchmarks/training_throughput.py

clean:
	rm -rf $(VENV) build dist src/*.egg-info .pytest_cache .mypy_cache .ruff_cache
