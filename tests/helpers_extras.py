"""What hri-envs does without an extra (tests/test_missing_extras.py).

:func:`scenarios` says, from the installed distributions' metadata, which top-level modules
would be missing in each situation a user can be in: one extra not installed while the
others are (minus the modules another installed extra brings as a dependency: ``scipy``
comes with ``mink``), no extra at all, or only ``bench`` (after ``make demo``).

``python -m tests.helpers_extras MODULES`` hides those modules (``sys.modules[m] = None``,
so that importing one raises ``ModuleNotFoundError`` and ``importlib.util.find_spec``
finds none, as if it were not installed) before anything imports them, then walks the
registry: every Gymnasium id (made, reset, stepped), with every backend and drive, the
vector forms, the PettingZoo modules, the optional packages of the library, and every
command of :data:`COMMANDS` whose needs are hidden. It prints one JSON line per attempt:
ok, or the exception's type and message (a library call), or the exit status and standard
error (a command).
"""

from __future__ import annotations

import sys

#: Every ``hri-bench`` command with what it needs beyond the base install (module names),
#: each in a form that reaches its optional imports quickly. ``FILE``, ``DIR`` and ``OUT``
#: are a results file (its format only), an empty folder and a new folder; ``RESULTS`` holds
#: ``FILE``. A command runs in a situation only when one of the modules it needs is missing
#: there: it must then stop with one line.
COMMANDS: tuple[tuple[tuple[str, ...], tuple[str, ...]], ...] = (
    (("study", "wheel", "--runs", "1", "--episodes", "1", "--agents", "passive", "--out", "OUT"),
     ("matplotlib", "tqdm")),
    (("study", "hanger", "--runs", "1", "--episodes", "1", "--agents", "passive", "--backend",
      "mujoco", "--no-progress", "--out", "OUT"), ("mujoco", "mink", "gymnasium_robotics")),
    (("study", "hanger", "--runs", "1", "--episodes", "1", "--agents", "passive", "--backend",
      "mjwarp", "--no-progress", "--out", "OUT"), ("warp", "mujoco_warp", "mink_warp", "mink")),
    (("study", "wheel", "--runs", "1", "--episodes", "1", "--agents", "passive", "--executor",
      "ray", "--no-progress", "--out", "OUT"), ("ray",)),
    (("study", "hanger", "--runs", "1", "--episodes", "1", "--agents", "sb3:FILE",
      "--no-progress", "--out", "OUT"), ("stable_baselines3", "sb3_contrib", "torch")),
    (("study", "hanger", "--runs", "1", "--episodes", "1", "--agents", "jaxppo",
      "--no-progress", "--out", "OUT"), ("jax", "optax")),
    (("figures", "--out", "OUT", "--runs", "1", "--only", "fig10a", "--wheel-episodes", "1"),
     ("matplotlib", "tqdm")),
    (("demo", "--out", "OUT"), ("matplotlib", "tqdm")),
    (("suite", "--out", "OUT", "--runs-scale", "0.01", "--tracks", "hanger-paper",
      "--no-progress"), ("matplotlib", "tqdm")),
    (("speed", "--physics", "--size", "tiny", "--no-jax", "--physics-worlds", "1"),
     ("mujoco", "mink", "gymnasium_robotics", "warp", "mujoco_warp", "mink_warp")),
    (("serve", "hanger", "--data", "DIR"), ("fastapi", "uvicorn")),
    (("dataset", "list", "--data", "DIR"), ("pyarrow",)),
    (("dataset", "record", "hanger", "--dataset", "d", "--sessions", "1", "--episodes", "1",
      "--data", "DIR"), ("pyarrow",)),
    (("replay", "d", "--data", "DIR"), ("pyarrow",)),
    (("validate", "FILE"), ("jsonschema",)),
    (("leaderboard", "RESULTS"), ("jsonschema", "matplotlib")),
)
#: What the muscle-driven arm needs (``drive="muscle"``, the "arm" extra).
MUSCLES = ("myo_sim", "scipy")
#: Commands that need nothing beyond the base install and ``bench`` (their own tests run
#: them): every command of the parser is in :data:`COMMANDS` or here.
WITHOUT_EXTRAS = ("play",)


def _attempt(what: str, fn, results: list) -> None:
    import traceback

    from hri_envs.errors import HriEnvsError

    try:
        fn()
        results.append({"what": what, "ok": True})
    except Exception as exc:  # noqa: BLE001 - reported, judged by the test
        results.append({"what": what, "ok": False, "type": type(exc).__name__,
                        "ours": isinstance(exc, HriEnvsError), "message": str(exc),
                        "traceback": traceback.format_exc()[-2000:]})


def _command(argv: list[str], results: list) -> None:
    import contextlib
    import io
    import traceback

    from hri_bench.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 99
        except BaseException:  # noqa: BLE001 - a traceback is what the test refuses
            traceback.print_exc(file=err)
            code = 98
    results.append({"what": "hri-bench " + " ".join(argv), "ok": code == 0, "code": code,
                    "stderr": err.getvalue()})


def walk(hidden: set[str], tmp: str) -> list:
    """Every attempt, in the situation where ``hidden`` is not installed."""
    import importlib
    import json
    import os

    import gymnasium as gym
    import numpy as np

    import hri_envs  # noqa: F401 - registers the ids
    from hri_bench.suite.submission import FORMAT
    from hri_envs.envs.backends import BACKENDS
    from hri_envs.task.scenarios import SCENARIOS

    def needs(*modules: str) -> bool:
        return any(m in hidden for m in modules)

    def make(env_id: str, **kwargs) -> None:
        env = gym.make(env_id, **kwargs)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()

    results: list = []
    ids = [i for i in gym.registry if i.startswith("hri_envs/")]
    for env_id in ids:
        spec = gym.registry[env_id]
        _attempt(f"gymnasium.make({env_id!r})", lambda i=env_id: make(i), results)
        continuous = "Continuous" in env_id
        physical = continuous or spec.kwargs.get("backend") in BACKENDS and BACKENDS[
            spec.kwargs["backend"]].physical
        # Another backend or drive: where what it needs is missing (else its own tests).
        for name, backend in BACKENDS.items():
            if physical and not backend.physical:
                continue  # refused with a ConfigError of its own (tests/test_panda_ids.py)
            if needs(*backend.requires):
                _attempt(f"gymnasium.make({env_id!r}, backend={name!r})",
                         lambda i=env_id, b=name: make(i, backend=b), results)
        if continuous and needs(*MUSCLES, *BACKENDS["mujoco"].requires):
            _attempt(f"gymnasium.make({env_id!r}, drive='muscle')",
                     lambda i=env_id: gym.make(i, drive="muscle").close(), results)
        vector = spec.vector_entry_point
        if vector is not None and (not physical or needs(*BACKENDS["mjwarp"].requires)):
            _attempt(f"gymnasium.make_vec({env_id!r})", lambda i=env_id: gym.make_vec(
                i, num_envs=2, vectorization_mode="vector_entry_point").close(), results)
    for scenario in SCENARIOS.values():
        modules = [scenario.pettingzoo_module, *(
            f"hri_envs.{scenario.name}_continuous_v{v}" for v in (0, 1)
            if scenario.continuous_id is not None)]
        for module in filter(None, modules):
            _attempt(f"{module}.parallel_env().reset()", lambda m=module: importlib.import_module(
                m).parallel_env().reset(seed=0), results)
    for module in ("hri_envs.jax", "agents.jax_ppo.train", "agents.rl", "agents.sb3"):
        _attempt(f"import {module}", lambda m=module: importlib.import_module(m), results)
    files = {"RESULTS": os.path.join(tmp, "results"), "DIR": os.path.join(tmp, "dir")}
    files["FILE"] = os.path.join(files["RESULTS"], "results.json")
    os.makedirs(files["DIR"], exist_ok=True)
    os.makedirs(files["RESULTS"], exist_ok=True)
    with open(files["FILE"], "w") as f:
        f.write(json.dumps({"format": FORMAT}) + "\n")
    for n, (command, modules) in enumerate(COMMANDS):
        if needs(*modules):
            out = {**files, "OUT": os.path.join(tmp, f"out{n}")}
            argv = [out.get(w, w.replace("FILE", out["FILE"])) for w in command]
            _command(argv, results)
    del np
    return results


def main() -> None:
    """``python -m tests.helpers_extras MODULE,MODULE TMP``: hide, walk, print JSON lines."""
    hidden = set(filter(None, sys.argv[1].split(",")))
    for module in hidden:
        sys.modules[module] = None  # type: ignore[assignment]
    import json

    for row in walk(hidden, sys.argv[2]):
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
