# The two commands a newcomer needs: `make run` and `make test`.
# Each creates its own virtual environment (.venv) and installs what it needs,
# so both work on a fresh machine with nothing but python3 (>= 3.11).
# `make run` installs the runtime dependencies only (what `pip install rc233-gateway` brings);
# `make test` adds the `test` extra, the AsyncAPI parser (npm) and the Debian software the
# tests drive (system-tools below).

PYTHON  ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
HASH    := $(shell $(PYTHON) -c "import hashlib,sys;print(hashlib.sha1(open('pyproject.toml','rb').read()).hexdigest()[:12])")
RUNTIME := $(VENV)/.runtime-$(HASH)
STAMP   := $(VENV)/.installed-$(HASH)
NODE_DIR   := tools/asyncapi
NODE_STAMP := $(NODE_DIR)/node_modules/.installed
# node-opcua: the independent OPC UA client the tests of the OPC UA face drive
OPCUA_CLIENT_DIR   := tools/opcua-client
OPCUA_CLIENT_STAMP := $(OPCUA_CLIENT_DIR)/node_modules/.installed

.PHONY: run test lint typecheck layers unit contract bench soak clean system-tools

$(RUNTIME): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet -e .
	rm -f $(VENV)/.runtime-*
	touch $(RUNTIME)

$(STAMP): $(RUNTIME)
	$(BIN)/python -m pip install --quiet -e '.[test]'
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

# The real software the tests drive, from Debian, installed when missing (CI runs as root):
# Node.js and npm for the AsyncAPI parser, chromium for the dashboard's browser tests and
# bench/dashboard.py (Playwright's own browser download is not used), mosquitto for the MQTT
# tests, promtool (package prometheus) for the alert rules, ser2net in front of the simulator,
# systemd-analyze for the unit file, curl for the README's first calls.
system-tools:
	@missing=""; \
	command -v node >/dev/null || missing="$$missing nodejs"; \
	command -v npm >/dev/null || missing="$$missing npm"; \
	command -v ser2net >/dev/null || missing="$$missing ser2net"; \
	command -v systemd-analyze >/dev/null || missing="$$missing systemd"; \
	command -v curl >/dev/null || missing="$$missing curl"; \
	test -x /usr/bin/chromium || missing="$$missing chromium"; \
	test -x /usr/sbin/mosquitto || missing="$$missing mosquitto"; \
	command -v promtool >/dev/null || missing="$$missing prometheus"; \
	if [ -n "$$missing" ]; then \
		echo "installing$$missing"; \
		apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q $$missing; \
	fi

$(NODE_STAMP): $(NODE_DIR)/package.json $(NODE_DIR)/package-lock.json | system-tools
	cd $(NODE_DIR) && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error
	touch $(NODE_STAMP)

$(OPCUA_CLIENT_STAMP): $(OPCUA_CLIENT_DIR)/package.json $(OPCUA_CLIENT_DIR)/package-lock.json | system-tools
	cd $(OPCUA_CLIENT_DIR) && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error
	touch $(OPCUA_CLIENT_STAMP)

run: $(RUNTIME)
	@echo "dashboard: http://127.0.0.1:8233/   API docs: http://127.0.0.1:8233/api/v1/docs"
	$(BIN)/rc233-gateway serve --simulate --no-auth --host 127.0.0.1 --port 8233

lint: $(STAMP)
	$(BIN)/ruff check gateway tests bench examples

typecheck: $(STAMP)
	$(BIN)/mypy

layers: $(STAMP)
	$(BIN)/lint-imports

# The protocol layer is what everything stands on: it must stay >= 95 % covered.
# Two pytest processes (-n 2), each test module to one of them (loadscope: a module's fixtures
# start once, and a test that reads what the tests before it in its module did finds it):
# on two cores the suite takes about two thirds of the time of one process.
unit: $(STAMP) $(NODE_STAMP) $(OPCUA_CLIENT_STAMP) system-tools
	$(BIN)/pytest -m "not contract" -n 2 --dist loadscope --cov --cov-report=term --cov-fail-under=90
	$(BIN)/coverage report --include='gateway/protocol/*' --fail-under=95 > /dev/null \
		|| { echo "gateway/protocol/ line coverage is under 95 %"; exit 1; }

# schemathesis against openapi.json: generated requests, every response checked.
# Without coverage: tracing the generator and the server thread makes it ten times slower.
contract: $(STAMP)
	$(BIN)/pytest -m contract -p no:cov

# The benchmarks print figures; here at scaled time (by hand: real time, see bench/README.md).
bench: $(STAMP) system-tools
	$(BIN)/python -m pip install --quiet -e '.[test,bench]'
	$(BIN)/python bench/line_efficiency.py --time-scale 10 --seconds 3
	$(BIN)/python bench/line_outside.py --seconds 2
	$(BIN)/python bench/line_scale.py --loops 1,2 --seconds 2 --plot $(VENV)/line_scale.png
	$(BIN)/python bench/exchange_profile.py --mode idle --seconds 2
	$(BIN)/python bench/api.py --quick
	$(BIN)/python bench/dashboard.py --seconds 3

# The static checks and the contract tests are short; the suite (two processes, see `unit`)
# runs beside them, so every test also passes beside a busy neighbour. The benchmarks run
# last, on their own, so their figures are not taken beside the tests.
test: $(STAMP) $(NODE_STAMP) $(OPCUA_CLIENT_STAMP) system-tools
	$(MAKE) --no-print-directory -j3 --output-sync=target lint typecheck layers unit contract
	$(MAKE) --no-print-directory bench

clean:
	rm -rf $(VENV) $(NODE_DIR)/node_modules $(OPCUA_CLIENT_DIR)/node_modules .pytest_cache .mypy_cache .ruff_cache .coverage .hypothesis

# The gateway's memory under the traffic of a cell, from outside (bench/soak.py; not part of
# `make test`): the target run is 2 hours, `make soak SOAK_MINUTES=120 SOAK_WARMUP=30`.
SOAK_MINUTES ?= 3
SOAK_WARMUP  ?= 1
soak: $(STAMP)
	$(BIN)/python bench/soak.py --minutes $(SOAK_MINUTES) --warmup $(SOAK_WARMUP)
