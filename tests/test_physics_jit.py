"""The compiled kernels' cache follows every source they are compiled from."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytest.importorskip("numba")

from hri_envs.physics.scene import jit  # noqa: E402

PHYSICS = Path(jit.__file__).parents[1]  # hri_envs/physics: SOURCES are relative to it


def test_every_module_with_kernels_names_the_cache() -> None:
    """A module compiled with jit.kernel (or calling MuJoCo from compiled code) that is not
    in jit.SOURCES would keep its old compiled code in the cache after an edit."""
    compiled = {p.relative_to(PHYSICS).as_posix() for p in PHYSICS.rglob("*.py")
                if re.search(r"^@kernel$|types\.ExternalFunction", p.read_text(), re.M)}
    assert compiled, "no compiled modules found"
    assert compiled <= set(jit.SOURCES), compiled - set(jit.SOURCES)


def test_the_cache_is_named_by_the_sources(tmp_path: Path, monkeypatch) -> None:
    """Another version of a source is another cache directory."""
    here = jit.cache_dir()
    copy = tmp_path / "physics"
    copy.mkdir()
    for name in jit.SOURCES:
        (copy / name).parent.mkdir(parents=True, exist_ok=True)
        (copy / name).write_text((PHYSICS / name).read_text())
    monkeypatch.setattr(jit, "__file__", str(copy / "scene" / "jit.py"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    same = jit.cache_dir()
    assert Path(same).name == Path(here).name
    (copy / "scene/laws.py").write_text((PHYSICS / "scene/laws.py").read_text() + "\n# edited\n")
    assert Path(jit.cache_dir()).name != Path(here).name
