# Two commands do everything on a fresh machine:
#   make run    set up .venv, run the whole pipeline (dvc repro) on the simulated drives
#   make test   run the whole test suite
PY := python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
export DVC_NO_ANALYTICS := 1
export MLFLOW_DISABLE_TELEMETRY := true
export DO_NOT_TRACK := true
export PYTHONUNBUFFERED := 1

.PHONY: setup system-packages run test test-fast lint ui bench variant report worlds ci-pipeline ci-gate baseline-ci

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip 2>&1 | grep -v "is ignored: it is neither a file nor a directory" || true
	$(BIN)/pip install -q -e '.[dev]' 2>&1 | grep -v "is ignored: it is neither a file nor a directory" || true
	$(BIN)/python -c "import rwhonet, torch, lightning, mlflow, dvc, pandera, geographiclib, safetensors"
	touch $(STAMP)

setup: $(STAMP) system-packages

# Debian's packages the team-mode test starts on localhost (PostgreSQL, nginx, openssl for
# its certificate: tests/tracking/test_team_server.py, docs/team.md). As root with apt-get
# they are installed when missing, and a failed installation stops here; elsewhere a note
# says the test will skip (CI runs with CI=true, where a skip is a failure instead).
TEAM_PACKAGES := postgresql nginx openssl
system-packages:
	@missing=""; \
	ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || missing="postgresql"; \
	test -x /usr/sbin/nginx || missing="$$missing nginx"; \
	command -v openssl >/dev/null || missing="$$missing openssl"; \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing Debian packages for the team-mode test:$$missing"; \
		DEBIAN_FRONTEND=noninteractive apt-get update -q \
		&& DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $$missing; \
	else \
		echo "note: not installed:$$missing; tests/tracking/test_team_server.py will skip" \
			"(as root: apt-get install $(TEAM_PACKAGES))"; \
	fi

# -rs: a skipped test says why in the summary (the team-mode test without its servers).
# The suite runs on TEST_JOBS pytest-xdist workers (auto: one per core), each test module
# whole on one worker (--dist loadfile), so a module's fixtures, most of them a whole DVC
# pipeline in a scratch project, are built once, and the modules that share the session's
# ci pipeline all on one (tests/conftest.py); TEST_JOBS=0 runs it in this process.
# --durations: the log names the slowest setups and tests, so a CI run shows where the
# suite's time goes (PYTEST_ARGS="--durations=0 --junitxml=F" for every one).
TEST_JOBS ?= auto
XDIST = -n $(TEST_JOBS) --dist loadfile
PYTEST_ARGS ?= --durations=25
test: $(STAMP) system-packages
	$(BIN)/python -m pytest -q -rs $(XDIST) $(PYTEST_ARGS)

test-fast: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow" $(XDIST)

lint: $(STAMP)
	$(BIN)/ruff check src tests pipelines benchmarks
	$(BIN)/ruff format --check src tests pipelines benchmarks

# dvc and the stage scripts must find the venv's python first.
RUN_ENV := PATH=$(abspath $(BIN)):$$PATH

# data.dvc tracks data/raw (real drives). It ships empty; an empty folder hashes
# the same everywhere, so recreating it keeps `dvc status` clean on a fresh clone.
data/raw:
	mkdir -p data/raw
	$(RUN_ENV) dvc commit -q -f data.dvc

run: $(STAMP) data/raw
	$(RUN_ENV) python -m rwhonet.tracking init
	$(RUN_ENV) dvc repro
	@echo
	@awk '/^## Paired differences/{exit} {print}' reports/tables.md
	@grep -m1 -E '^(The rule picks|No recipe passes)' reports/tables.md || true
	@echo "Full tables: reports/tables.md   MLflow UI: make ui   DVC plots: dvc plots show"

# A variant of the pipeline end to end in a scratch copy of the working tree,
# build/<NAME> (the workspace's own outputs stay untouched), with params set by
# `dvc exp run -S`. For example (docs/results.md):
#   make variant NAME=large-target SET="sim.profile=large_target"
#   make variant NAME=five-seeds SET="seeds=[42,43,44,45,46]"
variant: $(STAMP)
	@test -n "$(NAME)" || { echo "usage: make variant NAME=<dir under build/> SET='key=value ...'"; exit 2; }
	rm -rf build/$(NAME) && mkdir -p build/$(NAME)
	git ls-files -co --exclude-standard -z | xargs -0 cp --parents -t build/$(NAME)
	cd build/$(NAME) && git init -q && git config user.name variant \
		&& git config user.email variant@localhost && git add -A && git commit -qm snapshot
	cd build/$(NAME) && mkdir -p data/raw && $(RUN_ENV) PYTHONPATH=$(abspath build/$(NAME))/src dvc commit -q -f data.dvc
	cd build/$(NAME) && $(RUN_ENV) PYTHONPATH=$(abspath build/$(NAME))/src python -m rwhonet.tracking init
	cd build/$(NAME) && $(RUN_ENV) PYTHONPATH=$(abspath build/$(NAME))/src dvc exp run $(foreach s,$(SET),-S '$(s)')
	@echo "build/$(NAME): metrics/eval.json, reports/tables.md, mlruns/ (make ui there)"

# docs/results.md's five-seed figures (build/report/).
report:
	$(MAKE) variant NAME=report SET="seeds=[42,43,44,45,46]"

# The matrix of worlds (issue 16): the two target cars under both GNSS receiver grades,
# one pipeline each in build/worlds/<world>/ (its own repository, DVC cache and MLflow
# store), WORLD_JOBS of them at a time (each world's stages are mostly one thread; two
# use both cores of a 2-core machine), then every headline claim marked world by world
# in docs/results.md (rwhonet.report.worlds).
WORLDS := paper large_target paper_consumer large_target_consumer
WORLD_JOBS ?= 2
worlds: $(STAMP)
	@start=$$(date +%s); $(MAKE) --no-print-directory --output-sync=target -j$(WORLD_JOBS) \
		$(addprefix world-,$(WORLDS)) && echo "== $(words $(WORLDS)) worlds done after $$(( $$(date +%s) - start )) s"
	$(BIN)/python -m rwhonet.report.worlds $(addprefix build/worlds/,$(WORLDS)) --results docs/results.md

world-%: $(STAMP)
	@start=$$(date +%s); $(MAKE) --no-print-directory variant NAME=worlds/$* SET="sim.profile=$*" \
		&& echo "== world $* done after $$(( $$(date +%s) - start )) s"

CI_DIR := build/ci-run
# The `ci` profile end to end, then the mean-CRSE regression gate.
ci-pipeline:
	$(MAKE) variant NAME=ci-run SET="sim.profile=ci"

ci-gate: ci-pipeline
	$(BIN)/rwhonet-gate --eval $(CI_DIR)/metrics/eval.json

# Refresh the committed CI baseline on purpose (review the diff, then commit it).
baseline-ci: ci-pipeline
	cp $(CI_DIR)/metrics/eval.json metrics/baseline-ci.json
	@echo "metrics/baseline-ci.json refreshed from a ci-profile run; review and commit it."

ui: $(STAMP)
	$(RUN_ENV) python -m rwhonet.tracking init
	$(BIN)/mlflow ui --backend-store-uri sqlite:///mlruns/mlflow.db --default-artifact-root ./mlruns/artifacts --host 127.0.0.1 --port 5000 --workers 1

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_data.py
	$(BIN)/python benchmarks/bench_train.py
	$(BIN)/python benchmarks/bench_recalibrate.py
