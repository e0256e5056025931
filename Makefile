# Two commands for users:  make demo  (set up, run the default scene end to end)
#                          make test  (set up, lint, type-check, run every test)
# Both create .venv on first use and reuse it afterwards.
# For teachers:                make lab   (.venv-lab: the students' install, built from this clone: try the lab)
#                              make lab-handout  (a class's zips, key and wheel; docs/teaching.md)
# For the docs site:           make docs  (a light venv, .venv-docs: MkDocs and its theme only)

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DEMO_BAG ?= out/demo_bag

# With a sourced ROS 2 (ROS_DISTRO set) the system rclpy is used: the venv sees
# system site-packages and the PyPI ROS wheels are not installed.
ifdef ROS_DISTRO
VENV_FLAGS := --system-site-packages
ROS_REQS   :=
else
VENV_FLAGS :=
ROS_REQS   := -r requirements-ros.txt
endif

.PHONY: demo test setup lint typecheck pytest emulated-kernels pytest-emulated bags bench docs docs-reference clean lab lab-handout

setup: $(STAMP)

$(STAMP): requirements.txt requirements-dev.txt requirements-docs.txt requirements-ros.txt setup.py setup.cfg package.xml Makefile
	@if [ ! -x $(BIN)/python ]; then \
	  $(PYTHON) -m venv $(VENV_FLAGS) $(VENV) 2>/dev/null || { \
	    echo "python3 -m venv failed; installing Debian's python3-venv"; \
	    rm -rf $(VENV); \
	    apt-get update -qq && apt-get install -y -qq python3-venv >/dev/null && \
	    $(PYTHON) -m venv $(VENV_FLAGS) $(VENV); }; \
	fi
	@# The network tests read bound sockets with ss and build two "hosts" with ip netns and iptables;
	@# the animation test writes an .mp4 through ffmpeg and reads it back with ffprobe.
	@missing=""; for t in ss:iproute2 ip:iproute2 iptables:iptables ffmpeg:ffmpeg ffprobe:ffmpeg; do \
	  command -v $${t%%:*} >/dev/null 2>&1 || PATH="$$PATH:/usr/sbin:/sbin" command -v $${t%%:*} >/dev/null 2>&1 || \
	    missing="$$missing $${t##*:}"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian's$$missing (network and animation tests)"; \
	  apt-get update -qq && apt-get install -y -qq --no-install-recommends \
	    $$(echo $$missing | tr ' ' '\n' | sort -u) >/dev/null; \
	fi
	$(BIN)/python -m pip install -q --disable-pip-version-check --upgrade pip
	$(BIN)/python -m pip install -q --disable-pip-version-check -r requirements-dev.txt $(ROS_REQS)
	$(BIN)/python -m pip install -q --disable-pip-version-check --no-deps -e .
	$(BIN)/python -m pendulum_accel.kernel_cache
	@touch $(STAMP)

demo: $(STAMP)
	@mkdir -p $(dir $(DEMO_BAG))
	$(BIN)/pendulum-accel run --record $(DEMO_BAG) --overwrite

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: $(STAMP)
	$(BIN)/mypy

# The suite runs on pytest-xdist: one process per worker, each with its own ROS_DOMAIN_ID pair and temporary
# directories (test/conftest.py), so ROS tests cannot meet. More workers than cores: many tests wait on the
# processes they start (nodes, CLIs, a cluster), and a waiting test leaves its core to another. Each file
# runs whole on one worker (what a module computes once is computed once), the longest files first, in
# conftest's order (no reorder by xdist): see test/conftest.py.
PYTEST_WORKERS ?= 3
PYTEST_XDIST := -n $(PYTEST_WORKERS) --dist loadfile --no-loadscope-reorder

pytest: $(STAMP)
	$(BIN)/python -m pytest $(PYTEST_XDIST)

# The numerics tests: every test whose figures come from floating-point arithmetic that numpy, libm or
# numba may do differently on another x86-64 CPU (physics, integrators, kernels, closed forms, planner
# and conditioning, estimators and calibration, Allan deviation, sweeps, golden bags). pytest-emulated
# runs them once more with numpy at its baseline (NPY_DISABLE_CPU_FEATURES), glibc's libm off AVX2 and
# FMA, numba compiling for NUMBA_CPU_NAME=generic NUMBA_CPU_FEATURES= and OpenBLAS on its oldest
# kernels (OPENBLAS_CORETYPE=Prescott; test/cpu_emulation.py;
# docs/portability.md), so a machine-dependent assertion fails here first.
NUMERICS_TESTS := $(addprefix test/test_,$(addsuffix .py, \
  physics_properties equation_of_motion rigid elastic multiplier grade linear exact variational \
  integrators dop853_tableau kernels profiles simulate extremes planner error_bounds \
  estimators estimator_guard smoother calibration seed_spread sensor allan accel_csv corpus_scenes coverage \
  speed_trace speed_csv csv_layouts bundled_recordings bag_topic_input \
  lecture lab sweep scene_run plan_honesty wrap_bound bag_golden figures cpu_emulation bench_integrated_walk \
  trend_modes))

# The kernels compiled once for the generic CPU, before the emulated pass's workers start (else each would
# compile the same kernels).
emulated-kernels: $(STAMP)
	$(BIN)/python -m test.cpu_emulation $(BIN)/python -m pendulum_accel.kernel_cache

pytest-emulated: emulated-kernels
	$(BIN)/python -m test.cpu_emulation $(BIN)/python -m pytest $(PYTEST_XDIST) $(NUMERICS_TESTS)

# Every step runs even after one fails (the CPU-emulation pass most of all: it is what shows a machine-
# dependent assertion), then make test fails naming the steps that failed. lint, typecheck and the generic
# kernels' compile run beside the main pass, in the time its workers spend waiting on the processes they
# start; their output is held and printed when the main pass ends.
BESIDE_STEPS := lint typecheck emulated-kernels
test: $(STAMP)
	@failed=""; held=$$(mktemp -d); \
	for step in $(BESIDE_STEPS); do \
	  { $(MAKE) --no-print-directory $$step > $$held/$$step 2>&1 || echo $$step >> $$held/failed; } & \
	done; \
	$(MAKE) --no-print-directory pytest || failed="$$failed pytest"; \
	wait; \
	for step in $(BESIDE_STEPS); do echo "== make $$step"; cat $$held/$$step; done; \
	failed="$$failed $$(cat $$held/failed 2>/dev/null | tr '\n' ' ')"; rm -rf $$held; \
	$(MAKE) --no-print-directory pytest-emulated || failed="$$failed pytest-emulated"; \
	failed=$$(echo $$failed); \
	if [ -n "$$failed" ]; then echo "make test failed: $$failed"; exit 1; fi

bags: $(STAMP)
	$(BIN)/pendulum-accel golden-bags bags

# The docs site (mkdocs.yml) into site/; strict, so a broken link or a missing page fails. It needs only
# the docs extra's tools (requirements-docs.txt), in their own venv: not the package, not the dev tools.
DOCS_VENV ?= .venv-docs
docs: $(DOCS_VENV)/.installed
	NO_MKDOCS_2_WARNING=1 $(DOCS_VENV)/bin/mkdocs build --strict --site-dir site

$(DOCS_VENV)/.installed: requirements-docs.txt
	$(PYTHON) -m venv $(DOCS_VENV)
	$(DOCS_VENV)/bin/python -m pip install -q --disable-pip-version-check -r requirements-docs.txt
	@touch $@

# The reference pages generated from the code (node parameters, scene fields, CLI); test_docs checks them.
docs-reference: $(STAMP)
	$(BIN)/python -m pendulum_accel.cli.docs_reference docs

# Every benchmark; figures print, land in out/bench, and each writes its page under docs/benchmarks.
BENCHES := work_precision error_bounds estimators calibration constant_cover real_motion integrated_walk allan_recovery chain bags player_memory bag_memory sweep_bench soak teardown constants
bench: $(STAMP)
	@for b in $(BENCHES); do \
	  echo "== python -m benchmarks.$$b"; \
	  $(BIN)/python -m benchmarks.$$b --out out/bench || exit 1; \
	done

clean:
	rm -rf build install log out site .pytest_cache .mypy_cache .ruff_cache

# The lab's students' install, from this clone: the ROS-free core, Jupyter and matplotlib in .venv-lab (no
# ROS 2, no test tools), the same package as the wheel lab-handout hands out. Students install that wheel
# (docs/lab/README.md); this clone is the teacher's edition (lab_teacher/: the solution and the key).
LAB_VENV ?= .venv-lab
lab: $(LAB_VENV)/.installed
	@echo "check it:  $(LAB_VENV)/bin/pendulum-accel lab check"

# Teachers: a class's handout from a secret, e.g.
#   make lab-handout SECRET=secret.txt CLASS=2026a GROUPS=8 OUT=class_2026a
# a zip per group, the teacher key and the package's wheel that students install (docs/teaching.md).
# CLASS is required: with the secret it draws the data, so two classes get different data from one secret.
lab-handout: $(LAB_VENV)/.installed
	@test -n "$(SECRET)" -a -n "$(CLASS)" -a -n "$(GROUPS)" -a -n "$(OUT)" || \
		{ echo "usage: make lab-handout SECRET=FILE CLASS=NAME GROUPS=N OUT=DIR" >&2; exit 2; }
	$(LAB_VENV)/bin/pendulum-accel lab make-class --secret "$(SECRET)" --class "$(CLASS)" \
		--groups "$(GROUPS)" --out "$(OUT)"
	$(LAB_VENV)/bin/python -m pip wheel -q --no-deps -w "$(OUT)" .

# Reinstalled when the package changes, so that make-class measures the key with the code the wheel holds.
LAB_SOURCES := $(shell find pendulum_accel -type f \( -name '*.py' -o -name '*.yaml' -o -name '*.csv' \) 2>/dev/null)
$(LAB_VENV)/.installed: setup.py package.xml $(LAB_SOURCES)
	$(PYTHON) -m venv $(LAB_VENV)
	$(LAB_VENV)/bin/python -m pip install -q --disable-pip-version-check --upgrade pip
	$(LAB_VENV)/bin/python -m pip install -q --disable-pip-version-check ".[lab]"
	@touch $@
