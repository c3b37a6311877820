// The browser side of `tensegrity serve`: drawing, editing the character file
// and driving the API. Every solve, design and simulation step runs in the
// server's library (docs/WEB.md); this file only shows results and sends edits.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { TransformControls } from 'three/addons/controls/TransformControls.js';

const $ = (id) => document.getElementById(id);

// Nodes that moved less than this fraction of the structure's size count as unmoved.
const MOVED_FRACTION = 1e-4;
// A cable pulling less than this fraction of the largest force is drawn slack.
const SLACK_FRACTION = 1e-6;
const STRUT_RADIUS_FRACTION = 0.006;
const NODE_RADIUS_FRACTION = 0.009;

const state = {
  info: null,
  character: null,     // the character file being edited (JSON object) or null
  scene: null,         // the scene drawn (JSON, tensegrity-scene)
  solution: null,      // last form-finding result for `scene`
  design: null,        // last stiffness design (tensegrity-design)
  sheet: null,         // its fabrication sheet (CSV)
  view: null,          // {nodes, elements, positions, forces, reference}
  undo: [],
  redo: [],
  sim: null,           // {id, running, steps, started, drag}
  selectedBlock: null,
};

// ---------------------------------------------------------------- API -------

async function api(path, body, method = 'POST') {
  const res = await fetch(path, {
    method,
    headers: body === undefined ? {} : { 'Content-Type': 'application/json' },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  const text = await res.text();
  if (!res.ok) throw new Error(text.trim());
  return JSON.parse(text);
}

function showMessage(text) { $('message').textContent = text || ''; }

// ------------------------------------------------------------- viewer -------

const viewport = $('viewport');
// Multisampling doubles the frame time of a software renderer (SwiftShader, llvmpipe).
function softwareRenderer() {
  try {
    const gl = document.createElement('canvas').getContext('webgl2');
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    return /swiftshader|llvmpipe|software/i.test(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
  } catch (err) {
    return false;
  }
}
const renderer = new THREE.WebGLRenderer({ antialias: !softwareRenderer(), preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
viewport.appendChild(renderer.domElement);
const world = new THREE.Scene();
world.background = new THREE.Color(0xf4f5f7);
const camera = new THREE.PerspectiveCamera(40, 1, 0.001, 100);
camera.up.set(0, 0, 1);
camera.position.set(0.6, -0.9, 0.5);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
world.add(new THREE.AmbientLight(0xffffff, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.8);
sun.position.set(1, -1, 2);
world.add(sun);

let structureGroup = new THREE.Group();
world.add(structureGroup);
let parts = null;  // the three.js objects of the drawn structure
// Software WebGL is slow: draw only when something changed.
let needsRender = true;

function resize() {
  const w = viewport.clientWidth, h = viewport.clientHeight;
  renderer.setSize(w, h);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
  needsRender = true;
}
window.addEventListener('resize', resize);
resize();

function forceColor(f, scale, out) {
  // Blue for compression, red for tension, grey at zero.
  const t = scale > 0 ? Math.max(-1, Math.min(1, f / scale)) : 0;
  const grey = [0.62, 0.62, 0.62];
  const end = t < 0 ? [0.12, 0.31, 0.84] : [0.82, 0.15, 0.11];
  const a = Math.abs(t);
  out.setRGB(grey[0] + a * (end[0] - grey[0]), grey[1] + a * (end[1] - grey[1]), grey[2] + a * (end[2] - grey[2]));
  return out;
}

function sizeOf(positions) {
  const box = new THREE.Box3();
  for (const p of positions) box.expandByPoint(new THREE.Vector3(p[0], p[1], p[2]));
  return { box, size: Math.max(box.getSize(new THREE.Vector3()).length(), 1e-6) };
}

// Rebuilds the three.js objects for a new topology.
function buildParts(view, frame) {
  world.remove(structureGroup);
  structureGroup = new THREE.Group();
  world.add(structureGroup);
  const { box, size } = sizeOf(view.positions);
  const struts = [], cables = [];
  view.elements.forEach((e, k) => (e.kind === 'strut' ? struts : cables).push(k));
  const strutGeometry = new THREE.CylinderGeometry(1, 1, 1, 10);
  const strutMesh = new THREE.InstancedMesh(strutGeometry, new THREE.MeshStandardMaterial({ roughness: 0.6 }), Math.max(struts.length, 1));
  strutMesh.count = struts.length;
  const cableGeometry = new THREE.BufferGeometry();
  cableGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(cables.length * 6), 3));
  cableGeometry.setAttribute('color', new THREE.BufferAttribute(new Float32Array(cables.length * 6), 3));
  const cableLines = new THREE.LineSegments(cableGeometry, new THREE.LineBasicMaterial({ vertexColors: true }));
  const slackGeometry = new THREE.BufferGeometry();
  slackGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(cables.length * 6), 3));
  const slackLines = new THREE.LineSegments(slackGeometry,
    new THREE.LineDashedMaterial({ color: 0xe09000, dashSize: size * 0.01, gapSize: size * 0.008 }));
  const nodeMesh = new THREE.InstancedMesh(new THREE.SphereGeometry(1, 12, 8), new THREE.MeshStandardMaterial(), view.nodes.length);
  const ground = new THREE.GridHelper(size * 2, 20, 0x999999, 0xcccccc);
  ground.rotation.x = Math.PI / 2;
  const fixedZ = view.nodes.map((n, i) => (n.fixed ? view.positions[i][2] : Infinity));
  const groundZ = Math.min(...fixedZ);
  ground.position.set((box.min.x + box.max.x) / 2, (box.min.y + box.max.y) / 2, Number.isFinite(groundZ) ? groundZ : box.min.z);
  const dragLine = new THREE.Line(new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3()]),
    new THREE.LineBasicMaterial({ color: 0x00a000 }));
  dragLine.visible = false;
  structureGroup.add(strutMesh, cableLines, slackLines, nodeMesh, ground, dragLine);
  parts = { struts, cables, strutMesh, cableLines, slackLines, nodeMesh, dragLine, size };
  if (frame) {
    const center = box.getCenter(new THREE.Vector3());
    controls.target.copy(center);
    camera.position.copy(center).add(new THREE.Vector3(0.55, -1.0, 0.45).multiplyScalar(size));
    camera.near = size * 1e-3;
    camera.far = size * 100;
    camera.updateProjectionMatrix();
  }
}

const tmp = { m: new THREE.Matrix4(), q: new THREE.Quaternion(), s: new THREE.Vector3(), a: new THREE.Vector3(),
  b: new THREE.Vector3(), d: new THREE.Vector3(), c: new THREE.Color(), y: new THREE.Vector3(0, 1, 0) };

// Moves and colours the drawn structure.
function updateParts() {
  const v = state.view;
  if (!v || !parts) return;
  const { struts, cables, strutMesh, cableLines, slackLines, nodeMesh, size } = parts;
  const forces = v.forces;
  const scale = forces ? Math.max(...forces.map(Math.abs), 0) : 0;
  const r = STRUT_RADIUS_FRACTION * size;
  struts.forEach((e, k) => {
    const [i, j] = v.elements[e].nodes;
    tmp.a.fromArray(v.positions[i]);
    tmp.b.fromArray(v.positions[j]);
    tmp.d.subVectors(tmp.b, tmp.a);
    const len = tmp.d.length();
    tmp.q.setFromUnitVectors(tmp.y, tmp.d.normalize());
    tmp.m.compose(tmp.a.add(tmp.b).multiplyScalar(0.5), tmp.q, tmp.s.set(r, len, r));
    strutMesh.setMatrixAt(k, tmp.m);
    strutMesh.setColorAt(k, forces ? forceColor(forces[e], scale, tmp.c) : tmp.c.set(0x555555));
  });
  strutMesh.instanceMatrix.needsUpdate = true;
  if (strutMesh.instanceColor) strutMesh.instanceColor.needsUpdate = true;
  const pos = cableLines.geometry.attributes.position, col = cableLines.geometry.attributes.color;
  const slackPos = slackLines.geometry.attributes.position;
  let taut = 0, slack = 0;
  for (const e of cables) {
    const [i, j] = v.elements[e].nodes;
    const isSlack = forces && forces[e] <= SLACK_FRACTION * scale;
    const target = isSlack ? slackPos : pos;
    const k = isSlack ? slack++ : taut++;
    target.setXYZ(2 * k, ...v.positions[i]);
    target.setXYZ(2 * k + 1, ...v.positions[j]);
    if (!isSlack) {
      const c = forces ? forceColor(forces[e], scale, tmp.c) : tmp.c.set(0x888888);
      col.setXYZ(2 * k, c.r, c.g, c.b);
      col.setXYZ(2 * k + 1, c.r, c.g, c.b);
    }
  }
  cableLines.geometry.setDrawRange(0, 2 * taut);
  slackLines.geometry.setDrawRange(0, 2 * slack);
  pos.needsUpdate = col.needsUpdate = slackPos.needsUpdate = true;
  slackLines.computeLineDistances();
  const rn = NODE_RADIUS_FRACTION * size;
  const moved = movedNodes();
  v.positions.forEach((p, i) => {
    tmp.m.compose(tmp.a.fromArray(p), tmp.q.identity(), tmp.s.set(rn, rn, rn));
    nodeMesh.setMatrixAt(i, tmp.m);
    nodeMesh.setColorAt(i, tmp.c.set(v.nodes[i].fixed ? 0x111111 : moved.has(i) ? 0xff8c00 : 0xbbbbbb));
  });
  nodeMesh.instanceMatrix.needsUpdate = true;
  if (nodeMesh.instanceColor) nodeMesh.instanceColor.needsUpdate = true;
  nodeMesh.computeBoundingSphere();
  $('colorbar-min').textContent = forces ? (-scale).toPrecision(3) : '–';
  $('colorbar-max').textContent = forces ? scale.toPrecision(3) : '–';
  $('stats').textContent = statsText(slack);
  needsRender = true;
}

function movedNodes() {
  const v = state.view, moved = new Set();
  if (!v.reference || !parts) return moved;
  v.positions.forEach((p, i) => {
    const q = v.reference[i];
    if (Math.hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]) > MOVED_FRACTION * parts.size) moved.add(i);
  });
  return moved;
}

function statsText(slack) {
  const v = state.view;
  const struts = v.elements.filter((e) => e.kind === 'strut').length;
  const lines = [`${v.nodes.length} nodes (${v.nodes.filter((n) => n.fixed).length} fixed), ${struts} struts, ` +
    `${v.elements.length - struts} cables` + (v.forces ? `, ${slack} slack` : '')];
  if (v.reference) lines.push(`moved nodes: ${movedNodes().size}`);
  return lines.join('\n');
}

function setView(view, frame) {
  const topologyChanged = !state.view || state.view.nodes.length !== view.nodes.length ||
    state.view.elements.length !== view.elements.length;
  state.view = view;
  if (topologyChanged || frame) buildParts(view, frame || topologyChanged);
  updateParts();
}

function viewOfScene(scene, positions, forces, reference) {
  return { nodes: scene.nodes, elements: scene.elements, positions: positions || scene.nodes.map((n) => n.x),
    forces: forces || null, reference: reference || null };
}

function setStatus(text) { $('status-line').textContent = text; }

controls.addEventListener('change', () => { needsRender = true; });
function animate() {
  requestAnimationFrame(animate);
  if (!needsRender) return;
  needsRender = false;
  renderer.render(world, camera);
}
animate();

// ---------------------------------------------------------- character -------

function blockIds() { return state.character ? state.character.blocks.map((b) => b.id) : []; }
function blockById(id) { return state.character.blocks.find((b) => b.id === id); }

function emptyCharacter() {
  return { format: 'tensegrity-character', version: 1, name: 'untitled', gravity: [0, 0, -9.81],
    strut_density: 0.03, cable_density: 0.002, blocks: [], links: [], ground: [] };
}

// Every edit goes through here: undo history, the file view, a rebuild.
async function editCharacter(change) {
  const before = JSON.stringify(state.character);
  const next = JSON.parse(before);
  change(next);
  state.undo.push(before);
  state.redo = [];
  state.character = next;
  await characterChanged();
}

let buildRequests = 0;

async function characterChanged(frame = false) {
  $('character-json').value = JSON.stringify(state.character, null, 2);
  refreshEditor();
  state.solution = null;
  state.design = null;
  $('simulate').disabled = true;
  if (!state.character.blocks.length) {
    setStatus('empty character: add a block');
    return;
  }
  const request = ++buildRequests;
  try {
    const built = await api('/api/build', state.character);
    if (request !== buildRequests) return;  // a later edit's build supersedes this one
    state.scene = built.scene;
    const c = built.counts;
    setStatus(`built ${state.character.name}: ${c.blocks} blocks, ${c.face_links} face links, ` +
      `${c.edge_links} edge links, mass ${c.mass.toPrecision(3)} kg (not form-found)`);
    setView(viewOfScene(built.scene), frame);
    drawPicks();
    showMessage('');
    if (state.info.writes_character) {
      await api('/api/character', state.character, 'PUT');
      setStatus(`${$('status-line').textContent}; saved to ${state.info.initial.file}`);
    }
  } catch (err) {
    if (request !== buildRequests) return;
    setStatus('the character does not build');
    showMessage(err.message);
  }
}

function uniqueId(base) {
  const ids = new Set(blockIds());
  for (let k = 1; ; ++k) if (!ids.has(`${base}-${k}`)) return `${base}-${k}`;
}

function optionList(select, values, selected) {
  select.replaceChildren(...values.map(([value, label]) => new Option(label, value, false, value === selected)));
}

function refreshEditor() {
  const ids = blockIds();
  if (!ids.includes(state.selectedBlock)) state.selectedBlock = ids[ids.length - 1] || null;
  optionList($('block-select'), ids.map((id) => [id, id]), state.selectedBlock);
  const b = state.selectedBlock ? blockById(state.selectedBlock) : null;
  const t = b ? (b.translation || [0, 0, 0]) : [0, 0, 0], r = b ? (b.rotation_deg || [0, 0, 0]) : [0, 0, 0];
  $('bt-scale').value = b ? (b.scale ?? 1) : '';
  ['tx', 'ty', 'tz'].forEach((k, i) => { $(`bt-${k}`).value = b ? t[i] : ''; });
  ['rx', 'ry', 'rz'].forEach((k, i) => { $(`bt-${k}`).value = b ? r[i] : ''; });
  const g = b && state.character.ground.find((x) => x.block === b.id);
  $('bt-ground').checked = !!g;
  if (g && g.lowest) $('bt-ground-n').value = g.lowest;
  for (const side of ['a', 'b']) {
    const sel = $(`link-${side}-block`);
    const keep = ids.includes(sel.value) ? sel.value : ids[side === 'a' ? 0 : Math.min(1, ids.length - 1)];
    optionList(sel, ids.map((id) => [id, id]), keep);
    refreshLinkParts(side);
  }
  const links = state.character ? state.character.links : [];
  optionList($('link-select'), links.map((l) => [l.id, `${l.id} (${l.type})`]), $('link-select').value);
  placeGizmo();
}

function refreshLinkParts(side) {
  const id = $(`link-${side}-block`).value;
  const type = $('link-type').value;
  const b = id && blockById(id);
  const lib = b && state.info.blocks[b.type];
  const keep = $(`link-${side}-part`).value;
  if (!lib) return optionList($(`link-${side}-part`), [], null);
  if (type === 'face') optionList($(`link-${side}-part`), [['', 'face toward the other block'], ...lib.faces.map((f) => [f, `face ${f}`])], keep);
  else optionList($(`link-${side}-part`), lib.cables.map((c) => [c, `cable ${c}`]), keep);
}

function readTransform(b) {
  const num = (id) => Number($(id).value);
  b.scale = num('bt-scale');
  b.translation = ['bt-tx', 'bt-ty', 'bt-tz'].map(num);
  b.rotation_deg = ['bt-rx', 'bt-ry', 'bt-rz'].map(num);
}

function wireEditor() {
  optionList($('block-type'), Object.keys(state.info.blocks).map((n) => [n, n]), 'prism-3');
  $('add-block').onclick = () => editCharacter((c) => {
    const type = $('block-type').value;
    const id = uniqueId(type);
    const k = c.blocks.length;
    c.blocks.push({ id, type, scale: 0.05, translation: [0.12 * k, 0, 0.05], rotation_deg: [0, 0, 0] });
    if (!c.ground.length) c.ground.push({ block: id, lowest: 3 });
    state.selectedBlock = id;
  });
  $('delete-block').onclick = () => state.selectedBlock && editCharacter((c) => {
    const id = state.selectedBlock;
    c.blocks = c.blocks.filter((b) => b.id !== id);
    c.links = c.links.filter((l) => l.a.block !== id && l.b.block !== id);
    c.ground = c.ground.filter((g) => g.block !== id);
  });
  $('block-select').onchange = () => { state.selectedBlock = $('block-select').value; refreshEditor(); };
  $('gizmo-mode').onchange = placeGizmo;
  for (const id of ['bt-scale', 'bt-tx', 'bt-ty', 'bt-tz', 'bt-rx', 'bt-ry', 'bt-rz'])
    $(id).onchange = () => state.selectedBlock && editCharacter((c) => readTransform(c.blocks.find((b) => b.id === state.selectedBlock)));
  const groundChange = () => state.selectedBlock && editCharacter((c) => {
    c.ground = c.ground.filter((g) => g.block !== state.selectedBlock);
    if ($('bt-ground').checked) c.ground.push({ block: state.selectedBlock, lowest: Number($('bt-ground-n').value) });
  });
  $('bt-ground').onchange = groundChange;
  $('bt-ground-n').onchange = groundChange;
  $('link-type').onchange = () => { refreshLinkParts('a'); refreshLinkParts('b'); drawPicks(); };
  $('link-a-block').onchange = () => { refreshLinkParts('a'); drawPicks(); };
  $('link-b-block').onchange = () => { refreshLinkParts('b'); drawPicks(); };
  $('link-a-part').onchange = drawPicks;
  $('link-b-part').onchange = drawPicks;
  $('add-link').onclick = () => {
    const a = $('link-a-block').value, b = $('link-b-block').value;
    if (!a || !b || a === b) return showMessage('pick two different blocks to link');
    const type = $('link-type').value;
    const end = (side, block) => {
      const part = $(`link-${side}-part`).value;
      return part ? { block, [type === 'face' ? 'face' : 'cable']: part } : { block };
    };
    editCharacter((c) => {
      const ids = new Set(c.links.map((l) => l.id));
      let id = `${a}-${b}`;
      for (let k = 2; ids.has(id); ++k) id = `${a}-${b}-${k}`;
      c.links.push({ id, type, a: end('a', a), b: end('b', b) });
    });
  };
  $('delete-link').onclick = () => {
    const id = $('link-select').value;
    if (id) editCharacter((c) => { c.links = c.links.filter((l) => l.id !== id); });
  };
  $('undo').onclick = () => {
    if (!state.undo.length) return;
    state.redo.push(JSON.stringify(state.character));
    state.character = JSON.parse(state.undo.pop());
    characterChanged();
  };
  $('redo').onclick = () => {
    if (!state.redo.length) return;
    state.undo.push(JSON.stringify(state.character));
    state.character = JSON.parse(state.redo.pop());
    characterChanged();
  };
  $('new-character').onclick = () => editCharacter((c) => Object.assign(c, emptyCharacter()));
  $('apply-json').onclick = () => {
    let parsed;
    try { parsed = JSON.parse($('character-json').value); } catch (err) { return showMessage(`character file: ${err.message}`); }
    editCharacter((c) => { for (const k of Object.keys(c)) delete c[k]; Object.assign(c, parsed); });
  };
}

// The move/rotate/scale handle of the selected block: its translation,
// rotation R = Rz Ry Rx (three.js Euler order 'ZYX') and uniform scale.
const gizmo = new TransformControls(camera, renderer.domElement);
const gizmoTarget = new THREE.Object3D();
world.add(gizmoTarget, gizmo.getHelper());
gizmo.addEventListener('change', () => { needsRender = true; });
gizmo.addEventListener('dragging-changed', (ev) => {
  controls.enabled = !ev.value;
  if (!ev.value) applyGizmo();
});
const round = (x, digits) => Number(x.toFixed(digits));

function placeGizmo() {
  const b = state.selectedBlock && !state.sim && state.character && blockById(state.selectedBlock);
  const mode = $('gizmo-mode').value;
  if (!b || mode === 'off') {
    gizmo.detach();
    needsRender = true;
    return;
  }
  gizmoTarget.position.fromArray(b.translation || [0, 0, 0]);
  const r = (b.rotation_deg || [0, 0, 0]).map(THREE.MathUtils.degToRad);
  gizmoTarget.rotation.set(r[0], r[1], r[2], 'ZYX');
  const scale = b.scale ?? 1;
  gizmoTarget.scale.set(scale, scale, scale);
  gizmo.setMode(mode);
  gizmo.attach(gizmoTarget);
  needsRender = true;
}

function applyGizmo() {
  const id = state.selectedBlock;
  if (!id) return;
  const e = new THREE.Euler().setFromQuaternion(gizmoTarget.quaternion, 'ZYX');
  const s = gizmoTarget.scale;
  editCharacter((c) => {
    const b = c.blocks.find((x) => x.id === id);
    b.translation = gizmoTarget.position.toArray().map((x) => round(x, 4));
    b.rotation_deg = [e.x, e.y, e.z].map((x) => round(THREE.MathUtils.radToDeg(x), 1));
    b.scale = round(Math.cbrt(Math.abs(s.x * s.y * s.z)), 5);  // uniform: the mean of a free scaling
  });
}

// ------------------------------------------------------- form finding -------

async function formFind() {
  if (!state.scene) return showMessage('nothing to form-find');
  const solver = $('solver').value;
  const limit = state.info.time_limit;
  const started = performance.now();
  $('solve').disabled = true;
  const timer = setInterval(() => {
    const s = (performance.now() - started) / 1000;
    $('solve-progress').value = Math.min(s / limit, 1);
    $('solve-result').textContent = `${solver}: running ${s.toFixed(1)} s (limit ${limit} s)`;
  }, 100);
  try {
    const sol = await api('/api/solve', { scene: state.scene, solver });
    state.solution = sol;
    const st = sol.stats;
    $('solve-result').textContent = `${sol.solver}: ${sol.status}, ${st.iterations} iterations, ${st.seconds.toPrecision(3)} s\n` +
      `relative residual ${st.relative_residual.toExponential(2)}, geometry change ${st.geometry_change.toPrecision(3)} m`;
    setStatus(`form finding: ${sol.status}, relative residual ${st.relative_residual.toExponential(2)}, ` +
      `geometry change ${st.geometry_change.toPrecision(3)} m`);
    setView(viewOfScene(state.scene, sol.positions, sol.forces, state.scene.nodes.map((n) => n.x)));
    showMessage('');
  } catch (err) {
    showMessage(err.message);
  } finally {
    clearInterval(timer);
    $('solve-progress').value = 1;
    $('solve').disabled = false;
  }
}

// ------------------------------------------------- design, simulation -------

async function makeDesign() {
  // The form-found geometry when there is one, so the server does not solve again.
  let input = state.character || state.scene;
  if (state.solution && state.solution.status === 'converged') {
    input = JSON.parse(JSON.stringify(state.scene));
    input.nodes.forEach((n, i) => { n.x = state.solution.positions[i]; });
  }
  if (!input) return showMessage('nothing to design');
  $('design-result').textContent = 'designing…';
  try {
    const r = await api('/api/design', { input, material: $('material').value, strain: Number($('strain').value),
      solver: $('solver').value });
    state.design = r.design;
    state.sheet = r.sheet;
    const d = r.design;
    $('design-result').textContent = `cable strain ${(100 * r.strain_range[0]).toFixed(1)}–${(100 * r.strain_range[1]).toFixed(1)} %`;
    setStatus(`design: relative residual ${d.stats.relative_residual.toExponential(2)}`);
    setView(viewOfScene(d, d.positions, d.forces, null));
    $('simulate').disabled = false;
    showMessage('');
  } catch (err) {
    $('design-result').textContent = 'no design';
    showMessage(err.message);
  }
}

async function startSimulation() {
  await stopSimulation();
  const d = state.design;
  const r = await api('/api/simulation', { design: d, damping: Number($('damping').value) });
  state.sim = { id: r.id, running: true, steps: 0, requests: 0, started: performance.now(), drag: null, rate: 0,
    requestRate: 0, window: [], dt: r.dt, stepSeconds: 0 };
  setView(viewOfScene(d, r.positions, r.forces, d.positions));
  placeGizmo();
  $('stop').disabled = false;
  simulationLoop(state.sim);
}

async function stopSimulation() {
  const sim = state.sim;
  if (!sim) return;
  sim.running = false;
  state.sim = null;
  $('stop').disabled = true;
  try { await api(`/api/simulation/${sim.id}`, undefined, 'DELETE'); } catch (err) { /* already gone */ }
}

// Real time: each request asks for the steps due since the last one (at most
// MAX_CATCH_UP, half a second), so simulated time keeps up with the clock however slowly the
// page draws. Otherwise one step per request, as fast as the server answers.
const MAX_CATCH_UP = 30;
async function simulationLoop(sim) {
  while (sim.running) {
    let steps = 1;
    if ($('realtime').checked) {
      const due = Math.floor((performance.now() - sim.started) / (1000 * sim.dt)) - sim.steps;
      if (due < 1) {
        await new Promise((resolve) => setTimeout(resolve, sim.started + 1000 * sim.dt * (sim.steps + 1) - performance.now()));
        continue;
      }
      steps = Math.min(due, MAX_CATCH_UP);
      if (due > MAX_CATCH_UP) sim.started += 1000 * sim.dt * (due - MAX_CATCH_UP);  // fall behind, do not pile up
    }
    const drags = sim.drag ? [{ node: sim.drag.node, target: sim.drag.target }] : [];
    let r;
    try {
      r = await api(`/api/simulation/${sim.id}/step`, { steps, drags });
    } catch (err) {
      showMessage(err.message);
      sim.running = false;
      break;
    }
    if (!sim.running) break;
    sim.steps += steps;
    sim.requests += 1;
    sim.stepSeconds += r.step_seconds;
    // Steps and answers per second over the last second.
    const now = performance.now();
    sim.window.push([now, sim.steps, sim.requests]);
    while (sim.window.length > 2 && now - sim.window[0][0] > 1000) sim.window.shift();
    const [t0, s0, q0] = sim.window[0];
    sim.rate = now > t0 ? (sim.steps - s0) / ((now - t0) / 1000) : 0;
    sim.requestRate = now > t0 ? (sim.requests - q0) / ((now - t0) / 1000) : 0;
    state.view.positions = r.positions;
    state.view.forces = r.forces;
    updateParts();
    if (sim.drag && parts) {
      const g = parts.dragLine.geometry.attributes.position;
      g.setXYZ(0, ...r.positions[sim.drag.node]);
      g.setXYZ(1, ...sim.drag.target);
      g.needsUpdate = true;
    }
    $('sim-result').textContent = `t = ${r.time.toFixed(2)} s, ${sim.steps} steps, ${sim.rate.toFixed(1)} steps/s ` +
      `(${sim.requestRate.toFixed(1)} answers/s), ` +
      `${(1000 * sim.stepSeconds / sim.steps).toFixed(2)} ms solver time per step, ` +
      `largest displacement ${(1000 * r.max_displacement).toFixed(1)} mm` + (r.not_converged ? ' (Newton not converged)' : '');
  }
}

// Shift-click on a node picks a link end: its block and the first face (or
// cable) of the block through that node; shift-clicking the same node again
// cycles through the others. Ends a and b alternate.
let lastPick = null;
function pickLinkEnd(block, blockNode) {
  const type = $('link-type').value;
  const lib = state.info.blocks[blockById(block).type];
  const through = Object.entries(type === 'face' ? lib.face_nodes : lib.cable_nodes)
    .filter(([, nodes]) => nodes.includes(blockNode)).map(([name]) => name);
  const again = lastPick && lastPick.block === block && lastPick.node === blockNode;
  const side = again ? lastPick.side : lastPick && lastPick.side === 'a' ? 'b' : 'a';
  $(`link-${side}-block`).value = block;
  refreshLinkParts(side);
  const current = again ? $(`link-${side}-part`).value : null;
  const part = through.length ? through[(through.indexOf(current) + 1) % through.length] : '';
  $(`link-${side}-part`).value = part;
  lastPick = { block, node: blockNode, side };
  showMessage('');
}

// The chosen link ends, drawn as translucent triangles (faces) or thick lines (cables).
let pickGroup = new THREE.Group();
world.add(pickGroup);
function drawPicks() {
  world.remove(pickGroup);
  pickGroup = new THREE.Group();
  world.add(pickGroup);
  const v = state.view;
  if (!v || !state.character) return;
  const type = $('link-type').value;
  for (const [side, color] of [['a', 0x00b050], ['b', 0xb000b0]]) {
    const block = $(`link-${side}-block`).value, part = $(`link-${side}-part`).value;
    const b = block && blockById(block);
    if (!b || !part) continue;
    const lib = state.info.blocks[b.type];
    const local = (type === 'face' ? lib.face_nodes : lib.cable_nodes)[part];
    if (!local) continue;
    const points = local.map((k) => v.nodes.findIndex((n) => n.block === block && n.block_node === k))
      .filter((i) => i >= 0).map((i) => new THREE.Vector3().fromArray(v.positions[i]));
    if (points.length !== local.length) continue;
    const geometry = new THREE.BufferGeometry().setFromPoints(points);
    pickGroup.add(type === 'face'
      ? new THREE.Mesh(geometry, new THREE.MeshBasicMaterial({ color, transparent: true, opacity: 0.45, side: THREE.DoubleSide }))
      : new THREE.Line(geometry, new THREE.LineBasicMaterial({ color })));
  }
  needsRender = true;
}

// Dragging: a spring from the picked node to the pointer on the plane through
// the node facing the camera.
const raycaster = new THREE.Raycaster();
const pointer = new THREE.Vector2();
function pointerRay(ev) {
  const rect = renderer.domElement.getBoundingClientRect();
  pointer.set(((ev.clientX - rect.left) / rect.width) * 2 - 1, -((ev.clientY - rect.top) / rect.height) * 2 + 1);
  raycaster.setFromCamera(pointer, camera);
}
renderer.domElement.addEventListener('pointerdown', (ev) => {
  if (!parts || gizmo.dragging || gizmo.axis) return;  // the handle's own drag
  pointerRay(ev);
  const hit = raycaster.intersectObject(parts.nodeMesh)[0];
  if (!hit) return;
  const node = hit.instanceId;
  if (!state.sim) {
    const { block, block_node: blockNode } = state.view.nodes[node];
    if (block !== undefined && state.character && blockIds().includes(block)) {
      if (ev.shiftKey) pickLinkEnd(block, blockNode);
      state.selectedBlock = block;
      refreshEditor();
      drawPicks();
    }
    return;
  }
  if (state.view.nodes[node].fixed) return;
  controls.enabled = false;
  const p = new THREE.Vector3().fromArray(state.view.positions[node]);
  const normal = camera.getWorldDirection(new THREE.Vector3());
  state.sim.drag = { node, target: p.toArray(), plane: new THREE.Plane().setFromNormalAndCoplanarPoint(normal, p) };
  parts.dragLine.visible = true;
  renderer.domElement.setPointerCapture(ev.pointerId);
});
renderer.domElement.addEventListener('pointermove', (ev) => {
  const drag = state.sim && state.sim.drag;
  if (!drag) return;
  pointerRay(ev);
  const q = raycaster.ray.intersectPlane(drag.plane, new THREE.Vector3());
  if (q) drag.target = q.toArray();
});
renderer.domElement.addEventListener('pointerup', () => {
  if (state.sim) state.sim.drag = null;
  if (parts) parts.dragLine.visible = false;
  controls.enabled = true;
});

// ------------------------------------------------------------- export -------

function download(name, text, type) {
  const a = document.createElement('a');
  a.href = typeof text === 'string' && text.startsWith('data:') ? text : URL.createObjectURL(new Blob([text], { type }));
  a.download = name;
  a.click();
}

function wireExport() {
  const base = () => (state.character ? state.character.name : state.scene ? state.scene.name : 'tensegrity');
  const exporters = {
    character: () => state.character && download(`${base()}.character.json`, JSON.stringify(state.character, null, 2), 'application/json'),
    scene: () => state.scene && download(`${base()}.scene.json`, JSON.stringify(state.scene, null, 2), 'application/json'),
    solution: () => state.solution && download(`${base()}.solution.json`, JSON.stringify(state.solution, null, 2), 'application/json'),
    design: () => state.design && download(`${base()}.design.json`, JSON.stringify(state.design, null, 2), 'application/json'),
    sheet: () => state.sheet && download(`${base()}.sheet.csv`, state.sheet, 'text/csv'),
    png: () => download(`${base()}.png`, renderer.domElement.toDataURL('image/png')),
  };
  document.querySelectorAll('[data-export]').forEach((b) => {
    b.onclick = () => { if (!exporters[b.dataset.export]()) showMessage(`nothing to export as ${b.dataset.export} yet`); };
  });
}

// --------------------------------------------------------------- start -------

async function start() {
  state.info = await api('/api/info', undefined, 'GET');
  optionList($('solver'), state.info.solvers.map((s) => [s, s]), state.info.default_solver);
  optionList($('material'), state.info.materials.map((m) => [m, m]), state.info.default_material);
  wireEditor();
  wireExport();
  $('solve').onclick = formFind;
  $('design').onclick = makeDesign;
  $('simulate').onclick = () => startSimulation().catch((err) => showMessage(err.message));
  $('stop').onclick = stopSimulation;
  const initial = state.info.initial;
  if (initial.kind === 'character') {
    state.character = initial.json;
    await characterChanged(true);
  } else if (initial.kind === 'scene') {
    state.scene = initial.json;
    setView(viewOfScene(state.scene), true);
    setStatus(`scene ${initial.file} (not form-found)`);
  } else if (initial.kind === 'design') {
    const d = initial.json;
    state.design = d;
    state.scene = d;
    setView(viewOfScene(d, d.positions, d.forces), true);
    setStatus(`design ${initial.file}: relative residual ${d.stats.relative_residual.toExponential(2)}`);
    $('simulate').disabled = false;
  } else {
    state.character = emptyCharacter();
    await characterChanged(true);
  }
  refreshEditor();
  document.body.dataset.ready = 'true';
}

// Read-only hooks for the browser test: where a node is drawn on screen.
window.tensegrityApp = {
  state,
  updateParts,
  render: () => { renderer.render(world, camera); renderer.getContext().finish(); },
  nodeScreenPosition(i) { return this.screenPosition(state.view.positions[i]); },
  screenPosition(point) {
    const p = new THREE.Vector3().fromArray(point).project(camera);
    const rect = renderer.domElement.getBoundingClientRect();
    return { x: rect.left + (p.x + 1) / 2 * rect.width, y: rect.top + (1 - p.y) / 2 * rect.height };
  },
};

start().catch((err) => { setStatus('the app failed to start'); showMessage(err.message); });
