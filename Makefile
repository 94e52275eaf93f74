# One virtual environment for everything; created and filled on first use.
#   make demo   -> the main job: diagonal cloth fold (small by default)
#   make test   -> ruff, then the test suite on every core (pytest-xdist; tests are independent),
#                  naming its 15 slowest tests (CI's whole run must stay under 20 minutes)
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.dopt-installed
# The CPU build of torch must be installed before the project, or pip pulls GBs of CUDA wheels.
# Where PyPI's torch is the CUDA build, name the CPU index:
#   make demo TORCH_INDEX=https://download.pytorch.org/whl/cpu
TORCH  ?= torch==2.13.0
TORCH_INDEX ?=

.PHONY: demo test install bench clean

$(STAMP): pyproject.toml setup.py dopt/_rollout_kernels.c
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet "$(TORCH)" $(if $(TORCH_INDEX),--index-url $(TORCH_INDEX))
	# a .venv from before mujoco-core: the mujoco metapackage pins mujoco-core 4.0.0 and owns the
	# same mujoco/__init__.py, so it goes, with the core, which the next line installs afresh
	if $(PY) -m pip show --quiet mujoco >/dev/null 2>&1; then \
		$(PY) -m pip uninstall --quiet --yes mujoco mujoco-studio mujoco-core; fi
	$(PY) -m pip install --quiet -e ".[plots,cluster,dev,viz]"
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	MUJOCO_GL=egl $(PY) experiments/cloth_fold.py --goal diagonal --trials 1 --out results/cloth_diagonal

test: $(STAMP)
	$(VENV)/bin/ruff check .
	MUJOCO_GL=egl OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -n auto --durations=15 tests

clean:
	rm -rf $(VENV) results
