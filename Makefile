# taskcond: set-up, demo, tests and benchmarks. Everything runs inside .venv, created on first use.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
EXTRAS ?= all,server,dev,viz

.PHONY: install demo test lint format bench clean

# llama-cpp-python compiles llama.cpp for this CPU on install. On an Intel CPU with AMX (Sapphire Rapids and
# later) that native build uses AMX kernels that crash the first evaluation (ggml-org/llama.cpp#20824), so
# there it is compiled without AMX, every other native instruction kept. It is built apart and without pip's
# wheel cache, so that a wheel cached from another build is never reused.
NO_AMX := $(if $(shell grep -m1 -o amx_tile /proc/cpuinfo 2>/dev/null),-mno-amx-tile -mno-amx-int8 -mno-amx-bf16)
LLAMA_CPP := $(shell grep -m1 -o '"llama-cpp-python[^"]*"' pyproject.toml)

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	@echo "Installing taskcond[$(EXTRAS)] (the first time, llama-cpp-python compiles: about 5 min on 2 cores)"
	CFLAGS="$(NO_AMX)" CXXFLAGS="$(NO_AMX)" $(BIN)/pip install --progress-bar off --no-cache-dir $(LLAMA_CPP)
	$(BIN)/pip install --progress-bar off -e ".[$(EXTRAS)]"
	touch $@

install: $(VENV)/.installed  ## create .venv and install taskcond with everything the tests need

demo: install  ## learn the skills once, then perform LHT1 with conditions from the embedded LLM, to a video
	$(BIN)/taskcond run LHT1 --method llm --seed 0 --video runs/demo-LHT1.mp4 --trace runs/demo-LHT1.json

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
