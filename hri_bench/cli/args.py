"""Argument types shared by the commands' parsers: a value parsed and checked, with a
message saying what is allowed (exit 2 through argparse).
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import shutil
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from hri_envs.errors import BackendUnavailableError, ConfigError

__all__ = ["as_flags", "bounded", "invocation", "resume_hint", "split_imports", "whole"]


def bounded(kind: type, allowed: str, ok: Callable[[Any], bool]) -> Callable[[str], Any]:
    """An argparse ``type`` parsing ``kind`` and checking it with ``ok``, with a message
    saying what is ``allowed``.
    """

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {allowed}, got {text!r}") from None
        if not ok(value):
            raise argparse.ArgumentTypeError(f"expected {allowed}, got {value}")
        return value

    return parse


#: A whole number >= 0 (a seed, a count that may be 0).
whole = bounded(int, "a whole number >= 0", lambda v: v >= 0)


def as_flags(message: str, flags: Mapping[str, str]) -> str:
    """``message`` (the library's, which names Python parameters as ``human_params=``) with
    each parameter that ``flags`` maps to a command's flag written as that flag
    (``--human-param``); a parameter given with a value (``population='x'``) is left as it is.
    """
    for name, flag in flags.items():
        if flag.startswith("--"):
            message = re.sub(rf"(?<![\w.]){re.escape(name)}=(?![\w'\"(\[{{-])", flag, message)
    return message


def invocation() -> str:
    """How this ``hri-bench`` was started, as the start of a command to paste: the script
    as typed from this folder (``.venv/bin/hri-bench`` in the checkout; the first command a
    newcomer has is that path, the virtualenv not activated), ``hri-bench`` when that name
    on ``PATH`` is this script (an activated virtualenv), or ``python -m hri_bench.cli``
    with this Python.
    """
    script = Path(sys.argv[0]) if sys.argv and sys.argv[0] else None
    if script is not None and script.name == "hri-bench":
        found = shutil.which("hri-bench")
        if found is not None and Path(found).resolve() == script.resolve():
            return "hri-bench"
        return shlex.quote(_from_here(script))
    if script is not None and script.name == "__main__.py" and script.parent.name == "cli":
        return f"{shlex.quote(_from_here(Path(sys.executable)))} -m hri_bench.cli"
    return "hri-bench"  # called from Python (tests, a script of one's own)


def split_imports(argv: Sequence[str]) -> tuple[list[str], list[str]]:
    """``(modules, rest)``: the modules of the ``--import MODULE`` (or ``--import=MODULE``)
    options before the command (what they register must exist before the parser is built:
    its choices and checks read the registries), and the words from the command on.
    """
    modules, words = [], list(argv)
    while words:
        if words[0] == "--import" and len(words) > 1:
            modules.append(words[1])
            words = words[2:]
        elif words[0].startswith("--import="):
            modules.append(words.pop(0).partition("=")[2])
        else:
            break
    return modules, words


def resume_hint(argv: Sequence[str]) -> str:
    """The command that resumes this one (``argv``: its words after the program), as it can
    be pasted (:func:`invocation`).
    """
    words = [w for w in argv if w not in ("--overwrite", "--resume")]
    return f"{invocation()} " + " ".join(shlex.quote(w) for w in words) + " --resume"


def _from_here(path: Path) -> str:
    """``path`` relative to the current folder when it is inside it, else absolute."""
    absolute = Path(os.path.abspath(path))
    try:
        return str(absolute.relative_to(Path.cwd()))
    except ValueError:
        return str(absolute)


def config_error(parser: argparse.ArgumentParser, exc: ConfigError,
                 arguments: dict[str, str]) -> None:
    """Exit with status 2 like argparse does, naming the argument the bad field came from;
    a backend whose extra is missing is reported by :func:`main` in one line (status 1).
    """
    if isinstance(exc, BackendUnavailableError):
        raise exc
    argument = arguments.get(exc.field or "")
    text = as_flags(str(exc), arguments)
    parser.error(f"argument {argument}: {text}" if argument else text)


def cannot_write(exc: OSError, out: Path, argv: Sequence[str], *,
                 kept: str = "the finished units are kept") -> int:
    """Report a file that cannot be written (a full disk, say) in one line; exit status 1."""
    reason = exc.strerror or str(exc)
    print(f"hri-bench: cannot write {exc.filename or out}: {reason}; {kept}; once it can be "
          f"written, continue with: {resume_hint(argv)}", file=sys.stderr)
    return 1
