# Two commands: `make demo` (set up, then run the main job) and `make test` (set up, then the whole suite).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

# The set-up installs in one pip run: bim2rdt with its extras, plus SETUP_EXTRAS (comma-separated) and
# SETUP_PACKAGES, with pip's SETUP_PIP_OPTIONS. `.ci/run` adds the yoloe extra and torch to that run (one resolve
# instead of two); `make demo` and `make test` need none of them. The venv is set up again when these change.
SETUP_EXTRAS ?=
SETUP_PACKAGES ?=
SETUP_PIP_OPTIONS ?=
comma := ,
INSTALL_ARGS := -e ".[llm,bench,sensors,nats,ros,dev,docs$(addprefix $(comma),$(SETUP_EXTRAS))]" $(SETUP_PACKAGES)
ARGS := $(VENV)/.install-args

.PHONY: demo test bench setup clean web docs FORCE

# The install's arguments, rewritten only when they differ from the last set-up's.
$(ARGS): FORCE
	@mkdir -p $(VENV)
	@echo '$(SETUP_PIP_OPTIONS) $(INSTALL_ARGS)' | cmp -s - $@ || echo '$(SETUP_PIP_OPTIONS) $(INSTALL_ARGS)' > $@

$(STAMP): pyproject.toml $(ARGS)
	@echo "make: creating the virtual environment $(VENV) (once; again when pyproject.toml or the SETUP_ options change)"
	$(PYTHON) -m venv $(VENV)
	@echo "make: updating pip"
	$(PY) -m pip install -q --upgrade pip
	@echo "make: installing bim2rdt and its dependencies (ifcopenshell, open3d, ...: a few minutes the first time)"
	$(PY) -m pip install -q $(SETUP_PIP_OPTIONS) $(INSTALL_ARGS)
	@echo "make: $(VENV) is ready"
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/bim2rdt demo --out out/demo

# The suite on three workers over the two cores (pytest-xdist; many tests wait on brokers, databases and
# subprocesses, and a third worker fills that time: 824 s against 868 s with two; a test file stays on one worker,
# so its module fixtures are built once), then the timing-sensitive tests (marked serial in tests/conftest.py) alone.
# The compiled kernels (numba) are compiled once first, so no test with a deadline pays their first compile.
test: $(STAMP)
	$(VENV)/bin/lint-imports --no-logo
	$(PY) scripts/compile_kernels.py
	$(PY) -m pytest -q -n 3 --dist loadfile -m "not serial"
	$(PY) -m pytest -q -m serial

bench: $(STAMP)
	$(VENV)/bin/bim2rdt bench registration
	$(VENV)/bin/bim2rdt bench ifc
	$(VENV)/bin/bim2rdt bench hav
	$(VENV)/bin/bim2rdt bench server
	$(VENV)/bin/bim2rdt bench perception

# The docs site (mkdocs.yml) into site/; `make test` builds it with --strict too (tests/test_docs_site.py).
docs: $(STAMP)
	$(PY) scripts/reference_pages.py
	$(VENV)/bin/mkdocs build --strict

# The dashboard's page and the API docs' Swagger UI (web/ -> src/bim2rdt/server/static, committed): needs node 20
# and npm from the npm registry. --ignore-scripts: swagger-ui-dist's dependency @scarf/scarf would report the install.
web:
	cd web && npm ci --no-audit --no-fund --ignore-scripts && npm run build

clean:
	rm -rf $(VENV) out site .pytest_cache
