// The page's 3D view: the server's own MuJoCo scene drawn with three.js.
//
// The scene's description (GET /api/scene/KEY: every visible geom of the compiled model with
// its body, type, size, pose and colour, and the Panda's meshes) is loaded once; each view
// from the server then carries the drawn bodies' poses (x, y, z, qw, qx, qy, qz per body) and
// the camera fitted at the episode's start. The supports are labelled with HTML text placed
// over the canvas; the participant's goal is marked. The physical tasks add the hand's
// target (where the participant leads their hand), the force their hand puts on the handle
// (an arrow) and the robot's belief about their goal (in the labels).
import * as THREE from "/vendor/three.module.js";

const FORCE_M_PER_N = 0.015;   // the force arrow's length per newton
const FORCE_MAX_M = 0.45;      // its longest
const GOAL_RADIUS_M = 0.07;    // the goal's mark (as the renderer's)

function mujocoQuat(q, offset = 0) {
  // MuJoCo's (w, x, y, z) as three.js's (x, y, z, w)
  return new THREE.Quaternion(q[offset + 1], q[offset + 2], q[offset + 3], q[offset]);
}

function decode(b64, Type) {
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  return new Type(bytes.buffer);
}

function meshGeometry(mesh) {
  const q = decode(mesh.vertices, Uint16Array);
  const positions = new Float32Array(q.length);
  for (let i = 0; i < q.length; i++) {
    const axis = i % 3;
    positions[i] = mesh.offset[axis] + q[i] * mesh.scale[axis];
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute("position", new THREE.BufferAttribute(positions, 3));
  geometry.setIndex(new THREE.BufferAttribute(
    decode(mesh.faces, mesh.index === "uint16" ? Uint16Array : Uint32Array), 1));
  geometry.computeVertexNormals();
  return geometry;
}

function primitive(geom) {
  // three.js's capsules and cylinders stand along y; MuJoCo's along z
  const s = geom.size;
  switch (geom.type) {
    case "plane":
      return new THREE.PlaneGeometry(2 * (s[0] || 10), 2 * (s[1] || 10));
    case "sphere":
      return new THREE.SphereGeometry(s[0], 24, 16);
    case "ellipsoid":
      return new THREE.SphereGeometry(1, 24, 16).scale(s[0], s[1], s[2]);
    case "capsule":
      return new THREE.CapsuleGeometry(s[0], 2 * s[1], 6, 16).rotateX(Math.PI / 2);
    case "cylinder":
      return new THREE.CylinderGeometry(s[0], s[0], 2 * s[1], 24).rotateX(Math.PI / 2);
    case "box":
      return new THREE.BoxGeometry(2 * s[0], 2 * s[1], 2 * s[2]);
    default:
      return null;
  }
}

export class SceneView {
  constructor(canvas, labels) {
    this.canvas = canvas;
    this.labelLayer = labels;
    this.renderer = new THREE.WebGLRenderer({canvas, antialias: true,
                                             preserveDrawingBuffer: true});
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.shadowMap.enabled = true;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xe4e2dc);
    this.camera = new THREE.PerspectiveCamera(45, 1.5, 0.05, 60);
    this.camera.up.set(0, 0, 1);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8478, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.9);
    sun.position.set(1.5, -2.0, 6.0);
    sun.castShadow = true;
    sun.shadow.mapSize.set(2048, 2048);
    Object.assign(sun.shadow.camera, {left: -4, right: 4, top: 4, bottom: -4, near: 0.5,
                                      far: 15});
    this.scene.add(sun);
    this.key = null;
    this.bodies = [];
    this.labels = [];
    this.anchors = [];
    this.seats = [];
    this.goal = null;
    this.marks = new THREE.Group();
    this.scene.add(this.marks);
    this.goalMark = new THREE.Mesh(
      new THREE.SphereGeometry(GOAL_RADIUS_M, 24, 16),
      new THREE.MeshStandardMaterial({color: 0x1acc33, transparent: true, opacity: 0.45}));
    this.goalMark.visible = false;
    this.marks.add(this.goalMark);
    this.target = new THREE.Mesh(
      new THREE.SphereGeometry(0.028, 20, 14),
      new THREE.MeshStandardMaterial({color: 0xff8c1a, transparent: true, opacity: 0.7}));
    this.target.visible = false;
    this.marks.add(this.target);
    this.lead = new THREE.Line(new THREE.BufferGeometry().setFromPoints(
      [new THREE.Vector3(), new THREE.Vector3()]),
      new THREE.LineDashedMaterial({color: 0xff8c1a, dashSize: 0.02, gapSize: 0.015}));
    this.lead.visible = false;
    this.marks.add(this.lead);
    this.arrow = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(),
                                       0.1, 0xd9480f, 0.05, 0.035);
    this.arrow.visible = false;
    this.marks.add(this.arrow);
    for (const mark of [this.target, this.lead, this.arrow.line, this.arrow.cone]) {
      mark.material.depthTest = false;  // drawn over the scene: never hidden behind it
      mark.renderOrder = 10;
    }
    this.pending = false;
  }

  // Build the scene of a description (once per key).
  async load(key) {
    if (this.key === key) return;
    const response = await fetch(`/api/scene/${encodeURIComponent(key)}`);
    if (!response.ok) throw new Error(`the scene ${key} could not be loaded`);
    const doc = await response.json();
    for (const body of this.bodies) this.scene.remove(body);
    const meshes = doc.meshes.map(meshGeometry);
    this.bodies = doc.bodies.map((name) => {
      const group = new THREE.Group();
      group.name = name;
      this.scene.add(group);
      return group;
    });
    for (const geom of doc.geoms) {
      const shape = geom.type === "mesh" ? meshes[geom.mesh] : primitive(geom);
      if (!shape) continue;
      const [r, g, b, a] = geom.rgba;
      const material = new THREE.MeshStandardMaterial({
        color: new THREE.Color(r, g, b), roughness: 0.65, metalness: 0.05,
        transparent: a < 1, opacity: a});
      const mesh = new THREE.Mesh(shape, material);
      mesh.position.fromArray(geom.pos);
      mesh.quaternion.copy(mujocoQuat(geom.quat));
      mesh.castShadow = geom.type !== "plane";
      mesh.receiveShadow = true;
      (geom.body >= 0 ? this.bodies[geom.body] : this.scene).add(mesh);
    }
    this.makeLabels(doc.labels);
    this.rotationAxis = doc.rotation_axis ? new THREE.Vector3(...doc.rotation_axis) : null;
    this.key = key;
  }

  makeLabels(names) {
    this.labelLayer.replaceChildren();
    this.labels = names.map((name) => {
      const el = document.createElement("div");
      el.className = "label";
      el.dataset.support = name;
      const title = document.createElement("span");
      title.className = "label-name";
      title.textContent = name;
      const note = document.createElement("span");
      note.className = "label-note";
      el.append(title, note);
      this.labelLayer.appendChild(el);
      return {el, name, note};
    });
  }

  setCamera(cam) {
    if (!cam) return;
    this.camera.fov = cam.fovy;
    this.camera.position.fromArray(cam.eye);
    this.camera.lookAt(new THREE.Vector3(...cam.target));
    this.camera.updateProjectionMatrix();
    this.anchors = cam.labels.map((p) => new THREE.Vector3(...p));
    this.seats = cam.seats.map((p) => new THREE.Vector3(...p));
    this.setGoal(this.goal);
  }

  setPoses(poses) {
    for (let i = 0; i < this.bodies.length; i++) {
      const body = this.bodies[i];
      body.position.set(poses[7 * i], poses[7 * i + 1], poses[7 * i + 2]);
      body.quaternion.copy(mujocoQuat(poses, 7 * i + 3));
    }
  }

  // The participant's goal: marked at its seat and in its label (null: none).
  setGoal(goal) {
    this.goal = goal;
    this.goalMark.visible = goal !== null && goal !== undefined && !!this.seats[goal];
    if (this.goalMark.visible) this.goalMark.position.copy(this.seats[goal]);
    this.labels.forEach((label, k) => label.el.classList.toggle("goal", k === goal));
  }

  // The robot's belief about the goal, per support (null: none shown).
  setBelief(belief) {
    this.labels.forEach((label) => {
      const p = belief ? belief[label.name] : undefined;
      label.note.textContent = p === undefined ? (label.el.classList.contains("goal") ?
        "your goal" : "") : `robot: ${Math.round(100 * p)}%`;
    });
    if (!belief) this.setGoalNote();
  }

  setGoalNote() {
    this.labels.forEach((label) => {
      label.note.textContent = label.el.classList.contains("goal") ? "your goal" : "";
    });
  }

  // Where the participant leads their hand (world position), from the hand (null: none).
  setTarget(target, hand) {
    this.target.visible = !!target;
    this.lead.visible = !!(target && hand);
    if (!target) return;
    this.target.position.fromArray(target);
    if (hand) {
      this.lead.geometry.setFromPoints([new THREE.Vector3(...hand),
                                        new THREE.Vector3(...target)]);
      this.lead.computeLineDistances();
    }
  }

  // The force [N] the participant's hand puts on the handle, drawn at ``origin``.
  setForce(origin, force) {
    const f = force ? new THREE.Vector3(...force) : null;
    const size = f ? f.length() : 0;
    this.arrow.visible = size > 0.5;
    if (!this.arrow.visible) return;
    const length = Math.min(FORCE_MAX_M, FORCE_M_PER_N * size);
    this.arrow.position.fromArray(origin);
    this.arrow.setDirection(f.normalize());
    this.arrow.setLength(length, Math.min(0.06, 0.4 * length), Math.min(0.04, 0.3 * length));
  }

  // The supports' labels over the canvas: each centred above its support, the lower ones
  // placed first and a label that would cover one placed lifted above it.
  placeLabels() {
    const width = this.canvas.clientWidth;
    const height = this.canvas.clientHeight;
    const points = this.anchors.map((p) => p.clone().project(this.camera));
    const order = this.labels.map((_, k) => k).filter((k) => points[k]);
    order.sort((a, b) => points[a].y - points[b].y);
    const placed = [];
    for (const k of order) {
      const label = this.labels[k];
      const w = label.el.offsetWidth;
      const h = label.el.offsetHeight;
      const x = Math.max(w / 2, Math.min(width - w / 2, (points[k].x + 1) / 2 * width));
      let bottom = (1 - points[k].y) / 2 * height;
      for (let moved = true, tries = 0; moved && tries < 10; tries++) {
        moved = false;
        for (const o of placed) {
          if (Math.abs(o.x - x) < (w + o.w) / 2 + 2 && bottom > o.top - 2 && bottom - h < o.bottom) {
            bottom = o.top - 2;
            moved = true;
          }
        }
      }
      bottom = Math.max(h, Math.min(height, bottom));
      placed.push({x, w, top: bottom - h, bottom});
      label.el.style.left = `${Math.round(x - w / 2)}px`;
      label.el.style.top = `${Math.round(bottom - h)}px`;
    }
  }

  // Screen directions as world vectors at the target's depth: a pixel to the right, a pixel
  // up (the world's up), and the camera's forward on the floor (unit).
  screenAxes(point) {
    const height = this.canvas.clientHeight || 1;
    const eye = this.camera.position;
    const depth = new THREE.Vector3(...point).sub(eye).length();
    const perPixel = 2 * depth * Math.tan(THREE.MathUtils.degToRad(this.camera.fov) / 2) / height;
    const forward = new THREE.Vector3();
    this.camera.getWorldDirection(forward);
    forward.z = 0;
    forward.normalize();
    const right = new THREE.Vector3().crossVectors(forward, new THREE.Vector3(0, 0, 1));
    return {perPixel, right, forward};
  }

  draw() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      const width = this.canvas.clientWidth;
      const height = this.canvas.clientHeight;
      if (width && height) {
        this.renderer.setSize(width, height, false);
        this.camera.aspect = width / height;
        this.camera.updateProjectionMatrix();
      }
      this.renderer.render(this.scene, this.camera);
      this.placeLabels();
    });
  }
}
