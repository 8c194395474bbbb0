# wheelgym: the two commands of the README, from a fresh machine.
#   make run    set up .venv, train the default agent, score it against the analytic baseline
#   make test   set up .venv, run the test suite
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
UVPIP  := $(PY) -m uv pip install --quiet --native-tls --python $(PY) --compile-bytecode
# $(call install,ARGS): uv pip install ARGS, pip if uv fails (a comma in ARGS via a variable)
install = $(UVPIP) $(1) || $(PIP) install --quiet $(1)
DEV_EXTRAS := .[train,dev,cluster,clients,onnx]
STAMP  := $(VENV)/.installed

.PHONY: run test test-slow lint bench validate docs docs-check clean-venv wheel-smoke

$(STAMP): pyproject.toml setup.py
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip
	# The CPU build of torch first (an unpinned torch would pull a multi-GB CUDA build), and uv,
	# which installs the rest with parallel downloads and byte-compiling: 22 s instead of pip's
	# 58 s (docs/topics/performance.md); pip if uv fails.
	$(PIP) install --quiet "torch==2.13.0" uv
	$(call install,-e "$(DEV_EXTRAS)")
	touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/wheelgym main

# The kernels are compiled into numba's disk cache first, each in one of two processes: left
# to the two test workers, both would compile the costliest ones at the same time. ThreeWheel's
# DC kernels and the threaded DC kernels (256 robots and more) are not used by the default tests
# (docs/topics/performance.md has the compile costs).
test: $(STAMP)
	$(PY) -m wheelgym.warmup --processes 2 --skip-dc ThreeWheel --skip-threaded-dc
	$(PY) -m pytest -q -n 2 --dist loadgroup

test-slow: $(STAMP)
	$(PY) -m pytest -q -m slow

lint: $(STAMP)
	$(VENV)/bin/ruff check .

bench: $(STAMP)
	$(PY) benchmarks/physics.py

validate: $(STAMP)
	$(PY) -m wheelgym.validate

# Build the wheel, install it in a fresh venv, run the main job from an empty folder (CI).
wheel-smoke: $(STAMP)
	VENV_PY=$(PY) bash .ci/wheel-smoke

# The documentation site (docs/, Sphinx + MyST + furo): warnings are errors. docs-check opens
# every built page in headless Chromium (Debian's chromium package, /usr/bin/chromium).
DOCS_STAMP := $(VENV)/.installed-docs
$(DOCS_STAMP): $(STAMP)
	$(call install,-e ".[docs]")
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	$(PY) -m sphinx -W --keep-going -b html docs docs/_build/html

docs-check: docs
	$(PY) -m pytest -q -p no:xdist -m browser tests/test_docs_browser.py

clean-venv:
	rm -rf $(VENV)
