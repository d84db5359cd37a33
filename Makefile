# Two commands do everything on a fresh machine: `make run` and `make test`.
VENV   := .venv
PY     := $(VENV)/bin/python
HCSS   := $(VENV)/bin/hcss
STAMP  := $(VENV)/.installed-stamp

.PHONY: install run test test-fast bench chaos lint format browser nginx node-tools fuzz r

$(PY):
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

# Reinstall only when the project's metadata changes.
$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install -q -e '.[test,dev]'
	touch $(STAMP)

install: $(STAMP)

# The study platform on http://127.0.0.1:$(PORT)/ (make run PORT=8080 STUDY=demo);
# STUDY is the study new participants get. In another terminal,
# `.venv/bin/hcss demo-trial` prints the link of a live demo trial on that port.
PORT  ?= 5000
STUDY ?= $(or $(HCSS_STUDY),original)
run: install
	$(HCSS) db upgrade
	@echo 'Open a demo trial: in another terminal run  $(HCSS) demo-trial'
	$(HCSS) serve --port $(PORT) --study $(STUDY)

# Browser tests need Debian's Chromium; scripts/ensure-chromium installs it when missing.
browser:
	bash scripts/ensure-chromium

# R with lme4 and geepack for tests/analysis/test_r_script.py (skipped without it). Not a
# prerequisite of `test`: Debian's R takes ~5 minutes to install on a fresh machine.
r:
	bash scripts/ensure-r

# The multi-process tests start Debian's nginx; scripts/ensure-nginx installs it when missing.
nginx:
	bash scripts/ensure-nginx

# axe-core for the browser tests' accessibility checks and Biome for `make lint`, pinned by
# package-lock.json; scripts/ensure-node-tools installs them into node_modules/ when missing.
node-tools:
	bash scripts/ensure-node-tools

# Three workers on two cores: most of the suite's time is waiting (leases expiring, servers
# and browsers answering), and a third worker took a full run from 17 min 30 s to 15 min 1 s.
test: install browser nginx node-tools
	$(PY) -m pytest -q -n 3

# The fast tier, before each commit: SQLite only, no slow or browser test, and none that took
# over 2 s in tests/durations.csv (a full run's times; every run writes its own to
# test-artifacts/durations.csv, and copying that file over refreshes the tier).
test-fast: install
	env -u HCSS_TEST_DATABASE_URL $(PY) -m pytest -q -n 2 --fast

# Long fuzz run of every route (tests/platform/test_fuzz.py): 4 groups x FUZZ_EXAMPLES requests
# on SQLite (50,000 at the default), an outage group of a fifth as many, and as many again on
# PostgreSQL when HCSS_TEST_DATABASE_URL is set. The tally is by database, status and route.
# Then the same groups over HTTP through a real nginx in front of `hcss serve`
# (tests/platform/test_fuzz_nginx.py), FUZZ_NGINX_EXAMPLES per group, on both databases too.
FUZZ_EXAMPLES ?= 12500
FUZZ_NGINX_EXAMPLES ?= 2500
fuzz: install
	mkdir -p test-artifacts && rm -f test-artifacts/fuzz-tally.txt
	HCSS_FUZZ_EXAMPLES=$(FUZZ_EXAMPLES) HCSS_FUZZ_TALLY=test-artifacts/fuzz-tally.txt \
		$(PY) -m pytest tests/platform/test_fuzz.py -q -n 2
	HCSS_FUZZ_NGINX_EXAMPLES=$(FUZZ_NGINX_EXAMPLES) HCSS_FUZZ_TALLY=test-artifacts/fuzz-tally.txt \
		$(PY) -m pytest tests/platform/test_fuzz_nginx.py -q
	@awk '{n[$$4" HTTP "$$1]+=$$2; t[$$4]+=$$2} END {for (s in n) printf "  %s: %d\n", s, n[s]; \
		for (d in t) printf "fuzz %s: %d requests\n", d, t[d]}' test-artifacts/fuzz-tally.txt | sort
	@awk '{r[$$4" "$$3" "$$1]+=$$2} END {for (k in r) printf "  %s: %d\n", k, r[k]}' \
		test-artifacts/fuzz-tally.txt | sort

bench: install
	$(PY) -m benchmarks

# The chaos soak (benchmarks/chaos.py): 30 minutes of random faults under bots and a console,
# then a verdict per invariant; needs PostgreSQL (HCSS_TEST_DATABASE_URL) and nginx.
# HCSS_CHAOS_SEED=N reproduces a run, HCSS_CHAOS_S sets its length. Also part of `make bench`.
chaos: install nginx
	$(PY) -m benchmarks chaos

# ruff (style, banned dynamic imports, dead noqa), import-linter (the contracts of
# docs/architecture.md, in pyproject.toml), mypy (settings in pyproject.toml).
# Biome lints and checks the format of the platform's JavaScript and lints its CSS (biome.jsonc).
lint: install node-tools
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/lint-imports
	$(VENV)/bin/mypy
	node_modules/.bin/biome ci --colors=off

format: install node-tools
	$(VENV)/bin/ruff check --fix .
	$(VENV)/bin/ruff format .
	node_modules/.bin/biome check --write
