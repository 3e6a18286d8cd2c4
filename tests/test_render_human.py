"""render_mode="human": a clear error without a display; a window under a virtual display.

The window tests run a child Python under ``xvfb-run`` (package ``xvfb``) and are skipped
where it is not installed.
"""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import pytest

from hri_envs import hanger_v0, wheel_v0
from hri_envs.envs.partner import PartnerEnv
from hri_envs.errors import ConfigError, DisplayUnavailableError

ROOT = Path(__file__).resolve().parents[1]
XVFB = shutil.which("xvfb-run")
needs_xvfb = pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
linux_only = pytest.mark.skipif(sys.platform != "linux", reason="display checks are X11's")

CONSTRUCTORS = [
    pytest.param(lambda: hanger_v0.parallel_env(render_mode="human"), id="parallel"),
    pytest.param(lambda: wheel_v0.env(render_mode="human"), id="aec"),
    pytest.param(lambda: gym.make("hri_envs/Hanger-v0", render_mode="human"), id="gymnasium"),
    pytest.param(lambda: hanger_v0.parallel_env(render_mode="human", backend="mujoco"),
                 id="mujoco"),
]


@linux_only
@pytest.mark.parametrize("make", CONSTRUCTORS)
def test_no_display_is_a_clear_error_before_any_simulation(make, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(DisplayUnavailableError, match=re.escape(
            "render_mode='human' opens a window, but there is no display here (neither "
            "DISPLAY nor WAYLAND_DISPLAY is set); use render_mode='rgb_array'")) as err:
        make()
    assert isinstance(err.value, ConfigError) and err.value.field == "render_mode"
    assert "xvfb-run -a python" in str(err.value)


def test_every_env_lists_human_rendering():
    assert "human" in hanger_v0.parallel_env().metadata["render_modes"]
    assert "human" in wheel_v0.env().metadata["render_modes"]
    assert "human" in gym.make("hri_envs/Wheel-v0").metadata["render_modes"]
    assert "human" in PartnerEnv(hanger_v0.parallel_env()).metadata["render_modes"]


@linux_only
def test_non_interactive_matplotlib_backend_is_a_clear_error(monkeypatch):
    matplotlib = pytest.importorskip("matplotlib")
    monkeypatch.setenv("DISPLAY", ":99")
    matplotlib.use("agg")
    env = hanger_v0.parallel_env(render_mode="human")
    with pytest.raises(DisplayUnavailableError,
                       match="needs an interactive matplotlib backend, but the backend is 'agg'"):
        env.reset(seed=0)
    env.close()


def run_under_xvfb(code: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("MPLBACKEND", "DISPLAY")}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    env["MUJOCO_GL"] = "glfw"  # the passive viewer draws with GLFW
    # 24-bit colour: Xvfb's default 8-bit screen has no OpenGL visual for MuJoCo
    return subprocess.run([XVFB, "-a", "-s", "-screen 0 1024x768x24", sys.executable, "-c",
                           code], capture_output=True, text=True, timeout=300, env=env,
                          check=False)


@needs_xvfb
def test_pettingzoo_render_test_and_gymnasium_check_env_with_a_window():
    out = run_under_xvfb(
        "from pettingzoo.test import render_test\n"
        "from gymnasium.utils.env_checker import check_env\n"
        "import gymnasium as gym, matplotlib.pyplot as plt\n"
        "from hri_envs import hanger_v0, wheel_v0\n"
        "render_test(hanger_v0.env)\n"
        "render_test(wheel_v0.env)\n"
        "check_env(gym.make('hri_envs/Hanger-v0').unwrapped)\n"
        "env = hanger_v0.parallel_env(render_mode='human')\n"
        "env.reset(seed=0)\n"
        "print('windows', len(plt.get_fignums()), plt.get_backend())\n"
        "env.close()\n"
        "print('closed', len(plt.get_fignums()))\n"
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert "windows 1 tkagg" in out.stdout.lower() and "closed 0" in out.stdout


@needs_xvfb
def test_mujoco_passive_viewer_with_a_window():
    pytest.importorskip("mujoco")
    out = run_under_xvfb(
        "import gymnasium as gym, hri_envs\n"
        "env = gym.make('hri_envs/HangerPanda-v0', render_mode='human', max_cycles=2)\n"
        "env.reset(seed=0)\n"
        "viewer = env.unwrapped._episode._viewer\n"
        "print('viewer running', viewer.is_running(), flush=True)\n"
        "env.step(0)\n"
        "print('render', env.render(), flush=True)\n"
        "env.close()\n"
        "print('closed', env.unwrapped._episode._viewer, flush=True)\n"
        # On Xvfb's software OpenGL, GLFW's teardown at interpreter exit crashed in about
        # half of the runs (10 alone: 5 on 108a8d5, 7 now) and once hung past the timeout:
        # leave without it, once every check above has run.
        "import os; os._exit(0)\n"
    )
    assert "viewer running True" in out.stdout, out.stderr[-3000:]
    assert "render None" in out.stdout and "closed None" in out.stdout
    assert out.returncode == 0, out.stderr[-3000:]
