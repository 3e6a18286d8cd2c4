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
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

from hri_bench.people.serve.browser import chromium, page_state, wait_for
from hri_bench.people.serve.launch import start_serve, stop_serve


def start(scenario: str, data: str, *extra: str) -> tuple[subprocess.Popen[str], str]:
    """``hri-bench serve`` on a free port; (process, url)."""
    proc, url, lines = start_serve([scenario, "--port", "0", "--data", data, *extra],
                                   timeout=300)
    if url is None:
        raise SystemExit(f"serve {scenario} {' '.join(extra)} did not start:\n"
                         + "".join(lines))
    return proc, url


def consent(driver: Any, url: str) -> None:
    driver.get(url)
    wait_for(driver, lambda: page_state(driver).get("view") == "consent")
    driver.find_element("id", "agree").click()
    driver.find_element("id", "start").click()


def graph(driver: Any, url: str, out: Path) -> None:
    """The graph task's first frame, then one step (the robot grasps)."""
    from selenium.webdriver.common.action_chains import ActionChains

    consent(driver, url)
    wait_for(driver, lambda: (d := page_state(driver)).get("drawn") and d["drawn"] == d["seq"])
    seen = page_state(driver)["seq"]
    ActionChains(driver).send_keys("1").perform()  # wait: the robot takes its grasp
    wait_for(driver, lambda: (d := page_state(driver)).get("drawn") and d["drawn"] == d["seq"]
         and d["seq"] != seen)
    time.sleep(1.0)
    driver.save_screenshot(str(out))


def lead(driver: Any, url: str, out: Path, seconds: float) -> None:
    """A physical task: lead the hand up and towards the goal with the keys and a drag."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    consent(driver, url)
    wait_for(driver, lambda: page_state(driver).get("view") == "lead"
         and page_state(driver).get("drawn"))
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
            driver = chromium(f"{tmp}/profile{i}", webgl=True, window=(960, 1180))
            try:
                if "--physical" in extra:
                    lead(driver, url, args.out / name, args.seconds)
                else:
                    graph(driver, url, args.out / name)
                print(args.out / name)
            finally:
                driver.quit()
                stop_serve(proc, 60)


if __name__ == "__main__":
    main()
