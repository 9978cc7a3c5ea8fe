// The live view's page (docs/render.md, Live view): draws what the server's
// /state.json says, over the static scene of /scene.json, with three.js.
// Test hook: window.graspsimView (frame drawn, waitFor(condition) which stops
// polling at the first frame drawn that meets the condition).
import * as THREE from 'three';
import { OrbitControls } from './OrbitControls.js';

// the off-screen renderer's colours (render/renderer.cpp), values as given: no colour management
THREE.ColorManagement.enabled = false;
const kColours = { object: [0.95, 0.58, 0.18], fingertip: [0.93, 0.72, 0.60], fixed: [0.55, 0.65, 0.80] };
const kStick = [20 / 255, 190 / 255, 60 / 255], kSlip = [235 / 255, 40 / 255, 30 / 255];

const canvas = document.getElementById('scene');
const hud = document.getElementById('hud');
const plotCanvas = document.getElementById('plot');
const status = document.getElementById('status');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
renderer.setClearColor(new THREE.Color(0.92, 0.94, 0.97));
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(35, 1, 0.001, 100);
const controls = new OrbitControls(camera, canvas);
controls.enableDamping = false;

const view = { frame: 0, drawn: null, frozen: false, waiters: [], fps: 0 };
window.graspsimView = view;
const bodies = [];   // { obj, geom, rest, deformable, deformed }
let arrowGroup = new THREE.Group(), fingerGroup = new THREE.Group();
scene.add(arrowGroup, fingerGroup);
const history = [];  // [t, grip_N, height_m]
let sceneInfo = null;

// splats: screen-aligned round points sized in metres, lit by a key light (as the renderer's)
function splatMaterial(rgb, size) {
  return new THREE.ShaderMaterial({
    uniforms: { colour: { value: new THREE.Vector3(...rgb) }, size: { value: size }, scale: { value: 1 } },
    vertexShader: `
      uniform float size; uniform float scale; varying vec3 vN;
      void main() {
        vN = normalize(mat3(modelMatrix) * normal);
        vec4 mv = modelViewMatrix * vec4(position, 1.0);
        gl_PointSize = max(1.0, size * scale / -mv.z);
        gl_Position = projectionMatrix * mv;
      }`,
    fragmentShader: `
      uniform vec3 colour; varying vec3 vN;
      void main() {
        vec2 c = gl_PointCoord - 0.5; if (dot(c, c) > 0.25) discard;
        float key = max(dot(normalize(vN), normalize(vec3(-0.6, 0.7, 0.9))), 0.0);
        float fill = max(dot(normalize(vN), normalize(vec3(0.8, -0.2, 0.5))), 0.0);
        gl_FragColor = vec4(colour * min(1.0, 0.45 + 0.5 * key + 0.35 * fill), 1.0);
      }`,
  });
}

function buildScene(info) {
  sceneInfo = info;
  const c = info.camera;
  camera.fov = c.fov_deg;
  camera.up.set(...c.up);
  camera.position.set(...c.position);
  controls.target.set(...c.target);
  camera.lookAt(controls.target);
  const dist = new THREE.Vector3(...c.position).distanceTo(new THREE.Vector3(...c.target));
  camera.near = dist / 100;
  camera.far = dist * 100;
  controls.update();
  info.bodies.forEach((b) => {
    const obj = new THREE.Group();
    const entry = { obj, geom: null, rest: null, deformable: b.deformable, deformed: false, kind: b.kind };
    if (b.kind === 'plane') {
      const size = dist * 4;
      const plane = new THREE.Mesh(new THREE.PlaneGeometry(size, size),
                                   new THREE.MeshBasicMaterial({ color: new THREE.Color(0.80, 0.81, 0.83) }));
      const grid = new THREE.GridHelper(size, 32, 0x9a9da5, 0xb0b3ba);
      grid.rotation.x = Math.PI / 2;
      grid.position.z = 1e-4;
      obj.add(plane, grid);
    } else {
      const rest = new Float32Array(b.points_mm.map((v) => v / 1000));
      const geom = new THREE.BufferGeometry();
      geom.setAttribute('position', new THREE.BufferAttribute(rest.slice(), 3));
      geom.setAttribute('normal', new THREE.BufferAttribute(new Float32Array(b.normals), 3));
      const points = new THREE.Points(geom, splatMaterial(kColours[b.kind] || kColours.fixed, b.splat_m));
      points.frustumCulled = false;
      obj.add(points);
      entry.geom = geom;
      entry.rest = rest;
      entry.material = points.material;
    }
    bodies.push(entry);
    scene.add(obj);
  });
  resize();
}

function resize() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(w, h, false);
  camera.aspect = w / Math.max(1, h);
  camera.updateProjectionMatrix();
  // gl_PointSize in pixels = size_m * scale / depth: scale is the pixels per metre at depth 1
  const scale = renderer.domElement.height / (2 * Math.tan((camera.fov * Math.PI) / 360));
  bodies.forEach((b) => b.material && (b.material.uniforms.scale.value = scale));
}
window.addEventListener('resize', () => { resize(); draw(); });

function arrowMesh(tail, d, slip, radius) {
  const len = Math.hypot(...d);
  const head = Math.min(0.35 * len, 6 * radius);
  const mat = new THREE.MeshBasicMaterial({ color: new THREE.Color(...(slip ? kSlip : kStick)), depthTest: false });
  const outline = new THREE.MeshBasicMaterial({ color: new THREE.Color(0.1, 0.1, 0.12), depthTest: false });
  const g = new THREE.Group();
  const add = (geom, m, y, order) => { const x = new THREE.Mesh(geom, m); x.position.y = y; x.renderOrder = order; g.add(x); };
  add(new THREE.CylinderGeometry(radius * 1.6, radius * 1.6, len - head, 10), outline, (len - head) / 2, 10);
  add(new THREE.ConeGeometry(radius * 3.6, head * 1.15, 14), outline, len - head / 2, 10);
  add(new THREE.CylinderGeometry(radius, radius, len - head, 10), mat, (len - head) / 2, 11);
  add(new THREE.ConeGeometry(radius * 2.6, head, 14), mat, len - head / 2, 11);
  g.position.set(...tail);
  g.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), new THREE.Vector3(...d).normalize());
  return g;
}

function apply(s) {
  s.bodies.forEach((st, i) => {
    const b = bodies[i];
    if (!b) return;
    b.obj.position.set(...st.p);
    b.obj.quaternion.set(st.q[1], st.q[2], st.q[3], st.q[0]);
    if (!b.geom) return;
    const pos = b.geom.attributes.position;
    if (st.u_um && st.u_um.length === b.rest.length) {
      for (let k = 0; k < b.rest.length; ++k) pos.array[k] = b.rest[k] + st.u_um[k] * 1e-6;
      pos.needsUpdate = true;
      b.deformed = true;
    } else if (b.deformed) {
      pos.array.set(b.rest);
      pos.needsUpdate = true;
      b.deformed = false;
    }
  });
  const dist = camera.position.distanceTo(controls.target);
  scene.remove(arrowGroup);
  arrowGroup.traverse((o) => o.geometry && o.geometry.dispose());
  arrowGroup = new THREE.Group();
  s.arrows.forEach((a) => arrowGroup.add(arrowMesh(a.tail, a.d, a.slip, dist * 0.0035)));
  scene.add(arrowGroup);
  scene.remove(fingerGroup);
  fingerGroup = new THREE.Group();
  s.fingers.forEach((f) => {
    const g = new THREE.BufferGeometry().setFromPoints(f.map((p) => new THREE.Vector3(...p)));
    fingerGroup.add(new THREE.Line(g, new THREE.LineBasicMaterial({ color: new THREE.Color(0.45, 0.47, 0.53) })));
  });
  scene.add(fingerGroup);
  history.push([s.t, s.grip_N, s.height_m]);
  while (history.length && history[0][0] < s.t - 10) history.shift();
  while (history.length > 1 && history[history.length - 1][0] < history[0][0]) history.shift();  // a restart
}

let frameTimes = [];
function drawHud(s) {
  const now = performance.now();
  frameTimes.push(now);
  while (frameTimes.length && frameTimes[0] < now - 1000) frameTimes.shift();
  const lines = [
    `t ${s.t.toFixed(3)} s  step ${s.step}`,
    s.step_ms >= 0 ? `step time ${s.step_ms.toFixed(3)} ms` : 'step time -',
    `contacts ${s.contacts}  sweeps ${s.iterations}`,
    `residual ${s.residual.toExponential(1)}${s.converged ? '' : ' (cap)'}`,
    `tracker ${s.tracker}`,
    `view ${frameTimes.length} frames/s`,
  ];
  hud.textContent = lines.join('\n');
}

function drawPlot() {
  const g = plotCanvas.getContext('2d');
  const W = plotCanvas.width, H = plotCanvas.height;
  g.clearRect(0, 0, W, H);
  if (history.length < 2) return;
  const t1 = history[history.length - 1][0], t0 = t1 - 10;
  const maxF = Math.max(1, ...history.map((h) => h[1]));
  const hs = history.map((h) => h[2]);
  const lo = Math.min(...hs), hi = Math.max(lo + 0.01, ...hs);
  const line = (col, f) => {
    g.strokeStyle = col;
    g.beginPath();
    history.forEach((h, i) => {
      const x = ((h[0] - t0) / 10) * W, y = H - 4 - f(h) * (H - 18);
      i ? g.lineTo(x, y) : g.moveTo(x, y);
    });
    g.stroke();
  };
  line('#c0392b', (h) => h[1] / maxF);
  line('#2c5fa8', (h) => (h[2] - lo) / (hi - lo));
  g.fillStyle = '#c0392b';
  g.fillText(`grip ${history[history.length - 1][1].toFixed(2)} N (max ${maxF.toFixed(1)})`, 4, 11);
  g.fillStyle = '#2c5fa8';
  g.fillText(`height ${(1000 * history[history.length - 1][2]).toFixed(1)} mm`, 130, 11);
}

function draw() { renderer.render(scene, camera); }
controls.addEventListener('change', draw);

function settle(s) {
  view.waiters = view.waiters.filter((w) => {
    if (!w.condition(s)) return true;
    view.frozen = true;
    w.resolve(view.drawn);
    return false;
  });
}
// resolves with the first frame drawn that meets `condition` and stops polling there (tests)
view.waitFor = (condition) => new Promise((resolve) => {
  view.waiters.push({ condition, resolve });
  if (view.drawn) settle(view.drawn);
});

function showStatus(text) {
  status.textContent = text;
  status.style.display = text ? 'block' : 'none';
}

async function poll() {
  for (;;) {
    if (view.frozen) return;
    try {
      const r = await fetch(`state.json?after=${view.frame}`, { cache: 'no-store' });
      const s = await r.json();
      showStatus('');
      if (view.frozen) return;
      if (s.frame === view.frame) continue;
      if (s.frame < view.frame) history.length = 0;  // the server restarted
      view.frame = s.frame;
      apply(s);
      draw();
      drawHud(s);
      drawPlot();
      view.drawn = { frame: s.frame, step: s.step, t: s.t, arrows: s.arrows, contacts: s.contacts,
                     width: renderer.domElement.width, height: renderer.domElement.height };
      document.title = `graspsim view: frame ${s.frame}`;
      document.body.dataset.frame = String(s.frame);
      settle(view.drawn);
      await new Promise((ok) => setTimeout(ok, 30));  // at most about 30 frames a second
    } catch (e) {
      showStatus('simulation not reachable: retrying');
      await new Promise((ok) => setTimeout(ok, 1000));
    }
  }
}

fetch('scene.json').then((r) => r.json()).then((info) => {
  buildScene(info);
  draw();
  poll();
});
