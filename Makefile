# Two commands for a newcomer: `make demo` and `make test`. Both install everything they need.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test install hdl-tools bench clean

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	@touch $(STAMP)

install: $(STAMP)

# Icarus Verilog for the cocotb regressions (and Verilator for lint): installed when missing and permitted.
hdl-tools:
	@command -v iverilog >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq iverilog verilator >/dev/null) ; \
	  else echo "iverilog missing and apt-get not permitted: install iverilog to run the HDL tests" >&2; fi; }

demo: $(STAMP)
	$(VENV)/bin/fxdsp demo

test: $(STAMP) hdl-tools
	$(VENV)/bin/python -m pytest -q -n 2 --dist loadfile

bench: $(STAMP)
	$(VENV)/bin/fxdsp bench

clean:
	rm -rf $(VENV) sim_build .pytest_cache .hypothesis
