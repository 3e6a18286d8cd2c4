"""A human family of a user's own, as docs/extending.md, "A human family", writes it."""

from hri_envs.humans.families import Family, register_family
from hri_envs.humans.rational import rational_human
from hri_envs.humans.scripted import preference_human


def sloppy_human(graph, *, noise: float = 2.0, preference: str | None = None):
    """A Boltzmann version of a preference whose rationality is 1 / noise."""
    return rational_human(preference_human(graph, preference), 1.0 / noise)


SLOPPY = register_family(Family("sloppy", "misspecified", sloppy_human,
                                "a preference followed with Boltzmann noise"))
