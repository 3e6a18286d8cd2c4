"""Record the Learner's model after each update on real traces, for tests/test_learner_reference.py.

The reference file ``learner_reference.npz`` was written by the Learner as it was before the
update was restructured for speed (commit ef0eadf); the test replays the recorded traces
into today's Learner and asks for the same θ, π̂_H, Q_R and π_R to 1e-9. Re-running this
script overwrites the reference with the *current* code's numbers, so only do that on
purpose.

Usage::

    python tests/data/make_learner_reference.py [OUT.npz]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from agents.learner import Learner
from hri_bench.run.runner import make_schedule, simulate
from hri_bench.run.study import graph_for
from hri_envs.humans.scripted import preference_human

#: (scenario, preference, human passivity, runs, episodes, step limit): small, but every
#: branch of the update (loops removed, truncated episodes with intention -1, several
#: intentions) occurs.
CASES = (
    ("wheel", "straight", 0.0, 3, 4, 100),
    ("wheel", "detour", 0.4, 3, 4, 12),
    ("hanger", "down-over-rotate/over-rotate-up", 0.2, 3, 4, 100),
)
#: The model arrays recorded (π_R is the soft-max of Q_R, so it is not stored).
ARRAYS = ("theta", "pi_h", "q_r")


def record(scenario: str, preference: str, passive: float, n_runs: int, episodes: int,
           max_steps: int) -> dict[str, np.ndarray]:
    """Simulate the Learner against a scripted human; return its traces and models.

    Returns:
        ``states`` (E, B, max_steps + 1) padded with -1, ``intentions`` (E, B), and per
        array name of :data:`ARRAYS` the model after every update, (E, B, ...).
    """
    graph = graph_for(scenario)
    human = preference_human(graph, preference, passive=passive)
    runs = list(range(n_runs))
    schedule = make_schedule(graph, "random", runs, episodes, 3, human)
    agent = Learner(graph, n_runs, seed=3)
    states = np.full((episodes, n_runs, max_steps + 1), -1, dtype=np.int64)
    intentions = np.zeros((episodes, n_runs), dtype=np.int64)
    models: dict[str, list[np.ndarray]] = {k: [] for k in ARRAYS}
    end_episode = agent.end_episode

    def spy(traces, ints):  # type: ignore[no-untyped-def]
        e = agent.episodes
        for b, tr in enumerate(traces):
            states[e, b, : len(tr.states)] = tr.states
        intentions[e] = ints
        end_episode(traces, ints)
        for k in ARRAYS:
            models[k].append(getattr(agent, k).copy())

    agent.end_episode = spy  # type: ignore[method-assign]
    simulate(graph, agent, human, schedule, runs=runs, seed=3, r0=agent.config.r0,
             max_steps=max_steps)
    return {"states": states, "intentions": intentions,
            **{k: np.stack(v) for k, v in models.items()}}


def main(out: Path) -> None:
    """Write every case into one ``.npz`` (keys ``"{i}/{name}"``)."""
    data: dict[str, np.ndarray] = {}
    for i, case in enumerate(CASES):
        for k, v in record(*case).items():
            data[f"{i}/{k}"] = v
    np.savez_compressed(out, **data)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name(
        "learner_reference.npz"))
