"""Scripts measuring speed and comparing checkouts (a package only so that the layer contract
in ``pyproject.toml`` covers them: they sit on top of everything)."""
