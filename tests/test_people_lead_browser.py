"""A person leads the simulated arm in a real browser: ``hri-bench serve --physical`` as a
process, Debian's headless chromium (WebGL in software) driven by Selenium through
chromium-driver, holding the keys and dragging the mouse a person would. The recorded
physical dataset is then checked against the env's own replay of the same inputs (the
hand targets and stiffness the page sent, through the same env and robot). Skipped where
chromium, chromium-driver, the ``web`` extra or the page's three.js (``make web``) are
missing (``make test`` installs them)."""

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("fastapi")
webdriver = pytest.importorskip("selenium.webdriver")

from hri_bench.data.datasets import export_minari, open_dataset  # noqa: E402
from hri_bench.data.physical_replay import replay_physical  # noqa: E402

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
DRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
THREE = (Path(__file__).parents[1] / "hri_bench" / "people" / "serve" / "static" / "vendor"
         / "three.module.js")
pytestmark = [
    pytest.mark.skipif(not (os.path.exists(CHROMIUM) and os.path.exists(DRIVER)),
                       reason="needs Debian's chromium and chromium-driver (make test "
                              "installs them)"),
    pytest.mark.skipif(not THREE.exists(), reason="needs the page's three.js (make web)"),
    pytest.mark.xdist_group("people-browser"),
]
MAX_TIME_S = 6.0  # one short episode: 150 steps at 25 Hz


@pytest.fixture
def server(tmp_path):
    """``hri-bench serve hanger --physical`` on a free port of 127.0.0.1; (url, data)."""
    data = tmp_path / "data"
    proc = subprocess.Popen(
        [sys.executable, "-m", "hri_bench.cli", "serve", "hanger", "--physical", "--port", "0",
         "--data", str(data), "--episodes", "1", "--max-time", str(MAX_TIME_S),
         "--agent", "admittance"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert proc.stdout is not None
    url, lines = None, []
    deadline = time.monotonic() + 120
    while url is None and time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line)
        found = re.search(r"serving on (http://127\.0\.0\.1:\d+/)", line)
        url = found.group(1) if found else None
    assert url, "".join(lines)
    yield url, data
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(30)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


@pytest.fixture
def browser(tmp_path):
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ("--headless", "--no-sandbox", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--disable-dev-shm-usage", "--enable-unsafe-swiftshader",
                 "--use-angle=swiftshader", f"--user-data-dir={tmp_path / 'profile'}",
                 "--window-size=640,760"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(DRIVER), options=options)
    yield driver
    driver.quit()


def _page(driver):
    return driver.execute_script("return Object.assign({}, document.body.dataset);")


def _wait(driver, condition, timeout=120.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.02)
    raise AssertionError(f"timed out; the page's state {_page(driver)}; it shows "
                         f"{driver.find_element('tag name', 'body').text}")


def _frames(driver, n):
    """Wait until the page has drawn ``n`` more frames (each answered by one step)."""
    start = int(_page(driver)["drawn"])
    _wait(driver, lambda: int(_page(driver).get("drawn", start)) >= start + n)


def test_a_person_leads_the_arm_and_the_recording_replays(server, browser, monkeypatch):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    url, data = server
    browser.get(url)
    _wait(browser, lambda: _page(browser).get("view") == "consent")
    browser.find_element("id", "agree").click()
    browser.find_element("id", "start").click()
    _wait(browser, lambda: (p := _page(browser)).get("view") == "lead" and p.get("drawn"))
    # the person lifts the target with the up arrow, then drags it sideways with the mouse;
    # each input lasts frames of the page, not seconds (a loaded machine steps slowly)
    ActionChains(browser).key_down(Keys.ARROW_UP).perform()
    _frames(browser, 10)
    ActionChains(browser).key_up(Keys.ARROW_UP).perform()
    canvas = browser.find_element("id", "canvas")
    ActionChains(browser).move_to_element(canvas).click_and_hold().perform()
    for _ in range(2):
        _frames(browser, 2)
        ActionChains(browser).move_by_offset(-40, 0).perform()
    _frames(browser, 2)
    ActionChains(browser).release().perform()
    assert _page(browser).get("view") == "lead", "the episode ended before the inputs did"
    # the episode runs out at its time limit (the page keeps stepping with no input)
    _wait(browser, lambda: _page(browser).get("view") in ("outcome", "done"))
    if _page(browser).get("view") == "outcome":
        ActionChains(browser).send_keys(Keys.ENTER).perform()
    _wait(browser, lambda: _page(browser).get("view") == "done")
    participant = re.search(r"code is (p[0-9a-f]{12})",
                            browser.find_element("id", "done-text").text).group(1)

    dataset = open_dataset("hanger-physical-people-v0", data)
    assert dataset.physical and not dataset.synthetic
    assert dataset.participants() == [participant]
    steps = dataset.steps()
    n = steps.num_rows
    assert n == round(MAX_TIME_S * 25)  # every 25 Hz step of the episode recorded
    inputs = steps.column("input").to_pylist()
    assert "keys" in inputs and "mouse" in inputs  # what the person moved, named per step
    targets = np.stack(steps.column("hand_target").to_numpy(zero_copy_only=False))
    hands = np.stack(steps.column("hand_pose").to_numpy(zero_copy_only=False))
    assert targets[:, 2].max() > targets[0, 2] + 0.05  # the up arrow lifted the target
    lifted = int(np.argmax(targets[:, 2]))
    assert hands[lifted:, 2].max() > hands[0, 2] + 0.01  # and the hand followed it
    latency = [ms for ms in steps.column("client_latency_ms").to_pylist() if ms is not None]
    assert len(latency) >= n - 2 and min(latency) > 0  # measured in the browser
    # the same inputs through the same env and robot give the same episode, step by step
    replayed = replay_physical(dataset)
    assert len(replayed) == 1 and replayed[0].agrees, replayed[0].differences
    np.testing.assert_array_equal(replayed[0].replayed, steps.column("reward").to_numpy())
    # the robot's view as a Minari dataset
    import minari

    monkeypatch.setenv("MINARI_DATASETS_PATH", str(export_minari(dataset)))
    md = minari.load_dataset(dataset.minari_id)
    assert md.total_episodes == 1 and md.total_steps == n
    episode = next(md.iterate_episodes())
    np.testing.assert_array_equal(episode.actions,
                                  np.stack(steps.column("robot_action")
                                           .to_numpy(zero_copy_only=False)))
