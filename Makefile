# Two commands do everything on a fresh machine: `make serve` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

CHROMIUM := /usr/bin/chromium

.PHONY: test serve lint typecheck pytest postgres clean bench-abstract

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet torch==2.13.0
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

test: $(STAMP) lint typecheck pytest

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: $(STAMP)
	$(BIN)/mypy

# The browser tests drive Debian's chromium (Playwright's own download does not work here).
$(CHROMIUM):
	@echo "installing Debian's chromium for the browser tests (apt-get, needs root)"
	apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium

# The store, API and benchmark tests run on SQLite and on a PostgreSQL server they start in a
# temporary folder (tests/postgres.py): Debian's postgresql, installed as chromium is.
postgres:
	@ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || { \
		echo "installing Debian's postgresql for the store tests (apt-get, needs root)" && \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq postgresql; }

# Parallel workers (pytest-xdist), one per core, a test file each at a time (--dist loadfile):
# a module's fixtures are made once and its tests run in order (the browser tests share one
# server). On 2 cores beside a 2-worker benchmark, 3 or 4 workers were no faster than 2. The 20
# slowest tests are listed at the end. TEST_WORKERS=0 runs the suite in one process.
TEST_WORKERS ?= auto
pytest: $(STAMP) $(CHROMIUM) postgres
	$(BIN)/pytest -q -n $(TEST_WORKERS) --dist loadfile --durations=20

serve: $(STAMP)
	$(BIN)/tamp serve --domain examples/tabletop2d

bench-abstract: $(STAMP)
	$(BIN)/python benchmarks/abstract_topk.py

clean:
	rm -rf $(VENV)
