# Two commands do all the set-up on a fresh machine (Python >= 3.11 with venv):
#   make draw   - install into .venv and draw the default scenario with the simulated arm
#   make test   - install into .venv (with test extras) and run the test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
OUT    ?= out/default

.PHONY: draw test bench install clean

$(BIN)/activate:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip

# (PYTHONWARNINGS: setuptools says, informally, that an editable install with a C extension
# finds the package through a path hook; true and harmless here, kept off the commands' output)
$(VENV)/.installed: $(BIN)/activate pyproject.toml setup.py inkarm/sim/_period.c inkarm/control/_law.c inkarm/control/_member.c inkarm/control/_law.h inkarm/core/_plant.h inkarm/ink/_pen.c inkarm/sim/_batch.c inkarm/sim/_drive.h
	PYTHONWARNINGS="ignore:Editable installation:UserWarning" $(BIN)/pip install -q -e ".[test]"
	touch $@

install: $(VENV)/.installed

draw: $(VENV)/.installed
	$(BIN)/inkarm draw --out $(OUT)

test: $(VENV)/.installed
	$(BIN)/python -m pytest

bench: $(VENV)/.installed  # BENCH_ARGS=--quick: a smoke run (BENCHMARKS.md says so)
	PYTHONWARNINGS="ignore:Editable installation:UserWarning" $(BIN)/pip install -q -e ".[compare]"
	$(BIN)/python benchmarks/run_all.py --write $(BENCH_ARGS)

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis
