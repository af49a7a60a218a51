# kinbox: `make demo` sets up and runs a built-in example; `make test` sets up and runs the tests.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
KINBOX := $(VENV)/bin/kinbox

.PHONY: setup demo test test-slow bench clean

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	@echo "compiling kinbox's numba kernels once (cached on disk), then ahead of time (a few minutes of CPU)"
	$(PY) -m kinbox.problems.aot
	touch $@

setup: $(VENV)/.installed

demo: setup
	$(KINBOX) solve general-6r
	$(KINBOX) ik ur5 --frame tool0 --from-q 0.3,-1.2,1.5,-0.8,1.2,0.4

# -n auto: one test process per core (pytest-xdist)
test: setup
	$(PY) -m pytest -q -n auto

# the slow cases, and the soundness properties with ten times the default number of cases (0.3 -> 3)
test-slow: setup
	$(PY) -m pytest -q -n auto -m slow
	KINBOX_SOUNDNESS_SCALE=3 $(PY) -m pytest -q -n auto tests/search/test_soundness_arb.py

bench: setup
	$(PY) benchmarks/run.py --quick

clean:
	rm -rf $(VENV) build *.egg-info src/*.egg-info
