# Set-up and checks. Every target installs what it needs into .venv first, from the lock files
# in requirements/ (exact versions with hashes: a fresh machine gets what CI tested); `make lock`
# refreshes them, `make test-latest` runs the suite on the newest releases instead.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
UV     := $(BIN)/uv
STAMP  := $(VENV)/.installed
SERVE_STAMP := $(VENV)/.installed-serve
# locked: the lock files; latest: the newest releases pyproject.toml's ranges admit
REQUIREMENTS ?= locked
export TWIN_REQUIREMENTS := $(REQUIREMENTS)
COMPILE := $(UV) pip compile --quiet --generate-hashes --python-version 3.11

.PHONY: install serve test test-loaded test-latest lint typecheck lock demo urdf raos bench soak reliability clean

# uv (itself pinned with hashes) installs the locked set in seconds where pip took minutes.
$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --require-hashes -r requirements/bootstrap.txt

ifeq ($(REQUIREMENTS),latest)
INSTALL_SERVE = $(UV) pip install --python $(BIN)/python --upgrade -e .
INSTALL_TEST  = $(UV) pip install --python $(BIN)/python --upgrade -e ".[test,hydro]"
else
INSTALL_SERVE = $(UV) pip install --python $(BIN)/python --require-hashes -r requirements/serve.txt \
	&& $(UV) pip install --python $(BIN)/python --no-deps -e .
INSTALL_TEST  = $(UV) pip install --python $(BIN)/python --require-hashes -r requirements/test.txt \
	&& $(UV) pip install --python $(BIN)/python --no-deps -e .
endif

# Serving needs the package alone (no test, BEM or browser tooling): a fresh `make serve` is quick.
$(SERVE_STAMP): pyproject.toml requirements/serve.txt | $(BIN)/python
	$(INSTALL_SERVE)
	touch $(SERVE_STAMP)

# netsse: see requirements/netsse.in (it declares Python >= 3.12; the part we call runs on 3.11).
$(STAMP): pyproject.toml requirements/test.txt requirements/netsse.txt | $(BIN)/python
	$(INSTALL_TEST)
	$(BIN)/python -m pip install --quiet --no-deps --ignore-requires-python --require-hashes \
		-r requirements/netsse.txt
	touch $(STAMP) $(SERVE_STAMP)

## lock: re-resolve every dependency to its newest release within pyproject.toml's ranges.
# The Dockerfile's base image is pinned by digest too, outside this target (resolving it needs
# a registry): `docker buildx imagetools inspect python:3.11-slim-bookworm` prints the current
# digest; put it and the date into the Dockerfile's FROM line and its comment.
lock: | $(BIN)/python
	$(COMPILE) --upgrade pyproject.toml --extra test --extra hydro -o requirements/test.txt
	$(COMPILE) pyproject.toml -c requirements/test.txt -o requirements/serve.txt
	$(COMPILE) --upgrade requirements/bootstrap.in -o requirements/bootstrap.txt
	$(UV) pip compile --quiet --generate-hashes --python-version 3.12 --upgrade --no-deps \
		requirements/netsse.in -o requirements/netsse.txt
	@echo "Python packages locked. The Dockerfile's base image is pinned by digest apart: refresh it with"
	@echo "  docker buildx imagetools inspect python:3.11-slim-bookworm  (its FROM line and date)"

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
# The serial pass runs even when the parallel one fails, so one failure hides no browser test.
test: $(STAMP) /usr/bin/chromium
	$(BIN)/ruff check .
	$(BIN)/mypy
	# the kernels compiled once, in two processes, before two test workers would each compile them
	$(BIN)/python -m twin.cli warm --processes 2
	$(BIN)/python -m pytest -n 2 --dist loadfile -m "not serial" --durations=15; first=$$?; \
	$(BIN)/python -m pytest -m serial --durations=15; second=$$?; \
	echo "parallel pass exit $$first, serial pass exit $$second"; \
	test $$first -eq 0 && test $$second -eq 0

## test-loaded: `make test` with two busy CPU loops beside it (a shared 2-core machine)
test-loaded:
	@bash -c 'for i in 1 2; do (while :; do :; done) & done; \
		trap "kill \$$(jobs -p) 2>/dev/null" EXIT; $(MAKE) test'

## test-latest: the suite on the newest releases (not the lock), in its own .venv-latest
test-latest:
	$(MAKE) test VENV=.venv-latest REQUIREMENTS=latest

lint: $(STAMP)
	$(BIN)/ruff check .

## typecheck: mypy over the package (configured in pyproject.toml)
typecheck: $(STAMP)
	$(BIN)/mypy

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

## soak: 30 minutes of mixed load, viewers, a slowloris and the heatmap attack (scripts/soak.py)
soak: $(STAMP)
	$(BIN)/python scripts/soak.py

## reliability: fuzz, fault, load and crash tests; rewrites docs/reliability.md (~5 min)
reliability: $(STAMP)
	$(BIN)/python scripts/reliability.py

clean:
	rm -rf $(VENV) .venv-latest .pytest_cache .ruff_cache
