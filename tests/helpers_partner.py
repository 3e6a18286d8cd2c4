"""What the tests of the compiled learning math share (the ``path`` fixture: conftest.py)."""

from agents.learning import partner_mdp

#: The compiled kernels are importable in this process.
HAS_JIT = partner_mdp.kernels() is not None
