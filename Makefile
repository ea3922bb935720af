# taskcond: set-up, demo, tests and benchmarks. Everything runs inside .venv, created on first use.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
EXTRAS ?= all,dev

.PHONY: install install-native demo test lint format bench clean

$(BIN)/pip:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip

# The demo needs the embedded LLM and the PyBullet suite only (.[all]): a first `make demo` does not wait for
# robosuite, Ray, JAX and Rerun (about 700 MB), which `make test` adds.
$(VENV)/.demo: pyproject.toml | $(BIN)/pip
	$(BIN)/pip install --progress-bar off -e ".[all]"
	touch $@

$(VENV)/.installed: pyproject.toml | $(BIN)/pip
	$(BIN)/pip install --progress-bar off -e ".[$(EXTRAS)]"
	touch $@ $(VENV)/.demo

# The opt-in native runtime: llama-cpp-python compiles llama.cpp for this CPU. On an Intel CPU with AMX
# (Sapphire Rapids and later) that native build uses AMX kernels that crash the first evaluation
# (ggml-org/llama.cpp#20824), so there it is compiled without AMX, every other native instruction kept.
# The wheel is built once per CPU (its instruction-set flags), compiler flags, Python and version range,
# and kept in the cache directory's `wheels/`: the next `make install-native` on the same kind of machine
# installs it in seconds. pip's own wheel cache is not used: it would reuse a wheel built for another CPU.
# Once installed, the native runtime is the default (taskcond.llm.config.EMBEDDED_RUNTIMES).
NO_AMX := $(if $(shell grep -m1 -o amx_tile /proc/cpuinfo 2>/dev/null),-mno-amx-tile -mno-amx-int8 -mno-amx-bf16)
LLAMA_CPP := $(shell grep -m1 -o '"llama-cpp-python[^"]*"' pyproject.toml)
NATIVE_KEY := $(shell (grep -m1 '^flags' /proc/cpuinfo; echo '$(NO_AMX) $(LLAMA_CPP)'; $(PYTHON) -V) | sha256sum | cut -c1-16)
WHEELS ?= $(or $(TASKCOND_CACHE_DIR),$(HOME)/.cache/taskcond)/wheels/llama-cpp-python-$(NATIVE_KEY)

install-native: install  ## also install llama-cpp-python, the native runtime (compiled once per CPU: about 5 min on 2 cores)
	@ls $(WHEELS)/llama_cpp_python-*.whl >/dev/null 2>&1 || { echo "compiling llama-cpp-python for this CPU into $(WHEELS)"; \
	  CFLAGS="$(NO_AMX)" CXXFLAGS="$(NO_AMX)" $(BIN)/pip wheel --progress-bar off --no-cache-dir --no-deps \
	  -w $(WHEELS).part $(LLAMA_CPP) && rm -rf $(WHEELS) && mv $(WHEELS).part $(WHEELS); }
	$(BIN)/pip install --progress-bar off $(WHEELS)/llama_cpp_python-*.whl
	$(BIN)/pip install --quiet --force-reinstall --no-deps $(WHEELS)/llama_cpp_python-*.whl  # over any other build

install: $(VENV)/.installed  ## create .venv and install taskcond with everything the tests need

demo: $(VENV)/.demo  ## learn the skills once, then perform LHT1 with conditions from the embedded LLM, to a video
	$(BIN)/taskcond run LHT1 --method llm --seed 0 --video runs/demo-LHT1.mp4 --trace runs/demo-LHT1.json

lint: install
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks

test: install lint  ## ruff, then the test suite (every extra is installed, so a skipped test fails it)
	TASKCOND_TEST_NO_SKIP=1 $(BIN)/python -m pytest

bench: install  ## speed, memory and accuracy benchmarks; figures go to BENCHMARKS.md by hand
	$(BIN)/python -m benchmarks

format: install
	$(BIN)/ruff format src tests benchmarks
	$(BIN)/ruff check --fix src tests benchmarks

clean:
	rm -rf $(VENV) build dist src/*.egg-info .pytest_cache .ruff_cache
