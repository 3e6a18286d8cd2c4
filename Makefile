# Two entry points: `make demo` (the main job) and `make test` (the suite).
# Both create or reuse .venv in the repo root and install what they need into it.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip install --disable-pip-version-check -q -c constraints.txt
DEMO_OUT ?= out/demo
# `make serve SERVE_ARGS="wheel --episodes 10"`: the arguments of `hri-bench serve`.
SERVE_ARGS ?= hanger --data out/datasets

.PHONY: demo test speed serve web clean system-deps

$(PY):
	$(PYTHON) -m venv $(VENV)

# Stamps record which extras are installed; they are redone when pyproject.toml changes.
$(VENV)/.demo-installed: pyproject.toml constraints.txt | $(PY)
	$(PIP) -e ".[bench]"
	touch $@

$(VENV)/.serve-installed: pyproject.toml constraints.txt | $(PY)
	$(PIP) -e ".[bench,web,mujoco]"
	touch $@ $(VENV)/.demo-installed

$(VENV)/.test-installed: pyproject.toml constraints.txt | $(PY)
	$(PIP) -e ".[bench,mujoco,mjwarp,arm,rl,ray,clients,web,jax,dev]"
	touch $@ $(VENV)/.demo-installed $(VENV)/.serve-installed

demo: $(VENV)/.demo-installed
	$(VENV)/bin/hri-bench demo --out $(DEMO_OUT)

# What the tests need from the system: xvfb-run for the render_mode="human" window tests, and
# Debian's chromium and chromium-driver for the browser test of `hri-bench serve` (a browser
# build that a tool downloads itself cannot be fetched on these machines). Installed from
# Debian's packages where missing (as root, or with sudo when it asks nothing).
system-deps:
	@missing=; \
	command -v xvfb-run >/dev/null || missing="$$missing xvfb"; \
	command -v chromium >/dev/null || missing="$$missing chromium"; \
	command -v chromedriver >/dev/null || missing="$$missing chromium-driver"; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then SUDO=; else SUDO="sudo -n"; fi; \
	  $$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq $$missing >/dev/null \
	  || echo "make test: could not install$$missing (Debian's packages); the window and browser tests will skip"; \
	fi

# Lint, type and layer checks first, so that pytest's summaries are the last lines.
test: $(VENV)/.test-installed system-deps web
	$(VENV)/bin/ruff check hri_envs agents baselines hri_bench tests examples benchmarks
	@# MuJoCo Warp's tests run in a process of their own, beside the others: they keep about
	@# one core busy (Warp compiles its kernels once, about 1.5 min of one core without a
	@# cache, into ~/.cache/warp or $$WARP_CACHE_PATH, which later runs reuse), so the other
	@# core is left to the rest. Their output is shown when they end; a failure of either fails.
	@# The Learner's numba kernels (about 30 s of one core on a fresh clone, cached beside
	@# their module) and the continuous envs' compiled control periods (about 25 s, cached in
	@# hri_envs/physics/scene/__pycache__/kernels-<hash of their sources>) are compiled once,
	@# beside mypy, before the tests' processes would each compile them at once. JAX starts threads on import, and a process that forks after
	@# that may hang: its tests run in a process of their own too, never collected by the run
	@# whose tests fork pools.
	@warp_log=$$(mktemp); \
	echo "MUJOCO_GL=egl $(PY) -m pytest -q tests/test_mjwarp*.py  (in the background)"; \
	MUJOCO_GL=egl $(PY) -m pytest -q -p no:cacheprovider tests/test_mjwarp*.py \
	  >"$$warp_log" 2>&1 & warp=$$!; \
	trap 'kill $$warp 2>/dev/null; rm -f "$$warp_log"' EXIT; \
	set -x; \
	{ $(PY) -c "from agents.learning.algorithm1 import preload; preload()" \
	  && $(PY) -c "from hri_envs.physics.carry.stages import preload; preload()"; } & kernels=$$!; \
	$(VENV)/bin/mypy && $(VENV)/bin/lint-imports && wait $$kernels \
	&& MUJOCO_GL=egl $(PY) -m pytest -q -n auto --dist loadgroup \
	  --ignore-glob='tests/test_jax*' --ignore-glob='tests/test_mjwarp*' \
	&& MUJOCO_GL=egl $(PY) -m pytest -q tests/test_jax*.py; \
	rest=$$?; set +x; \
	if [ $$rest -ne 0 ]; then exit $$rest; fi; \
	echo "waiting for tests/test_mjwarp*.py"; wait $$warp; warp_status=$$?; \
	cat "$$warp_log"; exit $$warp_status

# A person plays the human in a browser (http://127.0.0.1:8000/); sessions are recorded.
serve: $(VENV)/.serve-installed web
	$(VENV)/bin/hri-bench serve $(SERVE_ARGS)

# The page's 3D view draws with three.js, installed from npm at the version web/package-lock.json
# pins and copied into the page's folder (served by hri-bench serve itself: the page loads
# nothing from elsewhere). Without npm the page still works and says how to build it.
WEB_VENDOR := hri_bench/people/serve/static/vendor
web: $(WEB_VENDOR)/.built

$(WEB_VENDOR)/.built: web/package.json web/package-lock.json
	@if command -v npm >/dev/null; then \
	  (cd web && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error) \
	  && mkdir -p $(WEB_VENDOR) \
	  && cp web/node_modules/three/build/three.module.js web/node_modules/three/build/three.core.js $(WEB_VENDOR)/ \
	  && cp web/node_modules/three/LICENSE $(WEB_VENDOR)/three.LICENSE \
	  && touch $@ \
	  || echo "make web: npm ci failed; the page's 3D view is not built (see above)"; \
	else \
	  echo "make web: npm is not installed; the page's 3D view is not built (apt-get install npm, then make web)"; \
	fi

speed: $(VENV)/.demo-installed
	$(VENV)/bin/hri-bench speed

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache .mypy_cache web/node_modules $(WEB_VENDOR)
