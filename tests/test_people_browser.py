"""A person's session in a real browser: ``hri-bench serve`` as a process, Debian's headless
chromium driven by Selenium through chromium-driver, pressing the keys a person would.
Then both datasets are loaded and checked against the env's own replay of the same
actions. Skipped where chromium, chromium-driver or the ``web`` extra are missing
(``make test`` installs them)."""

import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("fastapi")
pytest.importorskip("selenium.webdriver")

from hri_bench.data.datasets import export_minari, export_parquet, open_dataset  # noqa: E402
from hri_bench.data.replay import replay  # noqa: E402
from hri_bench.people.serve.browser import chromium, have_chromium, wait_for  # noqa: E402
from hri_bench.people.serve.launch import start_serve, stop_serve  # noqa: E402
from hri_envs.humans.scripted import preference_human  # noqa: E402
from hri_envs.task.scenarios import scenario_graph  # noqa: E402

pytestmark = [
    pytest.mark.skipif(not have_chromium(),
                       reason="needs Debian's chromium and chromium-driver (make test "
                              "installs them)"),
    pytest.mark.xdist_group("people-browser"),
]
EPISODES = 3


def _start(data, *extra):
    """``hri-bench serve`` on a free port of 127.0.0.1; (process, url)."""
    proc, url, lines = start_serve(
        ["hanger", "--port", "0", "--data", str(data), "--episodes", str(EPISODES),
         "--max-steps", "40", *extra], timeout=60)
    assert url, "".join(lines)
    return proc, url


@pytest.fixture
def server(tmp_path):
    """``hri-bench serve`` on a free port of 127.0.0.1; yields (url, data root)."""
    data = tmp_path / "data"
    proc, url = _start(data)
    yield url, data
    stop_serve(proc, 20)


@pytest.fixture
def browser(tmp_path):
    driver = chromium(tmp_path / "profile", webgl=False, window=(900, 1000))
    yield driver
    driver.quit()


def _wait(driver, condition, timeout=15.0):
    return wait_for(driver, condition, timeout, poll=0.01)


def _view(driver):
    """The page's view as its body's data attributes, read at once (one script)."""
    return driver.execute_script(
        "const d = document.body.dataset; const keys = {};"
        "for (const b of document.querySelectorAll('#options button'))"
        "  keys[b.dataset.action] = b.dataset.key;"
        "return {view: d.view, seq: d.seq, state: d.state, start: d.start, goal: d.goal,"
        "        keys: keys};")


@pytest.fixture
def elsewhere():
    """Another site: a page served from another port (another origin) of this machine."""
    import http.server
    import threading

    class Page(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            body = b"<!doctype html><p>another site</p>"
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Page)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}/"
    httpd.shutdown()
    httpd.server_close()


def test_a_person_plays_three_episodes_with_the_keyboard(server, browser, elsewhere,
                                                         monkeypatch):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    url, data = server
    graph = scenario_graph("hanger")
    person = preference_human(graph, None)  # the person's choices: the study's preference
    # a page elsewhere tries to join (as any site the lab machine visits could): refused
    browser.get(elsewhere)
    status = browser.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "fetch(arguments[0] + 'api/sessions', {method: 'POST', mode: 'no-cors',"
        "  headers: {'Content-Type': 'text/plain'}, body: '{\"consent\": true}'})"
        ".then((r) => done(r.type), (e) => done(String(e)));", url)
    assert status == "opaque"  # sent; the answer (403) is not theirs to read
    browser.get(url)
    _wait(browser, lambda: _view(browser)["view"] == "consent")
    assert "anonymous" in browser.find_element("id", "consent-text").text
    assert not browser.find_element("id", "start").is_enabled()
    browser.find_element("id", "agree").click()
    browser.find_element("id", "start").click()
    pressed, reloaded = 0, False

    def new_view(seen):
        return lambda: ((v := _view(browser))["seq"] != seen
                        and v["view"] in ("frame", "outcome", "done") and v)

    seen = None
    while True:
        view = _wait(browser, new_view(seen))
        if view["view"] == "done":
            break
        seen = view["seq"]
        if view["view"] == "outcome":
            ActionChains(browser).send_keys(Keys.ENTER).perform()
            continue
        if pressed == 4 and not reloaded:  # the page is reloaded mid-episode: it resumes
            browser.refresh()
            reloaded = True
            again = _wait(browser, lambda: (v := _view(browser))["view"] == "frame" and v)
            assert again == view
        state, start, goal = (int(view[k]) for k in ("state", "start", "goal"))
        action = int(person.preferred_action(np.array(state), np.array(start), np.array(goal)))
        ActionChains(browser).send_keys(view["keys"][str(action)]).perform()
        pressed += 1
    done_text = browser.find_element("id", "done-text").text
    participant = re.search(r"code is (p[0-9a-f]{12})", done_text).group(1)
    items = browser.find_elements("css selector", "#done-list li")
    assert len(items) == EPISODES and reloaded

    dataset = open_dataset("hanger-people-v0", data)
    assert dataset.participants() == [participant] and not dataset.synthetic
    steps = dataset.steps()
    assert steps.num_rows == pressed
    assert sorted(set(steps.column("episode").to_pylist())) == list(range(EPISODES))
    assert all(ms is not None and ms >= 0 for ms in steps.column("client_response_ms")
               .to_pylist())
    # the env's own replay of the recorded actions gives the recorded rewards
    replayed = replay(dataset)
    assert len(replayed) == EPISODES and all(r.agrees for r in replayed)
    # the multi-agent view as one Parquet file
    import pyarrow.parquet as pq

    table = pq.read_table(export_parquet(dataset, data / "all.parquet"))
    assert table.num_rows == pressed
    assert table.schema.metadata[b"content_hash"].decode() == dataset.content_hash()
    # the robot's view as a Minari dataset
    import minari

    root = export_minari(dataset)
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(Path(root)))
    md = minari.load_dataset(dataset.minari_id)
    assert md.total_episodes == EPISODES and md.total_steps == pressed
    for episode, mine in zip(md.iterate_episodes(), replayed, strict=True):
        np.testing.assert_array_equal(episode.rewards, mine.replayed)
        assert len(episode.observations["state"]) == len(episode.actions) + 1


def test_the_page_says_why_a_session_ended(tmp_path, browser):
    """A robot that calls sys.exit() ends the session with its error on the page (it once
    left the page waiting for ever)."""
    proc, url = _start(tmp_path / "data", "--agent", "tests.helpers_agents:ExitsInAct")
    try:
        browser.get(url)
        _wait(browser, lambda: _view(browser)["view"] == "consent")
        browser.find_element("id", "agree").click()
        browser.find_element("id", "start").click()
        _wait(browser, lambda: _view(browser)["view"] == "ended")
        text = browser.find_element("id", "done-text").text
        assert "failed" in text and "SystemExit in act()" in text, text
    finally:
        stop_serve(proc, 20)
