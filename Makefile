# Set-up and checks. Every target installs what it needs into .venv first.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
SERVE_STAMP := $(VENV)/.installed-serve

.PHONY: install serve test lint demo urdf raos bench reliability clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# Serving needs the package alone (no test, BEM or browser tooling): a fresh `make serve` is quick.
$(SERVE_STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $(SERVE_STAMP)

# netsse (the closed-form RAO peer of tests/vessel/test_netsse.py) declares Python >= 3.12 and
# drags in cartopy; the part we call needs only numpy, so it is installed on its own.
$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test,hydro]"
	$(BIN)/python -m pip install --quiet --no-deps --ignore-requires-python "netsse>=2.2,<3"
	touch $(STAMP) $(SERVE_STAMP)

install: $(STAMP)

## serve: the live twin — 3D viewer :8080, REST API and landing page :8000
serve: $(SERVE_STAMP)
	$(BIN)/twin serve --host 127.0.0.1 --port 8000 --viser-port 8080 --data-dir data

# The browser tests drive Debian's chromium (never a downloaded browser): install it if missing.
/usr/bin/chromium:
	$(if $(filter 0,$(shell id -u)),,sudo) apt-get update -q
	DEBIAN_FRONTEND=noninteractive $(if $(filter 0,$(shell id -u)),,sudo) \
		apt-get install -y -q --no-install-recommends chromium

## test: install, lint and run the whole test suite (what CI runs)
test: $(STAMP) /usr/bin/chromium
	$(BIN)/ruff check .
	# the kernels compiled once, in two processes, before two test workers would each compile them
	$(BIN)/python -m twin.cli warm --processes 2
	$(BIN)/python -m pytest -n 2 --dist loadfile -m "not serial" --durations=15
	$(BIN)/python -m pytest -m serial --durations=15

lint: $(STAMP)
	$(BIN)/ruff check .

## demo: leg lengths and gangway tip at the working state
demo: $(SERVE_STAMP)
	$(BIN)/python examples/working_state.py

## urdf: regenerate assets/urdf from the code's geometry
urdf: $(STAMP)
	$(BIN)/python scripts/build_urdf.py

## raos: recompute assets/vessels/*.nc with Capytaine (about a minute)
raos: $(STAMP)
	$(BIN)/python scripts/compute_raos.py

## bench: benchmarks against the Pinocchio peer; rewrites docs/performance.md (~3 min)
bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

## reliability: fuzz, fault, load and crash tests; rewrites docs/reliability.md (~5 min)
reliability: $(STAMP)
	$(BIN)/python scripts/reliability.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache
