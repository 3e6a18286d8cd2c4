"""Runnable scripts a new user copies from (a package only so that the layer contract in
``pyproject.toml`` covers them: they sit on top of everything)."""
