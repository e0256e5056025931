# Two commands for users:  make demo  (set up, run the default scene end to end)
#                          make test  (set up, lint, type-check, run every test)
# Both create .venv on first use and reuse it afterwards.

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

.PHONY: demo test setup lint typecheck pytest bags bench clean

setup: $(STAMP)

$(STAMP): requirements-dev.txt requirements-ros.txt setup.py setup.cfg package.xml Makefile
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
	@echo "compiling the stepping kernels and the estimators' loops into numba's cache (once, about 20 s)"
	$(BIN)/python -m pendulum_accel.physics.kernels
	$(BIN)/python -c 'from pendulum_accel.estimators import ekf_kernels, dynamic; ekf_kernels.warm(); dynamic.warm_cache()'
	@touch $(STAMP)

demo: $(STAMP)
	@mkdir -p $(dir $(DEMO_BAG))
	$(BIN)/pendulum-accel run --record $(DEMO_BAG) --overwrite

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: $(STAMP)
	$(BIN)/mypy

pytest: $(STAMP)
	$(BIN)/python -m pytest

test: lint typecheck pytest

bags: $(STAMP)
	$(BIN)/pendulum-accel golden-bags bags

# Every benchmark, each the way the README quotes it; figures print and land in out/bench.
BENCHES := work_precision error_bounds estimators calibration chain bags sweep_bench soak
bench: $(STAMP)
	@for b in $(BENCHES); do \
	  echo "== python -m benchmarks.$$b"; \
	  $(BIN)/python -m benchmarks.$$b --out out/bench || exit 1; \
	done

clean:
	rm -rf build install log out .pytest_cache .mypy_cache .ruff_cache
