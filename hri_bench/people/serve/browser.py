"""Debian's headless chromium driving the page of ``hri-bench serve`` through Selenium and
chromium-driver, for the browser tests and the docs' screenshots (the ``web`` extra's
selenium; ``make test`` installs chromium and chromium-driver).

    driver = chromium(profile_dir, webgl=True)
    driver.get(url)
    wait_for(driver, lambda: page_state(driver).get("view") == "consent")
"""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Callable
from typing import Any, TypeVar

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
DRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
T = TypeVar("T")

# a browser of its own: no network of its own, nothing shared with another profile
_FLAGS = ("--headless", "--no-sandbox", "--disable-quic", "--no-first-run",
          "--disable-background-networking", "--disable-component-update", "--disable-sync",
          "--disable-dev-shm-usage")


def have_chromium() -> bool:
    """Whether chromium and chromium-driver are installed (selenium aside)."""
    return os.path.exists(CHROMIUM) and os.path.exists(DRIVER)


def chromium(profile: str | os.PathLike[str], *, webgl: bool,
             window: tuple[int, int] = (900, 1000)) -> Any:
    """Headless chromium with its own profile folder.

    Args:
        profile: the profile's folder (made if missing).
        webgl: WebGL in software (SwiftShader), for the 3D views; else no GPU at all.
        window: the window's width and height in pixels.
    """
    from selenium import webdriver  # noqa: PLC0415 (the web extra)
    from selenium.webdriver.chrome.service import Service  # noqa: PLC0415

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    gpu = (("--enable-unsafe-swiftshader", "--use-angle=swiftshader") if webgl
           else ("--disable-gpu",))
    for flag in (*_FLAGS, *gpu, f"--user-data-dir={profile}",
                 f"--window-size={window[0]},{window[1]}"):
        options.add_argument(flag)
    return webdriver.Chrome(service=Service(DRIVER), options=options)


def page_state(driver: Any) -> dict[str, str]:
    """The page's state: its body's data attributes (``view``, ``seq``, ``drawn``, ...)."""
    return dict(driver.execute_script("return Object.assign({}, document.body.dataset);"))


def wait_for(driver: Any, condition: Callable[[], T], timeout: float = 120.0,
             poll: float = 0.02) -> T:
    """Poll ``condition`` until it is true; its value.

    Raises:
        AssertionError: after ``timeout`` seconds, with the page's state and text.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(poll)
    raise AssertionError(f"timed out; the page's state {page_state(driver)}; it shows "
                         f"{driver.find_element('tag name', 'body').text}")
