#!/usr/bin/env bash
# Check the lowest supported versions: install the package with every direct dependency at
# the lowest version pyproject.toml allows (uv's --resolution lowest-direct) into a scratch
# environment, and run the tests that need no more than the base, bench, dev and mujoco
# extras. The rl, ray and clients extras pin torch to the local CPU build, which uv cannot
# use, so they are not checked here.
#
#   bash benchmarks/lowest_versions.sh [SCRATCH_DIR]      # from the checkout, after make test
set -euo pipefail
cd "$(dirname "$0")/.."
scratch=${1:-$(mktemp -d)}
python3 -m venv "$scratch/uv" && "$scratch/uv/bin/pip" install -q uv
"$scratch/uv/bin/uv" venv -q -p python3 "$scratch/low"
"$scratch/uv/bin/uv" pip install -q -p "$scratch/low/bin/python" --resolution lowest-direct \
    -e ".[bench,dev,mujoco]"
"$scratch/uv/bin/uv" pip list -p "$scratch/low/bin/python" 2>/dev/null \
    | grep -iE '^(numpy|gymnasium|pettingzoo|threadpoolctl|matplotlib|tqdm|scipy|numba|tyro|mujoco|mink|gymnasium-robotics|imageio) '
MUJOCO_GL=egl "$scratch/low/bin/python" -m pytest -q -p no:cacheprovider -W ignore \
    tests/test_task.py tests/test_mdp.py tests/test_graph_invariants.py tests/test_step_table.py \
    tests/test_envs_pettingzoo.py tests/test_envs_vector.py tests/test_formats.py \
    tests/test_populations.py tests/test_house.py tests/test_bounds.py tests/test_suite.py \
    tests/test_partner_mdp.py tests/test_learner_reference.py tests/test_physics.py \
    tests/test_physics_human.py tests/test_physics_sensing.py tests/test_physics_contacts.py \
    tests/test_physics_loop.py
