"""Shared pytest set-up."""

import os
import tempfile

# MuJoCo picks its OpenGL backend at import time: headless EGL unless the user chose one.
os.environ.setdefault("MUJOCO_GL", "egl")
# pytest-xdist already runs a worker per core: the Learner's batches stay on one thread
# (tests/test_partner_threads.py sets threads itself).
os.environ.setdefault("HRI_ENVS_THREADS", "1")
# Tests that call SB3's learn() on a model of their own log nowhere: one shared folder for
# SB3's empty log folders instead of a new SB3-<time> folder in the temp dir per call.
os.environ.setdefault("SB3_LOGDIR", os.path.join(tempfile.gettempdir(), "hri-envs-tests-sb3"))

import pytest  # noqa: E402  (after MUJOCO_GL)

from tests.helpers_partner import HAS_JIT  # noqa: E402

try:  # MuJoCo's warnings (a test's NaN control) go to a list, not to MUJOCO_LOG.TXT in the cwd
    import mujoco

    MUJOCO_WARNINGS: list[str] = []
    mujoco.set_mju_user_warning(MUJOCO_WARNINGS.append)
except ImportError:  # the physics extra is not installed
    pass


@pytest.fixture(scope="module")
def wheel():
    """The wheel's task graph (a module's own: a test may change its arrays)."""
    from hri_envs.task import build_graph, wheel_scenario

    return build_graph(wheel_scenario())


@pytest.fixture(scope="module")
def hanger():
    """The hanger's task graph (a module's own)."""
    from hri_envs.task import build_graph, hanger_scenario

    return build_graph(hanger_scenario())


@pytest.fixture(params=["numpy", "jit"])
def path(request, monkeypatch):
    """Run a test of the learning math on the numpy path and on the compiled one (the
    compiled one is skipped without numba)."""
    from agents.learning import partner_mdp

    if request.param == "numpy":
        monkeypatch.setattr(partner_mdp, "kernels", lambda: None)
    elif not HAS_JIT:
        pytest.skip("numba is not importable (or HRI_ENVS_NO_JIT is set)")
    return request.param


def pytest_collection_modifyitems(config, items):
    """Mark the tests of the JAX modules (``tests/test_jax*.py``) ``jax``.

    JAX starts threads when imported, and a process that forks after that may deadlock (JAX
    warns so). Several tests fork (study pools, kills), so ``make test`` runs these modules in
    a pytest run of their own, after a run that does not collect (import) them; ``-m jax``
    selects them here.
    """
    for item in items:
        if item.path.name.startswith("test_jax"):
            item.add_marker(pytest.mark.jax)
