// haptic6d viewer page: draws the scene live from the server's WebSocket state stream and sends
// the device pose driven by keys, mouse and gamepad. Units: mm, rad, N, N·mm; world z is up.
// Configuration q = (x, y, z, gamma, beta, alpha), R = Rz(alpha) Ry(beta) Rx(gamma).
import * as THREE from 'three';

const $ = (id) => document.getElementById(id);

// Exposed for tests and the console.
const app = {
  ready: false,        // scene drawn and first state received
  connected: false,
  scene: null,         // /api/scene
  state: null,         // latest state message
  dev: null,           // the page's device pose (mm, rad)
  maxForceSeen: 0,     // largest |F| shown so far (N)
  frames: 0,           // states received
  role: null,          // 'owner' (this page drives the device) or 'watcher'; from the server
  ahead: 0,            // watcher: pages ahead in the queue
  pageRecording: false, // the server lets the page record (serve --allow-page-recording)
};
window.haptic6d = app;

// ---------------------------------------------------------------------------------------------
// Three.js scene.
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
renderer.setSize(window.innerWidth, window.innerHeight);
$('view').appendChild(renderer.domElement);
const scene3 = new THREE.Scene();
scene3.background = new THREE.Color(0x1b1e24);
const camera = new THREE.PerspectiveCamera(40, window.innerWidth / window.innerHeight, 1, 1e5);
camera.up.set(0, 0, 1);
scene3.add(new THREE.HemisphereLight(0xdde6ff, 0x30302a, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(1, -2, 3);
scene3.add(sun);

// Camera orbit (spherical coordinates around a target).
const orbit = { target: new THREE.Vector3(), dist: 400, az: -0.9, el: 0.45 };
function placeCamera() {
  const c = Math.cos(orbit.el);
  camera.position.set(
    orbit.target.x + orbit.dist * c * Math.cos(orbit.az),
    orbit.target.y + orbit.dist * c * Math.sin(orbit.az),
    orbit.target.z + orbit.dist * Math.sin(orbit.el));
  camera.lookAt(orbit.target);
}
placeCamera();

function geometryOf(m) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(m.positions, 3));
  g.setIndex(m.indices);
  g.computeVertexNormals();
  g.computeBoundingBox();
  return g;
}

// R = Rz(alpha) Ry(beta) Rx(gamma): three.js Euler order 'ZYX' is exactly that product.
function setPose(obj, q) {
  obj.position.set(q[0], q[1], q[2]);
  obj.rotation.set(q[3], q[4], q[5], 'ZYX');
}

let toolSolid = null;
let toolGhost = null;
const forceArrow = new THREE.ArrowHelper(new THREE.Vector3(0, 0, 1), new THREE.Vector3(), 1, 0xffd34d);
const torqueArrow = new THREE.ArrowHelper(new THREE.Vector3(0, 0, 1), new THREE.Vector3(), 1, 0xd36bff);
scene3.add(forceArrow, torqueArrow);
// Arrows and contact spheres are drawn over the meshes: they usually sit inside or behind them.
for (const a of [forceArrow, torqueArrow]) {
  for (const part of [a.line, a.cone]) {
    part.material.depthTest = false;
    part.material.transparent = true;
    part.renderOrder = 10;
  }
}
forceArrow.visible = false;
torqueArrow.visible = false;

const MAX_SPHERES = 512;
const sphereGeo = new THREE.SphereGeometry(1, 16, 12);
const toolSpheres = new THREE.InstancedMesh(sphereGeo,
  new THREE.MeshStandardMaterial({ color: 0xff6a4d, transparent: true, opacity: 0.55 }), MAX_SPHERES);
const objSpheres = new THREE.InstancedMesh(sphereGeo,
  new THREE.MeshStandardMaterial({ color: 0x4dd2ff, transparent: true, opacity: 0.55 }), MAX_SPHERES);
toolSpheres.count = 0;
objSpheres.count = 0;
for (const m of [toolSpheres, objSpheres]) { m.material.depthTest = false; m.renderOrder = 9; }
scene3.add(toolSpheres, objSpheres);
let sceneSize = 200;

async function loadScene() {
  const r = await fetch('/api/scene');
  if (!r.ok) throw new Error(`GET /api/scene: ${r.status}`);
  const s = await r.json();
  app.scene = s;
  $('scene-name').textContent = s.name;
  $('btn-friction').hidden = !s.friction;
  $('friction-row').hidden = !s.friction;
  const box = new THREE.Box3();
  for (const o of s.objects) {
    const mesh = new THREE.Mesh(geometryOf(o),
      new THREE.MeshStandardMaterial({ color: 0xb8bcc6, roughness: 0.75, metalness: 0.05 }));
    setPose(mesh, o.pose);
    mesh.name = o.name;
    scene3.add(mesh);
    mesh.updateMatrixWorld();
    box.expandByObject(mesh);
  }
  const tg = geometryOf(s.tool);
  toolSolid = new THREE.Mesh(tg,
    new THREE.MeshStandardMaterial({ color: 0xf08a3c, roughness: 0.55, metalness: 0.1 }));
  toolGhost = new THREE.Mesh(tg, new THREE.MeshBasicMaterial({
    color: 0x7fb4ff, transparent: true, opacity: 0.22, depthWrite: false }));
  const ghostEdges = new THREE.LineSegments(new THREE.EdgesGeometry(tg, 25),
    new THREE.LineBasicMaterial({ color: 0x7fb4ff, transparent: true, opacity: 0.35 }));
  toolGhost.add(ghostEdges);
  scene3.add(toolSolid, toolGhost);
  setPose(toolSolid, s.start);
  setPose(toolGhost, s.start);
  toolSolid.updateMatrixWorld();
  box.expandByObject(toolSolid);
  const size = box.getSize(new THREE.Vector3());
  sceneSize = Math.max(size.x, size.y, size.z, 1);
  box.getCenter(orbit.target);
  orbit.dist = sceneSize * 2.2;
  placeCamera();
  if (!app.dev) app.dev = s.start.slice();
}

// ---------------------------------------------------------------------------------------------
// WebSocket.
let ws = null;
let contactsOn = false;
function send(msg) {
  if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(msg));
}
function connect() {
  ws = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  ws.onopen = () => {
    app.connected = true;
    $('conn').textContent = 'live';
    $('conn').className = 'good';
    if (contactsOn) send({ type: 'contacts', on: true });
  };
  ws.onclose = () => {
    app.connected = false;
    app.role = null;
    $('conn').textContent = 'disconnected (retrying)';
    $('conn').className = 'bad';
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => {
    const m = JSON.parse(ev.data);
    if (m.type === 'state') onState(m);
    else if (m.type === 'role') onRole(m);
    else if (m.type === 'recording') { $('notice').textContent = m.message; }
    else if (m.type === 'error') { $('notice').textContent = m.message; }
  };
}

// ---------------------------------------------------------------------------------------------
// State display.
const HIST = 600;
const histF = new Float32Array(HIST);
const histT = new Float32Array(HIST);
let histN = 0;
const fmt = (v, d) => v.toFixed(d);
const fmtPose = (q) => `${fmt(q[0], 2)} ${fmt(q[1], 2)} ${fmt(q[2], 2)} mm  ${fmt(q[3], 3)} ${fmt(q[4], 3)} ${fmt(q[5], 3)} rad`;
const norm3 = (v) => Math.hypot(v[0], v[1], v[2]);
const SOURCES = ['none (released)', 'page', 'UDP device', 'script', 'device'];
const FRICTION = ['on (no contact)', 'on: stick', 'on: slip'];
let lastUserInput = -1e9;

// One page owns the device; the others watch until it closes (the server ignores their
// commands). While a physical device drives the tool, every page watches. A page that becomes
// the owner starts from the device pose it was shown.
function onRole(m) {
  const wasOwner = app.role === 'owner';
  app.role = m.role;
  app.ahead = m.ahead;
  app.pageRecording = !!m.page_recording;
  if (m.role === 'owner' && !wasOwner) {
    if (app.state) app.dev = app.state.device.slice();
    dirty = false;
  }
  const owner = m.role === 'owner';
  $('conn').textContent = owner ? 'live'
    : m.device ? 'watching (a device drives)'
    : `watching (${m.ahead} page${m.ahead === 1 ? '' : 's'} ahead)`;
  $('conn').className = owner ? 'good' : 'dim';
  for (const id of ['btn-reset', 'btn-release', 'btn-record']) $(id).disabled = !owner;
  $('btn-record').hidden = !app.pageRecording;
}

function onState(s) {
  app.state = s;
  app.frames += 1;
  // Follow the server's device pose whenever the page is not the one driving it.
  if (app.role !== 'owner' || (s.source !== 1 && performance.now() - lastUserInput > 500)) {
    app.dev = s.device.slice();
  }
  const f = norm3(s.force);
  const t = norm3(s.torque);
  app.maxForceSeen = Math.max(app.maxForceSeen, f);
  $('device-pose').textContent = fmtPose(s.device);
  $('graphic-pose').textContent = fmtPose(s.graphic);
  $('force-norm').textContent = fmt(f, 3);
  $('force-vec').textContent = `(${fmt(s.force[0], 2)}, ${fmt(s.force[1], 2)}, ${fmt(s.force[2], 2)})`;
  $('torque-norm').textContent = fmt(t, 1);
  $('torque-vec').textContent = `(${fmt(s.torque[0], 1)}, ${fmt(s.torque[1], 1)}, ${fmt(s.torque[2], 1)})`;
  $('pairs').textContent = String(s.pairs);
  $('friction').textContent = s.friction_on ? FRICTION[s.friction] || String(s.friction) : 'off';
  $('btn-friction').classList.toggle('on', !!s.friction_on);
  $('penetration').textContent = fmt(s.penetration_mm, 3);
  $('frame-us').textContent = fmt(s.frame_us, 0);
  $('frame-us-max').textContent = fmt(s.frame_us_max, 0);
  $('overruns').textContent = String(s.overruns);
  $('source').textContent = SOURCES[s.source] || String(s.source);
  $('btn-record').classList.toggle('on', s.recording);
  histF[histN % HIST] = f;
  histT[histN % HIST] = s.frame_us;
  histN += 1;
  if (toolSolid) {
    setPose(toolSolid, s.graphic);
    setPose(toolGhost, s.device);
    const origin = new THREE.Vector3(s.device[0], s.device[1], s.device[2]);
    const maxF = (app.scene && app.scene.max_force) || 40;
    const reach = sceneSize * 0.45;
    arrow(forceArrow, origin, s.force, (f / maxF) * reach);
    arrow(torqueArrow, origin, s.torque, (t / (maxF * 100)) * reach);
    drawContacts(s.contacts || []);
  }
  if (!app.ready && toolSolid) app.ready = true;
}

function arrow(a, origin, v, len) {
  const n = norm3(v);
  if (n < 1e-9 || len < 0.5) { a.visible = false; return; }
  a.visible = true;
  a.position.copy(origin);
  a.setDirection(new THREE.Vector3(v[0] / n, v[1] / n, v[2] / n));
  a.setLength(len, Math.min(len * 0.3, sceneSize * 0.05), Math.min(len * 0.15, sceneSize * 0.025));
}

const m4 = new THREE.Matrix4();
function drawContacts(list) {
  const n = contactsOn ? Math.min(list.length, MAX_SPHERES) : 0;
  for (let i = 0; i < n; i++) {
    const c = list[i];
    m4.makeScale(c.tool_radius, c.tool_radius, c.tool_radius).setPosition(...c.tool_centre);
    toolSpheres.setMatrixAt(i, m4);
    m4.makeScale(c.object_radius, c.object_radius, c.object_radius).setPosition(...c.object_centre);
    objSpheres.setMatrixAt(i, m4);
  }
  toolSpheres.count = n;
  objSpheres.count = n;
  toolSpheres.instanceMatrix.needsUpdate = true;
  objSpheres.instanceMatrix.needsUpdate = true;
}

// Scrolling line plot of the last HIST samples. The vertical scale follows the 99th percentile
// (×1.25) so one descheduled frame does not flatten the rest; taller samples are clipped.
function plot(canvas, hist, color, labelId, unit) {
  const ctx = canvas.getContext('2d');
  const w = canvas.width;
  const h = canvas.height;
  ctx.fillStyle = '#111318';
  ctx.fillRect(0, 0, w, h);
  const n = Math.min(histN, HIST);
  const sorted = Array.from(hist.subarray(0, n)).sort((a, b) => a - b);
  const max = n > 0 ? sorted[n - 1] : 0;
  const p99 = n > 0 ? sorted[Math.floor((n - 1) * 0.99)] : 0;
  const top = Math.max(p99 * 1.25, 1e-6);
  ctx.strokeStyle = '#2a2f3a';
  ctx.beginPath();
  for (let k = 1; k < 4; k++) { ctx.moveTo(0, (h * k) / 4); ctx.lineTo(w, (h * k) / 4); }
  ctx.stroke();
  ctx.strokeStyle = color;
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  for (let i = 0; i < n; i++) {
    const v = Math.min(hist[(histN - n + i) % HIST], top);
    const x = (i / (HIST - 1)) * w;
    const y = h - 2 - (v / top) * (h - 6);
    if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
  }
  ctx.stroke();
  $(labelId).textContent = `p99 ${p99.toFixed(unit)}, max ${max.toFixed(unit)} (last ${(n / 60).toFixed(0)} s)`;
}

// ---------------------------------------------------------------------------------------------
// Input: keys, mouse, gamepad. Each moves app.dev; the pose is sent once per animation frame.
const keys = new Set();
const TRANSLATE = 40;  // mm/s
const ROTATE = 0.8;    // rad/s
const KEYMAP = {       // key -> [axis, sign]
  KeyA: [0, -1], KeyD: [0, 1], KeyS: [1, -1], KeyW: [1, 1], KeyQ: [2, -1], KeyE: [2, 1],
  KeyK: [3, -1], KeyI: [3, 1], KeyJ: [4, -1], KeyL: [4, 1], KeyU: [5, 1], KeyO: [5, -1],
};
let dirty = false;

window.addEventListener('keydown', (e) => {
  if (e.target && e.target.tagName === 'INPUT') return;
  if (KEYMAP[e.code]) { keys.add(e.code); e.preventDefault(); }
  else if (e.code === 'Space') { release(); e.preventDefault(); }
  else if (e.code === 'Backspace') { reset(); e.preventDefault(); }
  else if (e.code === 'KeyC') toggleContacts();
  else if (e.code === 'KeyF') toggleFriction();
});
window.addEventListener('keyup', (e) => { keys.delete(e.code); });
window.addEventListener('blur', () => keys.clear());

function speedScale(e) {
  return (e && e.shiftKey ? 4 : 1) * (e && e.altKey ? 0.25 : 1);
}
let modifiers = { shiftKey: false, altKey: false };
window.addEventListener('keydown', (e) => { modifiers = e; });
window.addEventListener('keyup', (e) => { modifiers = e; });

// Rotates the device by the world-frame rotation vector w (rad): R <- exp(w) R.
function rotateDevice(w) {
  const ang = Math.hypot(w[0], w[1], w[2]);
  if (ang < 1e-12 || !app.dev) return;
  const d = app.dev;
  const qCur = new THREE.Quaternion().setFromEuler(new THREE.Euler(d[3], d[4], d[5], 'ZYX'));
  const qInc = new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(w[0] / ang, w[1] / ang, w[2] / ang), ang);
  const e = new THREE.Euler().setFromQuaternion(qInc.multiply(qCur), 'ZYX');
  d[3] = e.x; d[4] = e.y; d[5] = e.z;
}

function moveDevice(dq) {
  if (!app.dev) return;
  for (let k = 0; k < 6; k++) app.dev[k] += dq[k];
  touched();
}

function touched() {
  lastUserInput = performance.now();
  dirty = true;
}

function applyKeys(dt) {
  if (!app.dev || keys.size === 0) return;
  const s = speedScale(modifiers);
  const dq = [0, 0, 0, 0, 0, 0];
  for (const k of keys) {
    const [axis, sign] = KEYMAP[k];
    dq[axis] += sign * (axis < 3 ? TRANSLATE : ROTATE) * s * dt;
  }
  // Translations directly; rotations about the world axes.
  moveDevice([dq[0], dq[1], dq[2], 0, 0, 0]);
  rotateDevice([dq[3], dq[4], dq[5]]);
}

// Mouse: left-drag translates in the view plane, right-drag rotates, shift/middle-drag orbits.
let drag = null;
const el = renderer.domElement;
el.addEventListener('contextmenu', (e) => e.preventDefault());
el.addEventListener('pointerdown', (e) => {
  const mode = e.button === 1 || e.shiftKey ? 'orbit' : e.button === 2 ? 'rotate' : 'move';
  drag = { mode, x: e.clientX, y: e.clientY };
  el.setPointerCapture(e.pointerId);
});
el.addEventListener('pointerup', () => { drag = null; });
el.addEventListener('pointermove', (e) => {
  if (!drag) return;
  const dx = e.clientX - drag.x;
  const dy = e.clientY - drag.y;
  drag.x = e.clientX;
  drag.y = e.clientY;
  if (drag.mode === 'orbit') {
    orbit.az -= dx * 0.005;
    orbit.el = Math.max(-1.5, Math.min(1.5, orbit.el + dy * 0.005));
    placeCamera();
    return;
  }
  const right = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0);
  const up = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 1);
  if (drag.mode === 'move') {
    // mm per pixel at the target's depth.
    const mmPerPx = (2 * orbit.dist * Math.tan((camera.fov * Math.PI) / 360)) / el.clientHeight;
    const v = right.multiplyScalar(dx * mmPerPx).add(up.multiplyScalar(-dy * mmPerPx));
    moveDevice([v.x, v.y, v.z, 0, 0, 0]);
  } else {
    // Drag right turns about the view's up axis, drag down about its right axis.
    const w = up.multiplyScalar(dx * 0.01).add(right.multiplyScalar(dy * 0.01));
    rotateDevice([w.x, w.y, w.z]);
    touched();
  }
});
el.addEventListener('wheel', (e) => {
  orbit.dist = Math.max(sceneSize * 0.2, Math.min(sceneSize * 20, orbit.dist * Math.exp(e.deltaY * 0.001)));
  placeCamera();
  e.preventDefault();
}, { passive: false });

// Gamepad API: a standard gamepad (sticks + triggers) or a 6-DoF mouse (6 axes).
function dz(v) { return Math.abs(v) < 0.12 ? 0 : v; }
function applyGamepads(dt) {
  if (!navigator.getGamepads || !app.dev) return;
  for (const gp of navigator.getGamepads()) {
    if (!gp || !gp.connected) continue;
    const a = gp.axes.map(dz);
    const dq = [0, 0, 0, 0, 0, 0];
    if (gp.mapping === 'standard') {
      const b = (i) => (gp.buttons[i] ? gp.buttons[i].value : 0);
      dq[0] = a[0] || 0; dq[1] = -(a[1] || 0);
      dq[2] = b(7) - b(6);
      dq[5] = -(a[2] || 0); dq[3] = -(a[3] || 0);
      dq[4] = b(5) - b(4);
    } else if (a.length >= 6) {
      for (let k = 0; k < 6; k++) dq[k] = a[k];
    } else continue;
    if (dq.every((v) => v === 0)) continue;
    $('source').textContent = `gamepad: ${gp.id.slice(0, 40)}`;
    moveDevice([dq[0] * TRANSLATE * dt, dq[1] * TRANSLATE * dt, dq[2] * TRANSLATE * dt, 0, 0, 0]);
    rotateDevice([dq[3] * ROTATE * dt, dq[4] * ROTATE * dt, dq[5] * ROTATE * dt]);
  }
}

// Buttons.
function toggleContacts() {
  contactsOn = !contactsOn;
  $('btn-contacts').classList.toggle('on', contactsOn);
  send({ type: 'contacts', on: contactsOn });
  if (!contactsOn) drawContacts([]);
}
function release() {
  if (app.role !== 'owner') return;
  send({ type: 'release' });
  lastUserInput = -1e9;
}
function reset() {
  if (app.role !== 'owner') return;
  send({ type: 'reset' });
  if (app.scene) app.dev = app.scene.start.slice();
  lastUserInput = -1e9;
}
function toggleFriction() {
  if (app.role !== 'owner' || !app.scene || !app.scene.friction) return;
  send({ type: 'friction', on: !(app.state && app.state.friction_on) });
}
$('btn-contacts').onclick = toggleContacts;
$('btn-friction').onclick = toggleFriction;
$('btn-reset').onclick = reset;
$('btn-release').onclick = release;
$('btn-record').onclick = () => send({ type: 'record', on: !(app.state && app.state.recording) });

window.addEventListener('resize', () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
});

// ---------------------------------------------------------------------------------------------
// Main loop.
let last = performance.now();
function frame(now) {
  const dt = Math.min(0.1, (now - last) / 1000);
  last = now;
  applyKeys(dt);
  applyGamepads(dt);
  if (dirty && app.dev && app.role === 'owner') {
    send({ type: 'pose', q: app.dev });
  }
  dirty = false;
  plot($('plot-force'), histF, '#ffd34d', 'plot-f-max', 2);
  plot($('plot-time'), histT, '#6bd0ff', 'plot-t-max', 0);
  renderer.render(scene3, camera);
  requestAnimationFrame(frame);
}

loadScene()
  .then(() => { connect(); requestAnimationFrame(frame); })
  .catch((e) => { $('notice').textContent = `cannot load the scene: ${e.message}`; app.error = String(e); });
