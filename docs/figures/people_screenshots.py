"""The screenshots of docs/people.md: the page of ``hri-bench serve`` in a real browser.

Starts ``hri-bench serve`` (graph hanger and wheel; the physical hanger and wheel with
``--physical --show-belief``) on free ports of 127.0.0.1 with temporary datasets, opens
each page in Debian's headless chromium (Selenium, chromium-driver), consents, and for the
physical tasks leads the hand as a person would with the keys and a mouse drag for a few
seconds; then saves the browser's screenshot:

    .venv/bin/python docs/figures/people_screenshots.py [--agent NAME] [--out docs/figures]

Needs the ``web`` extra, ``make web`` (three.js) and chromium with chromium-driver.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

CHROMIUM, DRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"


def start(scenario: str, data: str, *extra: str) -> tuple[subprocess.Popen[str], str]:
    """``hri-bench serve`` on a free port; (process, url)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "hri_bench.cli", "serve", scenario, "--port", "0", "--data",
         data, *extra], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert proc.stdout is not None
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        found = re.search(r"serving on (http://127\.0\.0\.1:\d+/)", line)
        if found:
            return proc, found.group(1)
        if not line:
            break
    proc.kill()
    raise SystemExit(f"serve {scenario} {' '.join(extra)} did not start")


def browser(profile: str) -> Any:
    """Headless chromium (WebGL through SwiftShader, in software)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ("--headless", "--no-sandbox", "--disable-dev-shm-usage",
                 "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
                 "--window-size=960,1180", f"--user-data-dir={profile}"):
        options.add_argument(flag)
    return webdriver.Chrome(service=Service(DRIVER), options=options)


def dataset(driver: Any) -> dict[str, str]:
    return driver.execute_script("return Object.assign({}, document.body.dataset);")


def wait(driver: Any, condition: Any, timeout: float = 120.0) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.05)
    raise SystemExit(f"timed out; the page shows {dataset(driver)}")


def consent(driver: Any, url: str) -> None:
    driver.get(url)
    wait(driver, lambda: dataset(driver).get("view") == "consent")
    driver.find_element("id", "agree").click()
    driver.find_element("id", "start").click()


def graph(driver: Any, url: str, out: Path) -> None:
    """The graph task's first frame, then one step (the robot grasps)."""
    from selenium.webdriver.common.action_chains import ActionChains

    consent(driver, url)
    wait(driver, lambda: (d := dataset(driver)).get("drawn") and d["drawn"] == d["seq"])
    seen = dataset(driver)["seq"]
    ActionChains(driver).send_keys("1").perform()  # wait: the robot takes its grasp
    wait(driver, lambda: (d := dataset(driver)).get("drawn") and d["drawn"] == d["seq"]
         and d["seq"] != seen)
    time.sleep(1.0)
    driver.save_screenshot(str(out))


def lead(driver: Any, url: str, out: Path, seconds: float) -> None:
    """A physical task: lead the hand up and towards the goal with the keys and a drag."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    consent(driver, url)
    wait(driver, lambda: dataset(driver).get("view") == "lead"
         and dataset(driver).get("drawn"))
    canvas = driver.find_element("id", "canvas")
    ActionChains(driver).key_down(Keys.ARROW_UP).pause(0.8).key_up(Keys.ARROW_UP).perform()
    ActionChains(driver).move_to_element(canvas).click_and_hold().pause(0.2) \
        .move_by_offset(-40, -10).pause(0.3).move_by_offset(-40, 0).pause(0.3).release() \
        .perform()
    ActionChains(driver).key_down(Keys.ARROW_LEFT).perform()  # still leading: the shot
    time.sleep(seconds)
    driver.save_screenshot(str(out))
    ActionChains(driver).key_up(Keys.ARROW_LEFT).perform()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).parent)
    parser.add_argument("--agent", default=None, help="the physical robot (default serve's)")
    parser.add_argument("--seconds", type=float, default=1.2,
                        help="leading left before the shot (default 1.2 s)")
    args = parser.parse_args()
    robot = ("--agent", args.agent) if args.agent else ()
    jobs = [("hanger", (), "people_graph_hanger.png"), ("wheel", (), "people_graph_wheel.png"),
            ("hanger", ("--physical", "--show-belief", *robot), "people_lead_hanger.png"),
            ("wheel", ("--physical", "--show-belief", *robot), "people_lead_wheel.png")]
    with tempfile.TemporaryDirectory() as tmp:
        for i, (scenario, extra, name) in enumerate(jobs):
            proc, url = start(scenario, f"{tmp}/data{i}", *extra)
            driver = browser(f"{tmp}/profile{i}")
            try:
                if "--physical" in extra:
                    lead(driver, url, args.out / name, args.seconds)
                else:
                    graph(driver, url, args.out / name)
                print(args.out / name)
            finally:
                driver.quit()
                proc.send_signal(signal.SIGINT)
                proc.wait(60)


if __name__ == "__main__":
    main()
