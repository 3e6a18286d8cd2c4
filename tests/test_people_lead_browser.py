"""A person leads the simulated arm in a real browser: ``hri-bench serve --physical`` as a
process, Debian's headless chromium (WebGL in software) driven by Selenium through
chromium-driver, holding the keys and dragging the mouse a person would. The recorded
physical dataset is then checked against the env's own replay of the same inputs (the
hand targets and stiffness the page sent, through the same env and robot). Skipped where
chromium, chromium-driver, the ``web`` extra or the page's three.js (``make web``) are
missing (``make test`` installs them)."""

import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("fastapi")
pytest.importorskip("selenium.webdriver")

from hri_bench.data.datasets import export_minari, open_dataset  # noqa: E402
from hri_bench.data.physical_replay import replay_physical  # noqa: E402
from hri_bench.people.serve.browser import (  # noqa: E402
    chromium,
    have_chromium,
    page_state,
    wait_for,
)
from hri_bench.people.serve.launch import start_serve, stop_serve  # noqa: E402

THREE = (Path(__file__).parents[1] / "hri_bench" / "people" / "serve" / "static" / "vendor"
         / "three.module.js")
pytestmark = [
    pytest.mark.skipif(not have_chromium(),
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
    proc, url, lines = start_serve(
        ["hanger", "--physical", "--port", "0", "--data", str(data), "--episodes", "1",
         "--max-time", str(MAX_TIME_S), "--agent", "admittance"], timeout=120)
    assert url, "".join(lines)
    yield url, data
    stop_serve(proc, 30)


@pytest.fixture
def browser(tmp_path):
    driver = chromium(tmp_path / "profile", webgl=True, window=(640, 760))
    yield driver
    driver.quit()


def _frames(driver, n):
    """Wait until the page has drawn ``n`` more frames (each answered by one step)."""
    start = int(page_state(driver)["drawn"])
    wait_for(driver, lambda: int(page_state(driver).get("drawn", start)) >= start + n)


def test_a_person_leads_the_arm_and_the_recording_replays(server, browser, monkeypatch):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    url, data = server
    browser.get(url)
    wait_for(browser, lambda: page_state(browser).get("view") == "consent")
    browser.find_element("id", "agree").click()
    browser.find_element("id", "start").click()
    wait_for(browser, lambda: (p := page_state(browser)).get("view") == "lead" and p.get("drawn"))
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
    assert page_state(browser).get("view") == "lead", "the episode ended before the inputs did"
    # the episode runs out at its time limit (the page keeps stepping with no input)
    wait_for(browser, lambda: page_state(browser).get("view") in ("outcome", "done"))
    if page_state(browser).get("view") == "outcome":
        ActionChains(browser).send_keys(Keys.ENTER).perform()
    wait_for(browser, lambda: page_state(browser).get("view") == "done")
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
