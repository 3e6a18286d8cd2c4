// The participant's page of hri-bench serve: consent, then the task over one websocket.
// The session's token stays in this browser's localStorage, so a reload resumes the
// session. Text from the server is only ever set as textContent. The task is drawn in 3D
// (view3d.js, three.js built by `make web`); a physical task's input is lead.js's.
import {Lead} from "/lead.js";

const KEY = "hri-bench-session";
const $ = (id) => document.getElementById(id);
let socket = null;
let view = null;       // the last view from the server
let shownAt = 0;       // when the current frame was painted (performance.now())
let busy = false;      // an answer to the current view is on its way
let over = false;      // the session is done or ended: do not reconnect
let scene = null;      // the 3D view (view3d.js), once loaded
let sceneFailed = "";  // why the 3D view cannot be shown
let lead = null;       // a physical task's input (lead.js)

function paragraphs(el, text) {
  el.replaceChildren();
  for (const block of String(text).split(/\n\s*\n/)) {
    const p = document.createElement("p");
    p.textContent = block.replace(/\s*\n\s*/g, " ").trim();
    el.appendChild(p);
  }
}

function show(section) {
  for (const id of ["consent", "play", "done"]) $(id).hidden = id !== section;
}

function error(text) {
  $("error").textContent = text;
  $("error").hidden = !text;
}

function send(message) {
  if (socket && socket.readyState === WebSocket.OPEN) {
    socket.send(JSON.stringify(message));
    return true;
  }
  return false;
}

function choose(action) {
  if (!view || view.type !== "frame" || busy) return;
  if (!view.options.some((o) => o.action === action)) return;
  busy = true;
  for (const b of $("options").querySelectorAll("button")) b.disabled = true;
  send({type: "action", seq: view.seq, action: action,
        rt_ms: Math.max(0, Math.round(performance.now() - shownAt))});
}

function next() {
  if (!view || view.type !== "outcome" || view.last || busy) return;
  busy = true;
  $("next").disabled = true;
  send({type: "continue", seq: view.seq});
}

function header(m) {
  $("status").textContent = `Episode ${m.episode} of ${m.episodes}` +
    (m.step && m.type !== "lead" ? ` · step ${m.step}` : "");
  $("goal").textContent = `Your goal: bring it from ${m.start_name} to ${m.goal_name}.`;
  $("preference").hidden = !m.preference;
  $("preference").textContent = m.preference || "";
}

// The 3D view, loaded once (null where it cannot be: the page says why).
async function view3d() {
  if (scene || sceneFailed) return scene;
  try {
    const module = await import("/view3d.js");
    scene = new module.SceneView($("canvas"), $("labels"));
  } catch (e) {
    sceneFailed = "The 3D view is not available here: the server's page was not built " +
      "(run make web in the repository) or this browser has no WebGL.";
  }
  return scene;
}

// Draw a view's scene: in 3D from the server's poses, or its 2D picture.
async function draw(m) {
  if (m.picture) {
    $("view").hidden = true;
    $("picture").hidden = false;
    $("picture").src = m.picture;
    $("view-note").hidden = false;
    $("view-note").textContent = "A 3D view of the task is shown once the page is built " +
      "(run make web in the repository).";
    return null;
  }
  const v = await view3d();
  if (!v) {
    $("view").hidden = true;
    $("view-note").hidden = false;
    $("view-note").textContent = sceneFailed;
    return null;
  }
  $("view").hidden = false;
  $("picture").hidden = true;
  await v.load(m.scene);
  if (m.camera) v.setCamera(m.camera);
  v.setGoal(m.goal);
  v.setPoses(m.poses);
  v.setBelief(m.belief || null);
  v.draw();
  document.body.dataset.drawn = String(m.seq);
  return v;
}

function painted() {
  requestAnimationFrame(() => { shownAt = performance.now(); });
}

function onFrame(m) {
  show("play");
  header(m);
  draw(m).catch((e) => error(String(e)));
  $("outcome").hidden = true;
  $("where").textContent = `Now: ${m.state_name}.`;
  $("robot").textContent = `The robot is about to: ${m.robot}.`;
  $("note").hidden = !m.note;
  $("note").textContent = m.note || "";
  $("belief").hidden = !m.belief;
  if (m.belief) {
    $("belief").textContent = "The robot thinks your goal is: " + Object.entries(m.belief)
      .map(([k, v]) => `${k} ${Math.round(100 * v)}%`).join(", ");
  }
  const box = $("options");
  box.replaceChildren();
  for (const o of m.options) {
    const b = document.createElement("button");
    b.dataset.action = String(o.action);
    b.dataset.key = o.key;
    const k = document.createElement("kbd");
    k.textContent = o.key;
    b.append(k, o.label);
    b.addEventListener("click", () => choose(o.action));
    box.appendChild(b);
  }
  painted();
}

function onOutcome(m) {
  show("play");
  header(m);
  if (lead) lead.pause();
  draw(m).catch((e) => error(String(e)));
  $("options").replaceChildren();
  $("robot").textContent = "";
  $("note").hidden = true;
  $("belief").hidden = true;
  $("where").textContent = "";
  const where = m.reached_name ? `rests on ${m.reached_name}` : (m.outcome &&
    m.outcome !== "timeout" ? `was not put on a support (${m.outcome.replace("_", " ")})` :
    "did not arrive in time");
  const verdict = m.success ? "You reached your goal." :
    (m.reached_name ? "That was not your goal." : "");
  const length = m.time_s !== undefined ? `${m.time_s.toFixed(1)} s` : `${m.steps} steps`;
  const effort = m.effort !== undefined && m.effort !== null ?
    ` Your effort: ${m.effort} N s.` : "";
  $("outcome-text").textContent =
    `Episode ${m.episode} is over after ${length}: it ${where}. ${verdict}${effort} ` +
    `The robot's score: ${m.reward}. ` + (m.last ? "" : "The robot learns from it.");
  $("next").hidden = m.last;
  $("next").disabled = false;
  $("outcome").hidden = false;
  painted();
}

function onDone(m) {
  over = true;
  if (lead) lead.pause();
  show("done");
  $("done-text").textContent = `All episodes are done. Your anonymous code is ${m.participant}.`;
  const list = $("done-list");
  list.replaceChildren();
  for (const o of m.outcomes) {
    const li = document.createElement("li");
    li.textContent = `Episode ${o.episode}: ${o.reached_name || "no support"}` +
      ` (goal ${o.goal_name}), robot's score ${o.reward}`;
    list.appendChild(li);
  }
  localStorage.removeItem(KEY);
}

function onEnded(m) {
  over = true;
  if (lead) lead.pause();
  show("done");
  $("done-text").textContent = `The session has ended (${m.reason}` +
    (m.error ? `: ${m.error}` : "") + `). ` +
    `Your anonymous code is ${m.participant}. Thank you.`;
  localStorage.removeItem(KEY);
}

function handle(m) {
  if (m.type === "error") {
    error(m.error);
    if (lead && view && view.type === "lead") lead.retry();
    busy = false;
    for (const b of $("options").querySelectorAll("button")) b.disabled = false;
    $("next").disabled = false;
    return;
  }
  if (m.type === "replaced") {
    over = true;
    error("This session was opened in another window or tab; continue there.");
    return;
  }
  error("");
  view = m;
  busy = false;
  document.body.dataset.view = m.type;
  document.body.dataset.seq = String(m.seq);
  if (m.type === "frame") {
    document.body.dataset.state = String(m.state);
    document.body.dataset.start = String(m.start);
    document.body.dataset.goal = String(m.goal);
    onFrame(m);
  } else if (m.type === "lead") {
    onLead(m);
  } else if (m.type === "outcome") {
    onOutcome(m);
  } else if (m.type === "done") {
    onDone(m);
  } else if (m.type === "ended") {
    onEnded(m);
  } else {
    show("play");
    $("options").replaceChildren();  // the robot is busy: nothing to choose meanwhile
    $("status").textContent = m.message || "Preparing the robot...";
  }
}

// A frame of a physical task: the scene drawn, the participant's input sent back (lead.js).
function onLead(m) {
  show("play");
  header(m);
  $("outcome").hidden = true;
  $("options").replaceChildren();
  $("robot").textContent = "";
  $("where").textContent = "";
  $("lead").hidden = false;
  document.body.dataset.goal = String(m.goal);
  view3d().then((v) => {
    if (!v) {
      $("view-note").hidden = false;
      $("view-note").textContent = sceneFailed + " The physical task needs it.";
      return;
    }
    if (!lead) lead = new Lead(v, send, $("canvas"), $("force"));
    lead.frame(m).catch((e) => error(String(e)));
  });
}

function connect(token) {
  const scheme = location.protocol === "https:" ? "wss://" : "ws://";
  socket = new WebSocket(scheme + location.host + "/ws");
  socket.addEventListener("open", () => send({type: "hello", session: token}));
  socket.addEventListener("message", (e) => handle(JSON.parse(e.data)));
  socket.addEventListener("close", (e) => {
    if (e.code === 4401) {
      localStorage.removeItem(KEY);
      error("This session is no longer known to the server. Start a new one.");
      show("consent");
    } else if (!over) {
      setTimeout(() => connect(token), 1000);
    }
  });
}

async function start() {
  $("start").disabled = true;
  // the page's token: only a page this server served carries it
  const token = document.querySelector('meta[name="hri-bench-token"]').content;
  const response = await fetch("/api/sessions", {
    method: "POST",
    headers: {"Content-Type": "application/json", "X-HRI-Bench-Token": token},
    body: JSON.stringify({consent: true}),
  });
  const body = await response.json();
  if (response.status !== 201) {
    error(body.error || "Cannot start a session now.");
    $("start").disabled = false;
    return;
  }
  localStorage.setItem(KEY, body.session);
  show("play");
  connect(body.session);
}

document.addEventListener("keydown", (e) => {
  if (e.ctrlKey || e.altKey || e.metaKey || !view) return;
  if (view.type === "lead") {
    if (lead && lead.key(e.key, true)) e.preventDefault();
    return;
  }
  if (e.repeat) return;
  if (view.type === "frame") {
    const option = view.options.find((o) => o.key && o.key === e.key);
    if (option) {
      e.preventDefault();
      choose(option.action);
    }
  } else if (view.type === "outcome" && (e.key === "Enter" || e.key === " ")) {
    e.preventDefault();
    next();
  }
});

document.addEventListener("keyup", (e) => {
  if (lead) lead.key(e.key, false);
});

async function main() {
  $("agree").addEventListener("change", () => { $("start").disabled = !$("agree").checked; });
  $("start").addEventListener("click", start);
  $("next").addEventListener("click", next);
  const study = await (await fetch("/api/study")).json();
  paragraphs($("consent-text"), study.consent);
  paragraphs($("instructions-text"), study.instructions);
  paragraphs($("instructions-first"), study.instructions);
  const token = localStorage.getItem(KEY);
  if (token) {
    show("play");
    connect(token);
  } else {
    show("consent");
    document.body.dataset.view = "consent";
  }
}

main();
