// A physical task's input: the participant leads their simulated arm's hand.
//
// The participant moves a target for their hand (the orange ball): dragging in the picture
// with the mouse or a finger moves it in the plane facing the camera (right, left, up,
// down), Shift-drag or the buttons and W / S move it nearer or farther, the arrows move it
// too, Q / E and the turn buttons turn it about the task's axis of rotation. The hand
// follows the target as the simulated arm can (its impedance and strength turn the lead
// into the force the robot feels), so the target may run ahead of the hand.
//
// The simulation steps once per input, at most 25 times a second (lockstep): each frame
// from the server is answered with a "hand" message carrying the target, 40 ms after the
// last one was sent or at once if that has passed. The time from sending an input to
// receiving the frame it produced is measured and sent with the next input.

const STEP_MS = 40;            // the env's step (25 Hz)
const KEY_SPEED = 0.25;        // [m/s] a held key or button moves the target this fast
const TURN_SPEED = 0.9;        // [rad/s] a held turn key or button
const MAX_LEAD_M = 0.35;       // the target stays within this of the hand

const KEYS = {
  ArrowLeft: "left", ArrowRight: "right", ArrowUp: "up", ArrowDown: "down",
  w: "far", W: "far", s: "near", S: "near", q: "turn-", Q: "turn-", e: "turn+", E: "turn+",
};

function quatMultiply(a, b) {
  // (w, x, y, z) quaternions: a then b's frame, as MuJoCo's mju_mulQuat
  return [a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
          a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
          a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]];
}

function turned(quat, axis, angle) {
  // ``quat`` turned by ``angle`` about the world ``axis``
  const s = Math.sin(angle / 2);
  const q = quatMultiply([Math.cos(angle / 2), axis[0] * s, axis[1] * s, axis[2] * s], quat);
  const n = Math.hypot(...q);
  return q.map((v) => v / n);
}

export class Lead {
  constructor(view, send, canvas, forceText) {
    this.view = view;
    this.send = send;
    this.canvas = canvas;
    this.forceText = forceText;
    this.target = null;        // [x, y, z, qw, qx, qy, qz]
    this.episode = null;
    this.frameSeen = null;     // the last frame
    this.waiting = false;      // an input is on its way; its frame not back yet
    this.sentAt = 0;
    this.latency = null;       // of the last round trip [ms]
    this.held = new Set();     // held keys and buttons
    this.used = "none";        // what moved the target since the last input
    this.timer = null;
    this.paused = false;
    this.drag = null;
    this.listen();
  }

  listen() {
    const c = this.canvas;
    c.classList.add("leading");
    c.addEventListener("pointerdown", (e) => {
      if (!this.target) return;
      c.setPointerCapture(e.pointerId);
      this.drag = {x: e.clientX, y: e.clientY, depth: e.shiftKey,
                   kind: e.pointerType === "touch" ? "touch" : "mouse"};
      e.preventDefault();
    });
    c.addEventListener("pointermove", (e) => {
      if (!this.drag || !this.target) return;
      const dx = e.clientX - this.drag.x;
      const dy = e.clientY - this.drag.y;
      this.drag.x = e.clientX;
      this.drag.y = e.clientY;
      this.moveByPixels(dx, dy, this.drag.depth || e.shiftKey);
      this.used = this.drag.kind;
    });
    const end = () => { this.drag = null; };
    c.addEventListener("pointerup", end);
    c.addEventListener("pointercancel", end);
    for (const button of document.querySelectorAll("#lead [data-hold]")) {
      const name = button.dataset.hold;
      const release = () => this.held.delete(`button:${name}`);
      button.addEventListener("pointerdown", (e) => {
        this.held.add(`button:${name}`);
        e.preventDefault();
      });
      for (const kind of ["pointerup", "pointerleave", "pointercancel"]) {
        button.addEventListener(kind, release);
      }
    }
  }

  // A key pressed (down) or released; whether it is one of the task's.
  key(name, down) {
    const move = KEYS[name];
    if (!move) return false;
    if (down) this.held.add(`key:${move}`); else this.held.delete(`key:${move}`);
    return true;
  }

  moveByPixels(dx, dy, depth) {
    const {perPixel, right, forward} = this.view.screenAxes(this.target.slice(0, 3));
    const t = this.target;
    t[0] += right.x * dx * perPixel;
    t[1] += right.y * dx * perPixel;
    if (depth) {
      t[0] -= forward.x * dy * perPixel;
      t[1] -= forward.y * dy * perPixel;
    } else {
      t[2] -= dy * perPixel;
    }
    this.clamp();
  }

  // Held keys and buttons move the target for ``seconds``.
  applyHeld(seconds) {
    if (!this.held.size || !this.target) return;
    const {right, forward} = this.view.screenAxes(this.target.slice(0, 3));
    const step = KEY_SPEED * seconds;
    const t = this.target;
    let keys = false;
    let buttons = false;
    for (const entry of this.held) {
      const [source, move] = entry.split(":");
      if (source === "key") keys = true; else buttons = true;
      if (move === "left" || move === "right") {
        const sign = move === "right" ? 1 : -1;
        t[0] += sign * right.x * step;
        t[1] += sign * right.y * step;
      } else if (move === "far" || move === "near") {
        const sign = move === "far" ? 1 : -1;
        t[0] += sign * forward.x * step;
        t[1] += sign * forward.y * step;
      } else if (move === "up" || move === "down") {
        t[2] += (move === "up" ? 1 : -1) * step;
      } else if ((move === "turn+" || move === "turn-") && this.view.rotationAxis) {
        const axis = this.view.rotationAxis;
        const angle = (move === "turn+" ? -1 : 1) * TURN_SPEED * seconds;
        const q = turned(t.slice(3), [axis.x, axis.y, axis.z], angle);
        for (let i = 0; i < 4; i++) t[3 + i] = q[i];
      }
    }
    this.used = keys ? "keys" : (buttons ? "buttons" : this.used);
    this.clamp();
  }

  // The target stays within MAX_LEAD_M of the hand.
  clamp() {
    const hand = this.frameSeen && this.frameSeen.hand;
    if (!hand) return;
    const d = [0, 1, 2].map((i) => this.target[i] - hand[i]);
    const n = Math.hypot(...d);
    if (n > MAX_LEAD_M) {
      for (let i = 0; i < 3; i++) this.target[i] = hand[i] + d[i] * MAX_LEAD_M / n;
    }
  }

  // A frame from the server: draw it, and answer it.
  async frame(m) {
    this.paused = false;
    const now = performance.now();
    if (this.waiting) {
      this.latency = now - this.sentAt;
      this.waiting = false;
    }
    if (this.episode !== m.episode || !this.target) {  // a new episode: the target is the hand
      this.target = m.hand.slice();
      this.episode = m.episode;
      this.held.clear();
    }
    this.frameSeen = m;
    const v = this.view;
    await v.load(m.scene);
    v.setCamera(m.camera);
    v.setGoal(m.goal);
    v.setPoses(m.poses);
    v.setTarget(this.target.slice(0, 3), m.hand.slice(0, 3));
    v.setForce(m.handle, m.force);
    v.setBelief(m.belief || null);
    v.draw();
    const force = Math.hypot(...m.force);
    this.forceText.textContent = `The force of your hand on the handle: ` +
      `${force.toFixed(0)} N. Time: ${m.time_s.toFixed(1)} of ${m.time_limit_s.toFixed(0)} s.`;
    document.body.dataset.drawn = String(m.seq);
    document.body.dataset.time = String(m.time_s);
    this.schedule(m.seq);
  }

  schedule(seq) {
    clearTimeout(this.timer);
    const wait = Math.max(0, this.sentAt + STEP_MS - performance.now());
    this.timer = setTimeout(() => this.answer(seq), wait);
  }

  answer(seq) {
    if (this.paused || !this.frameSeen || this.frameSeen.seq !== seq) return;
    const now = performance.now();
    this.applyHeld(this.sentAt ? Math.min(0.1, (now - this.sentAt) / 1000) : STEP_MS / 1000);
    const v = this.view;
    v.setTarget(this.target.slice(0, 3), this.frameSeen.hand.slice(0, 3));
    v.draw();
    const sent = this.send({type: "hand", seq, target: this.target.map((x) => +x.toFixed(5)),
                            stiffness: 1, input: this.used,
                            latency_ms: this.latency === null ? null :
                              Math.round(this.latency * 10) / 10});
    if (!sent) return;
    this.used = "none";
    this.waiting = true;
    this.sentAt = now;
  }

  // The server refused the last input (an error): send the target again.
  retry() {
    this.waiting = false;
    if (this.frameSeen) this.schedule(this.frameSeen.seq);
  }

  pause() {
    this.paused = true;
    clearTimeout(this.timer);
    this.waiting = false;
    this.target = null;
    this.held.clear();
  }
}
