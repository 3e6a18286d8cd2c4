"""Validated parameters of the Learner and the plain ME-IRL baseline."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from hri_envs.checks import check_flag, check_real, check_whole
from hri_envs.errors import ConfigError
from hri_envs.task.scenarios import SCENARIOS, ScenarioSpec, as_spec

__all__ = ["MAX_PRETRAIN_PASSES", "LearnerConfig", "default_config"]

#: The most ME-IRL passes over the initial preference's demonstrations (each pass is one
#: update per (start, goal) pair, before the first episode).
MAX_PRETRAIN_PASSES = 1000


@dataclass(frozen=True)
class LearnerConfig:
    """Parameters of Algorithm 1 (paper Sect. 5 values as defaults, see :func:`default_config`).

    Every number must be a finite ``int`` or ``float`` (numpy scalars too; not ``bool``, not a
    string), in the range given below; a :class:`~hri_envs.errors.ConfigError` naming the
    field says what is allowed otherwise.

    Attributes:
        learning_rate: λ, the ME-IRL step size, > 0.
        robot_temperature: τ_R of the robot's soft-max, > 0.
        eta: η, the robot's relative probability bound, in [0, 1].
        human_temperature: τ_H of the human policy estimate, > 0.
        beta: Intention bias β of the Bayes filter, in (0, 1] (meaningful from 1/n).
        gamma: Discount of every Q-iteration (0.9 hanger, 0.6 wheel).
        r0: Robot reward for waiting while the human acts, in (-1, 0).
        irl_temperature: Demonstrator temperature inside the ME-IRL expectation. The paper
            is silent; its published code uses 1 (a near-uniform demonstrator given
            |θ| ≤ 1), which we keep as the default; > 0.
        robot_model_temperature: Temperature of the robot policy the human model assumes
            (T_H), > 0; the paper's code uses the robot's own τ_R.
        passive_prior: Keep the passive baseline's action in the bounded soft-max (the
            paper's only prior, Sect. 7); False: the bound is ``η · max_a p(a)`` alone (the
            paper's "without it" variant).
        initial_preference: Start from another preference (paper Sect. 7): before the first
            episode the human model makes :attr:`pretrain_passes` ME-IRL passes over the
            named preference's demonstrated routes, one per (start, goal) pair; None: θ⁰.
        pretrain_passes: Passes over those demonstrations, a whole number in
            [1, :data:`MAX_PRETRAIN_PASSES`].
    """

    learning_rate: float = 0.1
    robot_temperature: float = 5.0
    eta: float = 0.9
    human_temperature: float = 25.0
    beta: float = 0.95
    gamma: float = SCENARIOS["hanger"].gamma  # the class defaults are the hanger's
    r0: float = SCENARIOS["hanger"].r0
    irl_temperature: float = 1.0
    robot_model_temperature: float = 5.0
    passive_prior: bool = True
    initial_preference: str | None = None
    pretrain_passes: int = 3

    def __post_init__(self) -> None:
        positive = {"low": 0.0, "low_open": True}
        for name, bounds in (
            ("learning_rate", positive),
            ("robot_temperature", positive),
            ("eta", {"low": 0.0, "high": 1.0}),
            ("human_temperature", positive),
            ("beta", {"low": 0.0, "high": 1.0, "low_open": True}),
            ("gamma", {"low": 0.0, "high": 1.0, "high_open": True}),
            ("r0", {"low": -1.0, "high": 0.0, "low_open": True, "high_open": True}),
            ("irl_temperature", positive),
            ("robot_model_temperature", positive),
        ):
            check_real(getattr(self, name), name, **bounds)  # type: ignore[arg-type]
        check_flag(self.passive_prior, "passive_prior")
        if self.initial_preference is not None and not isinstance(self.initial_preference, str):
            raise ConfigError(f"initial_preference must be None or a preference's name, got "
                              f"{self.initial_preference!r}", field="initial_preference")
        check_whole(self.pretrain_passes, "pretrain_passes", minimum=1,
                    maximum=MAX_PRETRAIN_PASSES)

    def replace(self, **changes: Any) -> LearnerConfig:
        """A copy with some fields changed (validated)."""
        names = {f.name for f in dataclasses.fields(self)}
        unknown = set(changes) - names
        if unknown:
            raise ConfigError(f"unknown parameter(s) {sorted(unknown)}; allowed: {sorted(names)}",
                              field=sorted(unknown)[0])
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, float | bool | str | None]:
        """Plain dict, for JSON."""
        return dataclasses.asdict(self)


def default_config(scenario: ScenarioSpec | str, **changes: Any) -> LearnerConfig:
    """The paper's parameters for a scenario (γ and r0 from its
    :class:`~hri_envs.task.scenarios.ScenarioSpec`: hanger γ = 0.9, r0 = -0.33; wheel
    γ = 0.6, r0 = -0.25), with optional changes.

    Args:
        scenario: The scenario; a registered one's name where a user names it (the
            library passes the spec it resolved).
        changes: :class:`LearnerConfig` fields to change.

    Raises:
        ConfigError: An unknown scenario name, or a change that is not allowed.
    """
    spec = as_spec(scenario)
    pref = changes.get("initial_preference")
    if pref is not None and pref not in spec.preferences:
        raise ConfigError(f"initial_preference must be None or one of the {spec.name} "
                          f"preferences ({', '.join(spec.preferences[:3])}, ...), got {pref!r}",
                          field="initial_preference")
    return LearnerConfig(gamma=spec.gamma, r0=spec.r0).replace(**changes)
