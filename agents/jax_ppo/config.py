"""The JAX PPO learner's training config and the env it trains in.

:class:`TrainConfig` (what to train, on what, how long: JSON-ready, stored in the
checkpoint, and ``benchmarks/train_jax_ppo.py``'s flags), the checks of its values,
:func:`training_population` (the population it names) and :func:`make_env` (the
:class:`~hri_envs.jax.JaxRobotEnv` trials of one human each). :mod:`agents.jax_ppo.train`
trains with them and re-exports them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass
from typing import Any

from hri_envs.checks import check_real, check_whole
from hri_envs.errors import ConfigError
from hri_envs.humans.populations import PopulationSpec
from hri_envs.humans.splits import MixtureSpec, population
from hri_envs.jax.env import JaxRobotEnv
from hri_envs.task.scenarios import NamedScenario

__all__ = ["MAX_TRIAL", "TrainConfig", "make_env", "training_population"]


#: The most episodes of one trial (the update keeps a sum per episode index of a trial).
MAX_TRIAL = 10_000


@dataclass(frozen=True)
class TrainConfig(NamedScenario):
    """What to train, on what, how long (JSON-ready; stored in the checkpoint).

    The attributes' descriptions are ``benchmarks/train_jax_ppo.py --help``'s help texts
    (tyro prints them as written: plain text, no markup). :meth:`check` refuses bad values.

    Attributes:
        scenario: The scenario: "hanger" or "wheel".
        population: The training population: the frozen "train" split (40 scripted
            preference humans, deterministic, passive or Boltzmann; see
            hri_envs.humans.splits), "validation", or a scripted population the JAX env
            holds (hanger-all, preferences, mixed-rationality, passive-turnback). The
            held-out population and the evaluation splits are refused.
        passive: LOW HIGH: the passive rate drawn per human, in [0, 1] with LOW <= HIGH;
            replaces a scripted population's range (None: the population's; not for a
            split).
        turn_back: LOW HIGH: the turning-back rate drawn per human, likewise.
        episodes_per_trial: Episodes with one human, at least 1 (None: the scenario's
            study length, hanger 8, wheel 20).
        reward: The reward rule, a name of hri_envs.task.episode.REWARD_RULES ("paper", ...).
        r0: The robot's waiting reward, in (-1, 0) (None: the scenario's).
        max_cycles: Step limit per episode.
        total_steps: Env steps to train for (rounded up to whole chunks of updates).
        num_envs: Envs stepped together.
        rollout: Steps per env between updates.
        epochs: Passes over a rollout.
        minibatches: Minibatches per pass (split along the envs; must divide num-envs).
        lr: Adam's learning rate, > 0 (annealed linearly to 0).
        gamma: Discount per step, over the whole trial, in (0, 1].
        gae_lambda: GAE's lambda, in (0, 1].
        clip: PPO's ratio clip, in (0, 1].
        ent_coef: Weight of the entropy bonus, a finite number >= 0.
        vf_coef: Weight of the value loss, a finite number >= 0.
        max_grad_norm: Gradient clip (global norm), in (0, 1].
        reward_scale: Rewards are multiplied by it, in (0, 1], for the value function and
            GAE: a trial's return is tens of rewards; unscaled, the value loss's gradient
            would dominate the clipped global norm and starve the policy's.
        hidden: GRU width.
        seed: Every draw (initial weights, envs, sampling) derives from it.
        chunk: Updates per compiled call (progress is logged between calls).
    """

    scenario: str = "hanger"
    population: str = "train"
    passive: tuple[float, float] | None = None
    turn_back: tuple[float, float] | None = None
    episodes_per_trial: int | None = None
    reward: str = "paper"
    r0: float | None = None
    max_cycles: int = 100
    total_steps: int = 20_000_000
    num_envs: int = 1024
    rollout: int = 32
    epochs: int = 2
    minibatches: int = 2
    lr: float = 2e-3
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip: float = 0.2
    ent_coef: float = 0.01
    vf_coef: float = 0.5
    max_grad_norm: float = 1.0
    reward_scale: float = 0.05
    hidden: int = 32
    seed: int = 0
    chunk: int = 10

    @property
    def steps_per_update(self) -> int:
        """num_envs × rollout."""
        return self.num_envs * self.rollout

    @property
    def updates(self) -> int:
        """Updates to reach ``total_steps`` (whole chunks)."""
        n = math.ceil(self.total_steps / self.steps_per_update)
        return math.ceil(n / self.chunk) * self.chunk

    def trial_length(self) -> int:
        """Episodes per trial (the scenario's study length by default)."""
        return self.episodes_per_trial or self.spec.episodes

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return asdict(self)

    def check(self) -> TrainConfig:
        """Raise a :class:`ConfigError` naming the field of a bad value; return self.

        Every number is checked for its type and range (NaN and infinity are refused, so
        a bad coefficient cannot train NaN weights); a rate range must be ``(low, high)``
        in [0, 1] with ``low <= high``. The names (scenario, population, reward) are
        checked by :func:`make_env`.
        """
        for name in ("total_steps", "num_envs", "rollout", "epochs", "minibatches", "hidden",
                     "chunk", "max_cycles"):
            check_whole(getattr(self, name), name, minimum=1)
        if self.num_envs % self.minibatches:
            raise ConfigError(f"minibatches ({self.minibatches}) must divide num_envs "
                              f"({self.num_envs})", field="minibatches")
        for name in ("gamma", "gae_lambda", "clip", "max_grad_norm", "reward_scale"):
            check_real(getattr(self, name), name, low=0.0, high=1.0, low_open=True)
        check_real(self.lr, "lr", low=0.0, high=1e3, low_open=True)
        for name in ("ent_coef", "vf_coef"):
            check_real(getattr(self, name), name, low=0.0)
        for name in ("passive", "turn_back"):
            _check_range(getattr(self, name), name)
        if self.episodes_per_trial is not None:
            check_whole(self.episodes_per_trial, "episodes_per_trial", minimum=1,
                        maximum=MAX_TRIAL,
                        allowed=f"a whole number in 1..{MAX_TRIAL:,} or None (the "
                                "scenario's study length)")
        if self.r0 is not None:
            check_real(self.r0, "r0", low=-1.0, high=0.0, low_open=True, high_open=True,
                       allowed="a number in the open interval (-1, 0), or None (the "
                               "scenario's)")
        check_whole(self.seed, "seed", minimum=0)
        return self


def _check_range(value: Any, name: str) -> None:
    """None, or ``(low, high)`` rates in [0, 1] with ``low <= high``."""
    if value is None:
        return
    if not isinstance(value, tuple | list) or len(value) != 2:
        raise ConfigError(f"{name} must be a pair (low, high) of rates in [0, 1], or None, "
                          f"got {value!r}", field=name)
    low, high = (check_real(v, name, low=0.0, high=1.0, label=f"{name} {which}")
                 for v, which in zip(value, ("low", "high"), strict=True))
    if low > high:
        raise ConfigError(f"{name} must be (low, high) with low <= high, got ({low:g}, "
                          f"{high:g})", field=name)


def training_population(cfg: TrainConfig) -> PopulationSpec | MixtureSpec:
    """The population trained on: the named split, or scripted population with the config's
    rate ranges.

    Raises:
        ConfigError: An evaluation split or held-out population (``field="population"``),
            or rate ranges given for a split (``field="passive"``/``"turn_back"``).
    """
    spec = population(cfg.population, cfg.graph)
    if isinstance(spec, MixtureSpec):
        if cfg.population not in ("train", "validation"):
            raise ConfigError(f"population {cfg.population!r} is for evaluation (or not a "
                              "scripted population); train on 'train'", field="population")
        for name in ("passive", "turn_back"):
            if getattr(cfg, name) is not None:
                raise ConfigError(f"{name} ranges change a scripted population's draw; the "
                                  f"split {cfg.population!r} is a frozen list of humans",
                                  field=name)
        return spec
    if spec.held_out:
        raise ConfigError(f"population {cfg.population!r} is held out for evaluation; "
                          "train on 'train'", field="population")
    changes: dict[str, Any] = {}
    if cfg.passive is not None:
        changes["passive"] = tuple(float(x) for x in cfg.passive)
    if cfg.turn_back is not None:
        changes["turn_back"] = tuple(float(x) for x in cfg.turn_back)
    return dataclasses.replace(spec, **changes) if changes else spec


def make_env(cfg: TrainConfig) -> JaxRobotEnv:
    """The training env: trials of ``trial_length()`` episodes per human of the population."""
    return JaxRobotEnv(cfg.scenario, population=training_population(cfg),
                       episodes_per_human=cfg.trial_length(), reward=cfg.reward, r0=cfg.r0,
                       max_cycles=cfg.max_cycles)
