"""Every command and code block of README.md and docs/*.md works as pasted (issue 34).

Each fenced ``bash`` block runs, command by command in its order, in a fresh shell that
has not activated ``.venv`` (``PATH`` without it, no ``VIRTUAL_ENV``), in a workspace: a
temporary folder holding symbolic links to the checkout's files, so that every relative
``out/...`` a command writes lands there. Each fenced ``python`` block runs in a fresh
``.venv/bin/python`` there; consecutive blocks of one page share one process (a page builds
its example up block by block), and a block whose first line is a comment naming a file
(``# mylab/follower.py``) is also written to that file, for the commands that import it.

:data:`PLAN` says, for every command of the pages, what the test does with it: run it as
pasted, run it scaled down (the scaled command and why, next to the original), run it with
what a person would type on its standard input, or skip it with the reason (a browser
session, a server, an installation, minutes of training, JAX) and check its syntax instead
(its arguments parse; the flags of a script are its own; ``make -n`` of a target). A
command of the pages that :data:`PLAN` does not list fails the test, so a new one is
decided on when it is written. Blocks that are not commands (``json``, diagrams, a
synopsis) are listed in :data:`NOT_RUN`; the synopsis has its flags checked.

After each page, ``git status`` of the checkout must be as before: nothing a documented
command or snippet writes may land among the checkout's files (``ppo_hanger.zip`` did).
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from hri_bench.cli import build_parser
from hri_bench.cli.args import split_imports
from hri_bench.cli.physical import build_physical_parser, wants_physical

ROOT = Path(__file__).resolve().parents[1]
DOCS = ("README.md", *(f"docs/{p.name}" for p in sorted((ROOT / "docs").glob("*.md"))))
SHELL = ("bash", "sh", "shell")
#: Per command (seconds): the scaled commands take a few each.
TIMEOUT = 300


@dataclass(frozen=True)
class Block:
    """A fenced block of a page: where it starts (the line after the fence), its language
    and its text."""

    doc: str
    line: int
    lang: str
    text: str

    @property
    def where(self) -> str:
        return f"{self.doc}:{self.line}"


def read_blocks(doc: str) -> list[Block]:
    """The fenced blocks of ``doc`` in their order."""
    lines = (ROOT / doc).read_text().split("\n")
    blocks, i = [], 0
    while i < len(lines):
        opening = re.match(r"^```(\S*)\s*$", lines[i])
        if opening:
            end = next(j for j in range(i + 1, len(lines)) if re.match(r"^```\s*$", lines[j]))
            blocks.append(Block(doc, i + 2, opening.group(1),
                                "\n".join(lines[i + 1:end]) + "\n"))
            i = end
        i += 1
    return blocks


def commands(text: str) -> list[str]:
    """The commands of a shell block: continued lines joined, comments dropped, spaces
    collapsed (the keys of :data:`PLAN`)."""
    found = []
    for line in text.replace("\\\n", " ").split("\n"):
        line = re.sub(r"\s+#\s.*$", "", line).strip()
        if line and not line.startswith("#"):
            found.append(" ".join(line.split()))
    return found


# --------------------------------------------------------------------------- what to do
@dataclass(frozen=True)
class Scaled:
    """Run ``command`` instead (the same command, scaled down), because ``why``."""

    command: str
    why: str


@dataclass(frozen=True)
class Fed:
    """Run the command as pasted with ``stdin`` on its standard input (what a person
    types)."""

    stdin: str
    why: str


@dataclass(frozen=True)
class Skip:
    """Do not run it, because ``why``; ``check(command)`` checks its syntax instead."""

    why: str
    check: Callable[[str], None]


RUN = "run as pasted"
Plan = str | Scaled | Fed | Skip


def _words(command: str) -> list[str]:
    return shlex.split(command)


def parses(command: str, *, replace: tuple[tuple[str, str], ...] = ()) -> None:
    """``.venv/bin/hri-bench ...`` parses (argparse exits 2 if it does not). ``replace``
    swaps a file the command reads that an earlier (skipped) command writes."""
    for old, new in replace:
        command = command.replace(old, new)
    words = _words(command)
    while "=" in words[0]:  # VAR=value before the program
        words.pop(0)
    assert words[0] == ".venv/bin/hri-bench", command
    if wants_physical(words[1:]):  # the physical suite has a parser of its own
        build_physical_parser().parse_args(split_imports(words[1:])[1][1:])
        return
    build_parser().parse_args(words[1:])


def make_runs(target: str, expected: str) -> Callable[[str], None]:
    """``make -n`` of the command prints ``expected`` (an ``hri-bench`` command that then
    parses, or a part of the recipe)."""

    def check(command: str) -> None:
        done = subprocess.run(["make", "-n", *_words(command)[1:]], cwd=ROOT, text=True,
                              capture_output=True, timeout=60, env=_fresh_env())
        assert done.returncode == 0, done.stderr
        line = next(x for x in done.stdout.splitlines() if expected in x)
        if line.startswith(".venv/bin/hri-bench"):
            parses(line)
        assert _words(command)[1] == target, command  # the page's make target is ours

    return check


def script_flags(command: str, *, config: str | None = None) -> None:
    """A script's flags are its own: each ``--flag`` of the command is an argparse option or
    a tyro field (``--total-steps``: ``total_steps:``) in the script's source, or in the
    module ``config`` that defines the dataclass it reads."""
    words = _words(command)
    if words[1] == "-m":  # python -m package.module: its file in the checkout
        words = [words[0], words[2].replace(".", "/") + ".py", *words[3:]]
    script = ROOT / words[1]
    assert words[0] == ".venv/bin/python" and script.is_file(), command
    source = script.read_text() + ((ROOT / config).read_text() if config else "")
    for flag in (w.split("=")[0] for w in words[2:] if w.startswith("--")):
        field = flag[2:].replace("-", "_")
        assert f'"{flag}"' in source or re.search(rf"^\s+{field}:", source, re.M), flag


def jax_script_flags(command: str) -> None:
    """:func:`script_flags` of benchmarks/train_jax_ppo.py, whose settings are
    :class:`agents.jax_ppo.config.TrainConfig`'s (without importing JAX here)."""
    script_flags(command, config="agents/jax_ppo/config.py")


def syntax(command: str) -> None:
    """The syntax check of a command: an ``hri-bench`` command parses, a script's flags are
    its own (after any ``VAR=value`` before the program)."""
    words = _words(command)
    while "=" in words[0]:
        words.pop(0)
    if words[0] == ".venv/bin/python":
        script_flags(shlex.join(words))
    else:
        parses(command)


def an_extra(command: str) -> None:
    """``.venv/bin/pip install -c constraints.txt -e '.[EXTRA,...]'``: the extras exist."""
    words = _words(command)
    assert words[:5] == [".venv/bin/pip", "install", "-c", "constraints.txt", "-e"], command
    named = re.fullmatch(r"\.\[([\w,]+)\]", words[5]).group(1).split(",")
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    assert set(named) <= set(extras), named


#: The stand-in for a dataset people recorded with `make serve` (a browser session the test
#: cannot hold): the same recorder, with scripted humans (synthetic), under that name.
PEOPLE = (".venv/bin/hri-bench dataset record hanger --dataset hanger-people --sessions 4 "
          "--episodes 2 --data out/datasets")
SERVE = "a server for a person's browser session, until Ctrl-C: tests/test_people_browser.py"
INSTALL = "installs packages: `make test` has installed every extra into .venv already"
JAX = ("JAX, in a process of its own in `make test` (it must not share the forking pytest "
       "run): tests/test_jax_ppo.py trains a small policy and plays it in a study")

PLAN: dict[str, Plan] = {
    # README.md
    "make demo": Skip("the full demo: seven studies of 100 runs on both cores (20 s, and a "
                      "minute of compiling after installing); `hri-bench figures` below runs "
                      "the same code scaled down", make_runs("demo", "hri-bench demo")),
    "make test": Skip("this test runs inside it", make_runs("test", "pytest")),
    ".venv/bin/hri-bench study wheel --agents learner,imitator,maxent,passive,oracle --runs 100 "
    "--preference straight --r0 -0.25 --jobs 2 --out out/wheel": Scaled(
        ".venv/bin/hri-bench study wheel --agents learner,imitator,maxent,passive,oracle "
        "--runs 2 --preference straight --r0 -0.25 --jobs 2 --out out/wheel", "2 runs"),
    ".venv/bin/hri-bench study hanger --schedule table2 --preference all --out out/table2":
        Scaled(".venv/bin/hri-bench study hanger --schedule table2 --preference all --runs 2 "
               "--out out/table2", "2 runs instead of 100"),
    ".venv/bin/hri-bench study wheel --agents learner,examples.custom_learner:GoalMemory "
    "--out out/mine": Scaled(".venv/bin/hri-bench study wheel --agents "
                             "learner,examples.custom_learner:GoalMemory --runs 2 --out out/mine",
                             "2 runs instead of 100"),
    ".venv/bin/hri-bench study --config out/wheel/summary.json --out out/again": RUN,
    ".venv/bin/hri-bench figures --out out/figures --runs 100 --jobs 2": Scaled(
        ".venv/bin/hri-bench figures --out out/figures --runs 2 --wheel-episodes 3",
        "2 runs, 3 wheel episodes, one process"),
    ".venv/bin/hri-bench speed --json": Scaled(
        ".venv/bin/hri-bench speed --json --size tiny --no-jax",
        "every measurement at its smallest; the JAX figures compile PPO (" + JAX + ")"),
    ".venv/bin/hri-bench play hanger": Fed("1\n1\n2\nq\n", "a person's three moves, then q"),
    ".venv/bin/hri-bench study wheel --preference straight --human-passive 0.2 --agents "
    "informed,blind,learner,oracle --runs 100 --out out/bounds": Scaled(
        ".venv/bin/hri-bench study wheel --preference straight --human-passive 0.2 --agents "
        "informed,blind,learner,oracle --runs 2 --out out/bounds", "2 runs"),
    ".venv/bin/hri-bench study wheel --preference straight --human-passive 0.2 --agents "
    "informed,blind,learner,oracle --runs 100 --out out/bounds-toggle --reward no-free-toggle":
        Scaled(".venv/bin/hri-bench study wheel --preference straight --human-passive 0.2 "
               "--agents informed,blind,learner,oracle --runs 2 --out out/bounds-toggle "
               "--reward no-free-toggle", "2 runs"),
    ".venv/bin/hri-bench suite --out out/suite --jobs 2": Scaled(
        ".venv/bin/hri-bench suite --out out/suite --runs-scale 0.01 --tracks hanger-paper",
        "one track, its smallest runs scale (2 runs), one process"),
    ".venv/bin/hri-bench suite --out out/mine-suite --jobs 2 --agents "
    "learner,examples.custom_learner:GoalMemory": Scaled(
        ".venv/bin/hri-bench suite --out out/mine-suite --agents "
        "learner,examples.custom_learner:GoalMemory --runs-scale 0.01 --tracks hanger-paper",
        "one track, 2 runs, one process"),
    ".venv/bin/hri-bench suite --out out/smoke --runs-scale 0.05 --tracks "
    "wheel-test-inconsistent,wheel-paper": Scaled(
        ".venv/bin/hri-bench suite --out out/smoke --runs-scale 0.01 --tracks "
        "wheel-test-inconsistent,wheel-paper", "runs scale 0.01 instead of 0.05"),
    "make serve": Skip(SERVE, make_runs("serve", "hri-bench serve")),
    'make serve SERVE_ARGS="wheel --episodes 10 --data out/datasets"': Skip(
        SERVE, make_runs("serve", "hri-bench serve wheel --episodes 10")),
    ".venv/bin/hri-bench dataset show hanger-people --data out/datasets": RUN,
    ".venv/bin/hri-bench dataset export hanger-people --data out/datasets --format minari": RUN,
    ".venv/bin/hri-bench dataset export hanger-people --data out/datasets --out "
    "out/people.parquet": RUN,
    ".venv/bin/hri-bench replay hanger-people --data out/datasets --frames out/replay": RUN,
    ".venv/bin/hri-bench dataset fit hanger-people --data out/datasets": RUN,
    "HRI_BENCH_DATASETS=out/datasets .venv/bin/hri-bench study hanger --population "
    "recorded:hanger-people --out out/people": Scaled(
        "HRI_BENCH_DATASETS=out/datasets .venv/bin/hri-bench study hanger --population "
        "recorded:hanger-people --runs 2 --out out/people", "2 runs"),
    "HRI_BENCH_DATASETS=out/datasets .venv/bin/hri-bench suite --population "
    "recorded:hanger-people --out out/suite-people": Scaled(
        "HRI_BENCH_DATASETS=out/datasets .venv/bin/hri-bench suite --population "
        "recorded:hanger-people --out out/suite-people --runs-scale 0.01 --tracks hanger-paper",
        "the recorded track beside one of the suite's, 2 runs each"),
    ".venv/bin/pip install -c constraints.txt -e '.[rl]'": Skip(INSTALL, an_extra),
    ".venv/bin/python examples/train_maskable_ppo.py": Scaled(
        ".venv/bin/python examples/train_maskable_ppo.py --timesteps 1024 --n-envs 4 --runs 2 "
        "--episodes 2", "1,024 training steps instead of 30,000; 2 runs of 2 episodes"),
    ".venv/bin/hri-bench study hanger --agents learner,sb3:out/train_maskable_ppo/ppo_hanger.zip "
    "--out out/sb3": Scaled(
        ".venv/bin/hri-bench study hanger --agents "
        "learner,sb3:out/train_maskable_ppo/ppo_hanger.zip --runs 2 --out out/sb3", "2 runs"),
    ".venv/bin/python benchmarks/train_jax_ppo.py --scenario hanger --total-steps 25000000 "
    "--out out/jaxppo": Skip("25 M steps of JAX training (140 s); " + JAX, jax_script_flags),
    ".venv/bin/hri-bench suite --suite-version 1 --agents "
    "learner,imitator,maxent,passive,oracle,jaxppo --jobs 2 --out out/suite-jaxppo": Skip(
        JAX, parses),
    # docs/agents.md
    ".venv/bin/hri-bench study hanger --agents learner,mylab.follower:Follower --runs 20 "
    "--out out/follower": Scaled(".venv/bin/hri-bench study hanger --agents "
                                 "learner,mylab.follower:Follower --runs 2 --out out/follower",
                                 "2 runs instead of 20"),
    # docs/extending.md
    ".venv/bin/hri-bench --import mylab.humans study wheel --population sloppy --human-param "
    "noise=4 --agents learner,passive --runs 20 --out out/sloppy": Scaled(
        ".venv/bin/hri-bench --import mylab.humans study wheel --population sloppy "
        "--human-param noise=4 --agents learner,passive --runs 2 --out out/sloppy", "2 runs"),
    ".venv/bin/hri-bench study --config out/sloppy/summary.json --out out/sloppy-again": RUN,
    ".venv/bin/hri-bench --import mylab.rewards study wheel --reward costly-wait --agents "
    "learner,passive --runs 20 --out out/costly": Scaled(
        ".venv/bin/hri-bench --import mylab.rewards study wheel --reward costly-wait --agents "
        "learner,passive --runs 2 --out out/costly", "2 runs"),
    ".venv/bin/hri-bench --import mylab.agents study wheel --agents learner,eager-goalfilter "
    "--runs 20 --out out/eager": Scaled(
        ".venv/bin/hri-bench --import mylab.agents study wheel --agents "
        "learner,eager-goalfilter --runs 2 --out out/eager", "2 runs"),
    # docs/people.md
    ".venv/bin/pip install -c constraints.txt -e '.[web]'": Skip(INSTALL, an_extra),
    # docs/physics.md
    ".venv/bin/pip install -c constraints.txt -e '.[mujoco,arm]'": Skip(INSTALL, an_extra),
    'make serve SERVE_ARGS="hanger --data out/datasets"': Skip(
        SERVE, make_runs("serve", "hri-bench serve hanger --data out/datasets")),
    ".venv/bin/hri-bench serve hanger --data out/datasets": Skip(SERVE, parses),
    ".venv/bin/hri-bench serve wheel --episodes 10 --agent learner --preferences all --consent "
    "my-consent.txt --instructions my-instructions.txt --data out/datasets": Skip(
        SERVE + " (and your own consent and instruction texts)", parses),
    ".venv/bin/hri-bench dataset list --data out/datasets": RUN,
    ".venv/bin/hri-bench dataset show hanger-people --data out/datasets --json": RUN,
    ".venv/bin/hri-bench dataset export hanger-people --data out/datasets --out "
    "out/hanger.parquet": RUN,
    ".venv/bin/hri-bench dataset record hanger --dataset hanger-scripted --sessions 20 "
    "--episodes 8 --preference all --human-passive 0.1 --data out/datasets": Scaled(
        ".venv/bin/hri-bench dataset record hanger --dataset hanger-scripted --sessions 4 "
        "--episodes 2 --preference all --human-passive 0.1 --data out/datasets",
        "4 sessions of 2 episodes"),
    ".venv/bin/hri-bench replay hanger-people --data out/datasets --participant p3fa2b1c9d0e4 "
    "--frames out/replay": Scaled(
        ".venv/bin/hri-bench replay hanger-people --data out/datasets --participant s0001 "
        "--frames out/replay", "a participant of the stand-in dataset (its ids are s0001, ...)"),
    ".venv/bin/hri-bench replay hanger-people --data out/datasets --participant p3fa2b1c9d0e4 "
    "--step": Scaled(
        "printf '\\n%.0s' $(seq 200) | .venv/bin/hri-bench replay hanger-people --data "
        "out/datasets --participant s0001 --step",
        "a participant of the stand-in dataset, and Enter after each step"),
    ".venv/bin/hri-bench dataset fit hanger-scripted --data out/datasets --out out/models": RUN,
    "export HRI_BENCH_DATASETS=out/datasets": RUN,
    ".venv/bin/hri-bench study hanger --population recorded:hanger-people --agents "
    "learner,imitator,oracle --out out/people": Scaled(
        ".venv/bin/hri-bench study hanger --population recorded:hanger-people --agents "
        "learner,imitator,oracle --runs 2 --out out/people", "2 runs"),
    ".venv/bin/hri-bench study hanger --population recorded-irl:hanger-people --out "
    "out/people-irl": Scaled(
        ".venv/bin/hri-bench study hanger --population recorded-irl:hanger-people --runs 2 "
        "--out out/people-irl", "2 runs"),
    ".venv/bin/hri-bench suite --out out/suite-people --population recorded:hanger-people":
        Scaled(".venv/bin/hri-bench suite --out out/suite-people --population "
               "recorded:hanger-people --runs-scale 0.01 --tracks hanger-paper",
               "the recorded track beside one of the suite's, 2 runs each"),
    ".venv/bin/python benchmarks/serve_load.py --sessions 20 --episodes 8 --think-ms 300": Skip(
        "20 simultaneous browser clients against a server for minutes; "
        "tests/test_people_serve.py drives the same server", script_flags),
    ".venv/bin/hri-bench serve hanger --physical --data out/datasets": Skip(
        SERVE.replace("browser.py", "lead_browser.py"), parses),
    ".venv/bin/hri-bench serve wheel --physical --agent admittance --show-belief --max-time 45 "
    "--data out/datasets": Skip(SERVE.replace("browser.py", "lead_browser.py"), parses),
    "MUJOCO_GL=egl .venv/bin/python docs/figures/people_screenshots.py --out docs/figures": Skip(
        "four servers and headless chromium sessions, writing the docs' figures; "
        "tests/test_people_lead_browser.py drives the same page", syntax),
    "MUJOCO_GL=egl .venv/bin/python benchmarks/people_physical_fit.py --data out/datasets "
    "--sessions 8 --out out/physical-fit": Skip(
        "minutes of sessions led in real time through a server; "
        "tests/test_people_physical_fit.py records, fits and seats the same", syntax),
    ".venv/bin/hri-bench dataset fit hanger-physical-synthetic --data out/datasets --out "
    "out/models": Skip("fits the dataset the skipped command above records", parses),
    ".venv/bin/python benchmarks/serve_load.py --physical --sessions 10 --episodes 4": Skip(
        "10 sessions led at 25 Hz against a server for minutes; "
        "tests/test_people_lead_browser.py drives the same server", script_flags),
    # docs/physics.md
    ".venv/bin/pip install -c constraints.txt -e '.[mjwarp]'": Skip(INSTALL, an_extra),
    ".venv/bin/hri-bench study hanger --backend mujoco --agents learner --runs 4 --episodes 2 "
    "--seed 0 --out out/hanger_c": Scaled(
        ".venv/bin/hri-bench study hanger --backend mujoco --agents learner --runs 1 "
        "--episodes 1 --seed 0 --out out/hanger_c", "1 run of 1 episode on the simulated Panda"),
    ".venv/bin/hri-bench study hanger --backend mjwarp --agents learner --runs 4 --episodes 2 "
    "--seed 0 --out out/hanger_warp": Skip(
        "MuJoCo Warp compiles its kernels first (1.5 min of a core without a cache); "
        "tests/test_mjwarp.py runs it in its own process of `make test`", parses),
    "MUJOCO_GL=egl .venv/bin/python docs/figures/continuous_videos.py --policies upper,passive "
    "--out docs/figures": Scaled(
        "MUJOCO_GL=egl .venv/bin/python docs/figures/continuous_videos.py --policies "
        "upper,passive --scenarios wheel --max-steps 6 --size 160x120 --out out/videos",
        "6 steps of the wheel, small pictures, into the workspace (the page's command "
        "rewrites the committed GIFs in 4 min)"),
    # docs/physical-benchmark.md
    ".venv/bin/hri-bench suite --physical --out out/physical --jobs 2": Scaled(
        ".venv/bin/hri-bench suite --physical --out out/physical --runs-scale 0.01 --tracks "
        "hanger-nominal --agents admittance", "one track, 2 runs, one robot, one process"),
    ".venv/bin/hri-bench suite --physical --out out/physical-smoke --runs-scale 0.03 --jobs 2":
        Skip("every track of the physical suite (2 minutes of both cores); the command "
             "above runs one of them", parses),
    ".venv/bin/hri-bench suite --physical --out out/mine --agents mylab.robots:Mine,admittance":
        Scaled(".venv/bin/hri-bench suite --physical --out out/mine --agents "
               "tests.helpers_physical:OwnAdmittance --runs-scale 0.01 --tracks hanger-nominal",
               "a robot of one's own from the tests (mylab is the reader's), one track"),
    ".venv/bin/hri-bench validate out/physical/results.json": RUN,
    ".venv/bin/hri-bench validate out/physical/results.json --replay 2": Scaled(
        ".venv/bin/hri-bench validate out/physical/results.json --replay 1",
        "one run per track and agent re-simulated"),
    ".venv/bin/hri-bench leaderboard out/physical": RUN,
    # docs/rl.md
    ".venv/bin/pip install -c constraints.txt -e '.[ray]'": Skip(INSTALL, an_extra),
    ".venv/bin/python examples/train_maskable_ppo.py --timesteps 50000 --n-envs 16": Scaled(
        ".venv/bin/python examples/train_maskable_ppo.py --timesteps 1024 --n-envs 16 --runs 2 "
        "--episodes 2 --out out/throughput", "1,024 training steps; 2 runs of 2 episodes; its "
        "own --out (the README's command writes the default one)"),
    ".venv/bin/hri-bench study hanger --agents learner,sb3:out/ppo_hanger.zip,oracle --runs 100 "
    "--out out/ppo": Scaled(".venv/bin/hri-bench study hanger --agents "
                            "learner,sb3:out/ppo_hanger.zip,oracle --runs 2 --out out/ppo",
                            "2 runs"),
    ".venv/bin/python examples/rllib_multiagent.py": Skip(
        "starts a local Ray cluster (36 s and more); tests/test_rl.py trains the same example",
        script_flags),
    ".venv/bin/python examples/rllib_multiagent.py --iterations 12 --batch-size 1000": Skip(
        "a local Ray cluster for 217 s; tests/test_rl.py trains the same example",
        script_flags),
    ".venv/bin/python -m hri_bench.report.sample_efficiency --out out/figures": Scaled(
        ".venv/bin/python -m hri_bench.report.sample_efficiency --out out/figures "
        "--algorithms ''", "the Learner's curve and the references; the RL curves are "
        "minutes of training (tests/test_rl.py trains them small)"),
    ".venv/bin/pip install -c constraints.txt -e '.[jax]'": Skip(INSTALL, an_extra),
    ".venv/bin/python benchmarks/train_jax_ppo.py --scenario wheel --total-steps 12000000 "
    "--out out/jaxppo": Skip("12 M steps of JAX training (84 s); " + JAX, jax_script_flags),
    ".venv/bin/hri-bench suite --suite-version 1 --agents "
    "learner,imitator,maxent,passive,oracle,jaxppo:out/jaxppo --jobs 2 --out out/suite-jaxppo":
        Skip(JAX + "; out/jaxppo is what the skipped training writes",
             lambda c: parses(c, replace=(("jaxppo:out/jaxppo", "jaxppo"),))),
}

#: Commands a page shares with another whose test runs them (page, command) -> that page:
#: checked here (they parse), run once.
ELSEWHERE: dict[tuple[str, str], str] = {
    ("README.md", ".venv/bin/hri-bench dataset show hanger-people --data out/datasets"):
        "docs/people.md",
    ("README.md", ".venv/bin/hri-bench dataset export hanger-people --data out/datasets "
                  "--format minari"): "docs/people.md",
    # the same suite, with the dataset root given by `export HRI_BENCH_DATASETS` there
    ("README.md", "HRI_BENCH_DATASETS=out/datasets .venv/bin/hri-bench suite --population "
                  "recorded:hanger-people --out out/suite-people"): "docs/people.md",
    # the same example script as the README's (there scaled alike), other flags
    ("docs/rl.md", ".venv/bin/python examples/train_maskable_ppo.py --timesteps 50000 "
                   "--n-envs 16"): "README.md",
}
#: Shell commands run in a page's workspace before its blocks (what a person had done).
SETUP: dict[str, tuple[str, ...]] = {
    "README.md": (PEOPLE,),
    "docs/people.md": (PEOPLE,),
}
#: Python blocks run before a page's own, in the same process: the page builds on them.
#: (None now: docs/extending.md imports the box it checks, each of its blocks runs alone.)
PRELUDE: dict[str, tuple[str, int]] = {}
#: Python blocks scaled down: (page, text in a block, replacement, why).
PYTHON_SCALED: tuple[tuple[str, str, str, str], ...] = (
    ("docs/rl.md", "total_timesteps=30_000", "total_timesteps=1_024",
     "1,024 PPO steps instead of 30,000"),
    ("docs/rl.md", "total_timesteps=5_000", "total_timesteps=500",
     "500 DQN steps instead of 5,000"),
)
#: Fenced blocks that are not commands or code, and why.
NOT_RUN: dict[str, str] = {
    "README.md:text": "what the tour's first study prints (its lines are checked)",
    "docs/architecture.md:text": "the packages' floors, a diagram",
    "docs/benchmark.md:text": "the synopsis of `hri-bench study` (its flags are checked)",
    "docs/benchmark.md:json": "a sketch of summary.json, with elisions",
    "docs/people.md:text": "a dataset's files, a diagram",
    "docs/results.md:json": "a sketch of results.json, with elisions",
    "docs/extending.md:toml": "a package's entry point (tests/test_own_modules.py installs "
                              "one)",
}
#: Pages whose python blocks each run alone, as a reader pastes them: the blocks that name
#: their file (``# mylab/humans.py``) are only written, and the others import them.
ALONE = ("docs/extending.md",)
#: What the pages' own modules register (``--import mylab.agents``), and a name of the same
#: kind the test's parser knows, for the syntax checks run before those modules exist.
REGISTERED_BY_PAGES = {"eager-goalfilter": "goalfilter", "costly-wait": "no-free-toggle"}


# --------------------------------------------------------------------------- running
def _fresh_env() -> dict[str, str]:
    """A shell as a new terminal has it: no virtualenv activated, nothing on PYTHONPATH."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("VIRTUAL_ENV", "PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP")
           and not k.startswith(("PYTEST_", "COV_"))}
    path = [p for p in env.get("PATH", "").split(os.pathsep)
            if p and ".venv" not in Path(p).parts]
    env["PATH"] = os.pathsep.join(path or ["/usr/bin", "/bin"])
    # A worktree that shares another checkout's .venv (whose editable install imports that
    # checkout) selects its own code with PYTHONPATH: the pasted commands run this code.
    if any(p and Path(p).resolve() == ROOT
           for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)):
        env["PYTHONPATH"] = str(ROOT)
    return env


def _workspace(tmp: Path) -> Path:
    """A folder that looks like the checkout (links to its files) where ``out/`` is new."""
    ws = tmp / "checkout"
    ws.mkdir()
    for entry in ROOT.iterdir():
        if entry.name not in (".git", "out") and not (entry.name.startswith(".")
                                                     and entry.name != ".venv"):
            (ws / entry.name).symlink_to(entry)
    return ws


def _status() -> list[str]:
    done = subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=ROOT,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, f"the checkout's git status: {done.stderr}"
    return done.stdout.splitlines()


def _without_made_agents(command: str) -> str:
    """``command`` with the agents that the page's earlier commands make (a module it writes,
    ``mylab.follower:Follower``; a model it trains, ``sb3:out/...zip``) as ``passive``, and
    the names its modules register (:data:`REGISTERED_BY_PAGES`) as built-in ones, so that
    it parses here, before they exist."""
    command = re.sub(r"(?<=[ ,])(mylab\.\w+:\w+|sb3:\S+?\.zip)(?=[ ,]|$)", "passive", command)
    for made, known in REGISTERED_BY_PAGES.items():
        command = re.sub(rf"(?<=[ ,]){re.escape(made)}(?=[ ,]|$)", known, command)
    return command


def _shell_line(command: str, doc: str) -> tuple[str, str]:
    """What runs for ``command`` of page ``doc`` (the shell text) and a note for the log."""
    plan = PLAN[command]
    if (doc, command) in ELSEWHERE:
        plan = Skip(f"the same command runs in {ELSEWHERE[doc, command]}'s test",
                    plan.check if isinstance(plan, Skip) else syntax)
    if plan == RUN:
        return command, "as pasted"
    if isinstance(plan, Scaled):
        syntax(_without_made_agents(command))  # as the page shows it, though a smaller one runs
        return plan.command, f"scaled: {plan.why}"
    if isinstance(plan, Fed):
        return f"printf %s {shlex.quote(plan.stdin)} | {command}", f"fed: {plan.why}"
    assert isinstance(plan, Skip)
    plan.check(command)
    return ":", f"skipped: {plan.why}"


def _run(argv: list[str], ws: Path, what: str, stdin: str | None = None) -> str:
    done = subprocess.run(argv, cwd=ws, env=_fresh_env(), input=stdin, text=True,
                          capture_output=True, timeout=TIMEOUT * 4)
    if done.returncode != 0:
        pytest.fail(f"{what} failed (exit {done.returncode}):\n{done.stdout[-3000:]}\n"
                    f"{done.stderr[-5000:]}", pytrace=False)
    return done.stdout


def run_shell(block: Block, ws: Path) -> str:
    """Run a shell block's commands in order (its plan for each) in one fresh shell."""
    script = ["set -eo pipefail"]
    for command in commands(block.text):
        line, note = _shell_line(command, block.doc)
        script.append(f"printf '%s\\n' {shlex.quote(f'>>> {block.where} {command} ({note})')}")
        script.append(line)
    return _run(["bash", "-c", "\n".join(script)], ws, f"the block at {block.where}")


def python_code(block: Block) -> str:
    """A python block's code as it runs (scaled where :data:`PYTHON_SCALED` says)."""
    code = block.text
    for doc, old, new, _ in PYTHON_SCALED:
        if doc == block.doc and old in code:
            code = code.replace(old, new)
    return code


def run_python(blocks: list[Block], ws: Path, prelude: str = "") -> str:
    """Run consecutive python blocks in one fresh ``.venv/bin/python``; write the blocks
    that name their file there first. On a page of :data:`ALONE`, each block that does not
    name its file runs in a process of its own (the first after ``prelude``)."""
    for block in blocks:
        named = re.match(r"# ([\w/]+\.py)\n", block.text)
        if named:
            (ws / named.group(1)).parent.mkdir(parents=True, exist_ok=True)
            (ws / named.group(1)).write_text(block.text)
    if blocks and blocks[0].doc in ALONE:
        out = []
        for block in blocks:
            if not re.match(r"# ([\w/]+\.py)\n", block.text):
                out.append(_run([".venv/bin/python", "-"], ws, f"the python block at "
                                f"{block.where}", stdin=prelude + python_code(block)))
                prelude = ""
        return "".join(out)
    code = prelude + "".join(python_code(b) for b in blocks)
    where = ", ".join(b.where for b in blocks)
    return _run([".venv/bin/python", "-"], ws, f"the python block(s) at {where}", stdin=code)


def run_page(blocks: list[Block], ws: Path, prelude: str = "") -> str:
    """Run ``blocks`` in their order; consecutive python blocks share a process."""
    out, pending = [], []
    for block in [*blocks, None]:
        if block is not None and block.lang == "python":
            pending.append(block)
            continue
        if pending:
            out.append(run_python(pending, ws, prelude))
            pending, prelude = [], ""
        if block is not None and block.lang in SHELL:
            out.append(run_shell(block, ws))
    return "".join(out)


#: Commands of one README block that read what an earlier one wrote: they run together.
CHAINS: tuple[tuple[str, ...], ...] = (
    (".venv/bin/hri-bench study wheel --agents learner,imitator,maxent,passive,oracle "
     "--runs 100 --preference straight --r0 -0.25 --jobs 2 --out out/wheel",
     ".venv/bin/hri-bench study --config out/wheel/summary.json --out out/again"),
    (".venv/bin/python examples/train_maskable_ppo.py",
     ".venv/bin/hri-bench study hanger --agents "
     "learner,sb3:out/train_maskable_ppo/ppo_hanger.zip --out out/sb3"),
)


def units() -> list[tuple[str, str, tuple[Block, ...]]]:
    """What one test runs (an id, the page, its blocks): a page's blocks together (they
    build on each other); but the README's blocks do not, and each of its commands runs
    alone (with those it reads from, :data:`CHAINS`, and all of a block that uses the
    stand-in dataset together), so that pytest-xdist spreads them over the cores."""
    found = []
    for doc in DOCS:
        blocks = tuple(b for b in read_blocks(doc) if b.lang in (*SHELL, "python"))
        if doc != "README.md":
            if blocks:
                found.append((f"{doc}", doc, blocks))
            continue
        for block in blocks:
            if block.lang == "python" or "hanger-people" in block.text:
                found.append((f"{block.where}", doc, (block,)))
                continue
            done: set[str] = set()
            for command in commands(block.text):
                if command in done:
                    continue
                group = next((c for c in CHAINS if command in c), (command,))
                done.update(group)
                part = Block(doc, block.line, block.lang, "\n".join(group) + "\n")
                words = _words(command)
                name = words[words.index("--out") + 1] if "--out" in words else " ".join(words[:3])
                found.append((f"{block.where}:{name}", doc, (part,)))
    return found


#: Files the pages' blocks name (``# mylab/follower.py``): written there by the test.
NAMED = {m.split("/")[0] for doc in DOCS for b in read_blocks(doc) if b.lang == "python"
         for m in re.findall(r"\A# ([\w/]+\.py)\n", b.text)}


@pytest.fixture
def workspace(tmp_path):
    """A workspace. Afterwards nothing the page ran may have written beside ``out/`` (in a
    checkout, anything else would be among its files: ``model.save("ppo_hanger.zip")``
    was), and the checkout's `git status` must be as before."""
    before = _status()
    ws = _workspace(tmp_path)
    yield ws
    stray = sorted(p.name for p in ws.iterdir()
                   if not p.is_symlink() and p.name not in ("out", *NAMED))
    assert not stray, f"written beside out/ (into the checkout, when pasted there): {stray}"
    new = sorted(set(_status()) - set(before))
    assert not new, f"written into the checkout: {new}"


UNITS = units()


@pytest.mark.parametrize("doc,chosen", [u[1:] for u in UNITS], ids=[u[0] for u in UNITS])
def test_the_page_runs_as_pasted(doc, chosen, workspace):
    if doc in SETUP and _needs_setup(chosen):
        _run(["bash", "-c", "set -e\n" + "\n".join(SETUP[doc])], workspace, f"{doc}'s set-up")
    prelude = ""
    if doc in PRELUDE:
        source, count = PRELUDE[doc]
        snippets = [b for b in read_blocks(source) if b.lang == "python"][:count]
        prelude = "".join(python_code(b) for b in snippets)
    out = run_page(chosen, workspace, prelude)
    if doc == "docs/scenarios.md":
        _check_the_box_numbers(out, (ROOT / doc).read_text())


def _needs_setup(blocks: list[Block]) -> bool:
    """Whether a block uses the stand-in of the people's dataset."""
    return any("hanger-people" in b.text for b in blocks)


def _check_the_box_numbers(out: str, page: str) -> None:
    """docs/scenarios.md quotes the numbers its snippet prints (they were another seed's)."""
    printed = {agent: (first, last) for agent, first, last in
               re.findall(r"^(\w+) \[\s*(-?[\d.]+)\s+(-?[\d.]+)\s*\]$", out, re.M)}
    assert set(printed) == {"learner", "imitator", "passive", "blind"}, out
    text = " ".join(page[page.index("On the box"):].split())

    def quoted(v: str) -> str:
        return f"{float(v):.2f}".replace("-", "−")

    assert f"from {quoted(printed['learner'][0])} per episode to {quoted(printed['learner'][1])}" \
        in text, printed
    for agent in ("blind", "imitator", "passive"):
        assert quoted(printed[agent][1]) in text, (agent, printed)


# --------------------------------------------------------------------------- static checks
def test_every_command_of_the_pages_has_a_plan():
    """A new command in a page must be decided on here: run, scaled, fed or skipped."""
    found = {c for doc in DOCS for b in read_blocks(doc) if b.lang in SHELL
             for c in commands(b.text)}
    missing = sorted(found - set(PLAN))
    assert not missing, f"commands of the pages without a plan in tests/test_docs.py: {missing}"
    stale = sorted(set(PLAN) - found)
    assert not stale, f"plans for commands no page has any more: {stale}"
    for plan in PLAN.values():
        assert plan == RUN or (isinstance(plan, Scaled | Fed | Skip) and plan.why)


def test_every_python_scaling_applies_to_one_block():
    """A :data:`PYTHON_SCALED` entry whose text left its page would silently run the page's
    full-size code."""
    for doc, old, _, why in PYTHON_SCALED:
        found = [b for b in read_blocks(doc) if b.lang == "python" and old in b.text]
        assert len(found) == 1, (doc, old, why)


def test_every_block_is_a_command_code_or_listed():
    kinds = {f"{b.doc}:{b.lang or 'text'}" for doc in DOCS for b in read_blocks(doc)
             if b.lang not in (*SHELL, "python")}
    assert kinds == set(NOT_RUN), kinds ^ set(NOT_RUN)
    for doc in DOCS:
        for b in read_blocks(doc):
            assert b.lang, f"{b.where}: give the block a language (text for a diagram)"


def test_every_shell_line_runs_in_a_fresh_shell():
    """Nothing assumes an activated virtualenv: a command calls .venv/bin/..., make, or sets
    a variable; none carries an option shown in brackets."""
    for doc in DOCS:
        for block in read_blocks(doc):
            if block.lang not in SHELL:
                continue
            for command in commands(block.text):
                words = _words(command)
                while words and re.fullmatch(r"[A-Z_]+=\S*", words[0]):
                    words.pop(0)
                assert words[0] in ("make", "export") or words[0].startswith(".venv/bin/"), (
                    block.where, command)
                assert not re.search(r"\s\[-", command), (block.where, command)


def test_inline_commands_run_from_the_checkout():
    """Commands quoted in the prose: `python ...` and `pip ...` would use whatever Python
    comes first on PATH, and a complete `hri-bench <command> <scenario> ...` is a command to
    paste: all go through .venv/bin. Those with .venv/bin parse."""
    for doc in DOCS:
        text = (ROOT / doc).read_text()
        text = re.sub(r"```.*?```", "", text, flags=re.S)
        for span in re.findall(r"`([^`]+)`", text.replace("\n", " ")):
            span = " ".join(span.split())
            bare = re.sub(r"^([A-Z_]+=\S+ )+", "", span)
            placeholder = re.search(r"[\[{|]|\.\.\.|…|\b[A-Z]{2,}\b", bare)
            assert not re.match(r"(python3?|pip3?) ", bare), (doc, span)
            assert placeholder or not re.match(r"hri-bench \w+ (hanger|wheel)\b", bare), (
                doc, span)
            if bare.startswith(".venv/bin/hri-bench ") and not placeholder:
                # an agent of the reader's own (mylab...) as one of ours; a model it trained
                bare = re.sub(r"mylab\.\w+:\w+", "examples.custom_learner:GoalMemory", bare)
                parses(bare, replace=((",sb3:out/train_maskable_ppo/ppo_hanger.zip", ""),))


def test_the_study_synopsis_names_its_flags():
    """docs/benchmark.md's synopsis of `hri-bench study`: every flag it shows exists, and
    every flag of `study` is shown."""
    synopsis = next(b for b in read_blocks("docs/benchmark.md") if b.lang == "text").text
    parser = build_parser()
    study = next(a for a in parser._actions if a.dest == "command").choices["study"]
    flags = {s for a in study._actions for s in a.option_strings if s.startswith("--")}
    shown = set(re.findall(r"--[a-z][a-z0-9-]*", synopsis))
    assert shown <= flags, shown - flags
    assert flags - {"--help"} <= shown, flags - {"--help"} - shown


# --------------------------------------------------------------------------- the README
#: The README's most lines: what the project is, the two set-up commands, a tour and links;
#: history, timings and long tables live in CHANGELOG.md and docs/ (issue 43: it had grown
#: to 826 lines, the project's history before what to do next).
README_LINES = 400
#: Where the lead regenerates the physical suite's table (README, "Physical benchmark").
PHYSICAL_TABLE = ("<!-- physical-suite:begin -->", "<!-- physical-suite:end -->")


def test_the_readme_starts_with_a_quickstart():
    text = (ROOT / "README.md").read_text()
    assert len(text.rstrip("\n").split("\n")) <= README_LINES
    headings = re.findall(r"^## (.+)$", text, re.M)
    assert headings[:2] == ["Quickstart", "A five-minute tour"], headings
    quick = text[text.index("## Quickstart"):text.index("## A five-minute tour")]
    setup = next(b for b in read_blocks("README.md") if b.lang in SHELL)
    assert commands(setup.text) == ["make demo", "make test"]
    assert setup.text in quick
    # the first place a newcomer needs it says why commands start with .venv/bin/
    assert ".venv/bin/" in quick and "activate" in quick
    assert text.index("Nothing gets activated") < text.index("```bash\n.venv/bin/")
    # no history and no speed notes before what to do next
    assert not re.search(r"\bissues? \d|\bThis change\b|`[0-9a-f]{7}`|\bload average\b", text)
    assert "## Documentation" in text and "[CHANGELOG.md](CHANGELOG.md)" in text
    begin, end = (text.index(m) for m in PHYSICAL_TABLE)
    assert text.index("## Physical benchmark") < begin < end


def test_every_link_of_the_pages_leads_somewhere():
    """The README's content moved into docs/: every relative link of a page (and of the
    changelog) names a file of the checkout."""
    for doc in (*DOCS, "CHANGELOG.md"):
        text = re.sub(r"```.*?```", "", (ROOT / doc).read_text(), flags=re.S)
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            path = target.split("#")[0]
            if not path or re.match(r"[a-z]+:", path):
                continue
            assert ((ROOT / doc).parent / path).exists(), (doc, target)


def test_the_tour_shows_what_the_first_study_prints(tmp_path, capsys):
    """The README's printed table has the columns and the footnote a study prints (the
    footnote once named the regret module where it no longer was)."""
    from hri_bench.cli import main

    shown = next(b for b in read_blocks("README.md") if b.lang == "text").text.splitlines()
    assert main(["study", "wheel", "--agents", "learner,imitator,maxent,passive,oracle",
                 "--runs", "2", "--episodes", "2", "--preference", "straight", "--r0",
                 "-0.25", "--no-progress", "--out", str(tmp_path / "wheel")]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert shown[1] in printed  # the header
    assert shown[-2] in printed  # the regret note
    assert [line.split()[0] for line in shown[2:7]] == \
        [line.split()[0] for line in printed[printed.index(shown[1]) + 1:][:5]]
