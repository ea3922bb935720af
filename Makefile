# taskcond: set-up, demo, tests and benchmarks. Everything runs inside .venv, created on first use.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
EXTRAS ?= all,server,dev

.PHONY: install demo test lint format bench clean

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	@echo "Installing taskcond[$(EXTRAS)] (the first time, llama-cpp-python compiles for ~11 min on 2 cores)"
	$(BIN)/pip install --progress-bar off -e ".[$(EXTRAS)]"
	touch $@

install: $(VENV)/.installed  ## create .venv and install taskcond with everything the tests need

demo: install  ## generate task conditions with the embedded LLM, then run LHT1's oracle to a video
	$(BIN)/taskcond conditions "move bottle into box"
	$(BIN)/taskcond conditions "close box" --json
	$(BIN)/taskcond conditions "move mug in front of bowl" --exclude move_in_front
	mkdir -p runs
	$(BIN)/taskcond oracle LHT1 --episodes 1 --seed 0 --video runs/demo-LHT1.mp4
	@echo "video: runs/demo-LHT1.mp4"

lint: install
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks

test: install lint  ## ruff, then the test suite
	$(BIN)/python -m pytest

bench: install  ## speed, memory and accuracy benchmarks; figures go to BENCHMARKS.md by hand
	$(BIN)/python -m benchmarks

format: install
	$(BIN)/ruff format src tests benchmarks
	$(BIN)/ruff check --fix src tests benchmarks

clean:
	rm -rf $(VENV) build dist src/*.egg-info .pytest_cache .ruff_cache
