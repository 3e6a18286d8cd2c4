"""Who may call the server: the ``Host`` it answers to, the ``Origin`` of a page that may
join, and the page's token.

A web page the lab machine's browser visits must not reach the server (and fill its
sessions): every browser request of such a page carries its own ``Origin``, and a page
that tries DNS rebinding (its own name resolving to this machine) carries its own name in
``Host``. So:

* **Host**: every request must name this server as the address it listens on, with its
  port: for the loopback (the default) ``127.0.0.1:PORT``, ``localhost:PORT`` or
  ``[::1]:PORT``; for a wildcard address (``0.0.0.0``, ``::``) those and any IP address
  (a rebinding request always carries a name, never an address); for another address,
  that address. Names the operator gives (``--allow-host NAME[:PORT]``, say the machine's
  name or a TLS proxy's) are allowed as well; a name without a port is allowed on the
  server's port and without a port (the default port of a proxy).
* **Origin**: joining (``POST /api/sessions``) needs an ``Origin`` (browsers always send
  one with a POST) that is the request's own ``Host`` (the page came from this server) or
  a name the operator gave; a websocket's ``Origin``, when it has one, likewise.
* **Token**: each server makes a random token that only its page carries (in a ``<meta>``
  element); joining needs it in the ``X-HRI-Bench-Token`` header. A cross-site request
  cannot send that header without a CORS preflight, which the server never grants.
"""

from __future__ import annotations

import ipaddress
import re
import secrets
from collections.abc import Sequence
from urllib.parse import urlsplit

__all__ = ["TOKEN_HEADER", "Access", "check_host_name", "split_host"]

#: The header that carries the page's token.
TOKEN_HEADER = "x-hri-bench-token"
#: The host part of ``Host`` or an operator's name: a DNS name, an IPv4 address or an IPv6
#: address in brackets, then an optional port.
_HOST_RE = re.compile(r"^(\[[0-9a-f:.]+\]|[a-z0-9]([a-z0-9.-]{0,251}[a-z0-9])?)(:[0-9]{1,5})?$")
_LOOPBACK = ("localhost", "127.0.0.1", "::1")
_WILDCARD = ("0.0.0.0", "::", "")


def _address(name: str) -> str | None:
    """``name`` as a normalised IP address, or None when it is a name."""
    try:
        return str(ipaddress.ip_address(name))
    except ValueError:
        return None


def split_host(text: str | None) -> tuple[str, int | None] | None:
    """``Host``'s (name, port): the name lower-cased, an address normalised (IPv6 without
    its brackets), the port None when not given; None when it is no host.
    """
    if not isinstance(text, str):
        return None
    text = text.strip().lower()
    found = _HOST_RE.match(text)
    if found is None:
        return None
    name, port = found.group(1), found.group(3)
    if name.startswith("["):
        name = _address(name[1:-1]) or ""
        if not name or ":" not in name:
            return None
    number = None if port is None else int(port[1:])
    if number is not None and not 0 < number < 65536:
        return None
    return _address(name) or name, number


def check_host_name(text: str) -> str:
    """An operator's ``--allow-host`` value, lower-cased; ValueError when it is no host."""
    if split_host(text) is None:
        raise ValueError(f"expected a host name or address, optionally with ':PORT' "
                         f"(IPv6 in brackets), got {text!r}")
    return text.strip().lower()


class Access:
    """The hosts a server answers to, and its page's token.

    Args:
        bind: The address the server listens on (``--host``).
        port: The port it listens on (the actual one, after binding port 0).
        named: Names the operator allows (``--allow-host``).
    """

    def __init__(self, bind: str, port: int, named: Sequence[str] = ()) -> None:
        self.port = int(port)
        self.token = secrets.token_urlsafe(32)
        bound = split_host(bind if ":" not in bind else f"[{bind}]")
        bound_name = bind.lower() if bound is None else bound[0]
        self.any_address = bind in _WILDCARD
        loopback = bind in _LOOPBACK or bind.startswith("127.") or self.any_address
        self._names = {bound_name, *(_LOOPBACK if loopback else ())} - {"0.0.0.0", "::"}
        self._named: set[tuple[str, int | None]] = set()  # (name, port or None: any of two)
        for entry in named:
            parsed = split_host(entry)
            if parsed is not None:
                self._named.add(parsed)

    def allowed(self) -> list[str]:
        """The hosts it answers to, for messages."""
        out = [f"[{n}]:{self.port}" if ":" in n else f"{n}:{self.port}"
               for n in sorted(self._names)]
        if self.any_address:
            out.append(f"any IP address:{self.port}")
        out += [n if p is None else f"{n}:{p}" for n, p in sorted(self._named, key=str)]
        return out

    def _is_named(self, name: str, port: int | None) -> bool:
        return (name, port) in self._named or (
            (name, None) in self._named and port in (None, self.port))

    def host_ok(self, host: str | None) -> bool:
        """Whether ``Host`` names this server (see the module docstring)."""
        parsed = split_host(host)
        if parsed is None:
            return False
        name, port = parsed
        if self._is_named(name, port):
            return True
        if (port if port is not None else 80) != self.port:
            return False
        return name in self._names or (self.any_address and _address(name) is not None)

    def origin_ok(self, origin: str | None, host: str | None, *, required: bool) -> bool:
        """Whether a request with this ``Origin`` (None: it sent none, allowed unless
        ``required``) and ``Host`` comes from this server's own page.
        """
        if origin is None:
            return not required
        try:
            parts = urlsplit(origin)
        except ValueError:
            return False
        if parts.scheme not in ("http", "https") or parts.path or parts.query:
            return False
        theirs, ours = split_host(parts.netloc), split_host(host)
        if theirs is None:
            return False
        default = 443 if parts.scheme == "https" else 80  # Host has no scheme: the same
        if ours is not None and (theirs[0], theirs[1] or default) == (ours[0],
                                                                       ours[1] or default):
            return True
        return self._is_named(*theirs)

    def token_ok(self, value: str | None) -> bool:
        """Whether ``value`` is the page's token (compared in constant time)."""
        return isinstance(value, str) and secrets.compare_digest(value.encode(),
                                                                 self.token.encode())
