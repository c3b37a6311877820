// The 3-D view: three.js renderer, camera and orbit controls, and the drawn
// structure (struts, cables coloured by force, slack cables, nodes, ground).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

import { $, state } from './common.js';

// Nodes that moved less than this fraction of the structure's size count as unmoved.
const MOVED_FRACTION = 1e-4;
// A cable pulling less than this fraction of the largest force is drawn slack.
const SLACK_FRACTION = 1e-6;
const STRUT_RADIUS_FRACTION = 0.006;
const NODE_RADIUS_FRACTION = 0.009;

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
export const renderer = new THREE.WebGLRenderer({ antialias: !softwareRenderer(), preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
viewport.appendChild(renderer.domElement);
export const world = new THREE.Scene();
world.background = new THREE.Color(0xf4f5f7);
export const camera = new THREE.PerspectiveCamera(40, 1, 0.001, 100);
camera.up.set(0, 0, 1);
camera.position.set(0.6, -0.9, 0.5);
export const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
world.add(new THREE.AmbientLight(0xffffff, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.8);
sun.position.set(1, -1, 2);
world.add(sun);

let structureGroup = new THREE.Group();
world.add(structureGroup);
export let parts = null;  // the three.js objects of the drawn structure
// Software WebGL is slow: draw only when something changed.
let needsRender = true;

// Asks for a new frame at the next animation frame.
export function requestRender() { needsRender = true; }

function resize() {
  const w = viewport.clientWidth, h = viewport.clientHeight;
  renderer.setSize(w, h);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
  requestRender();
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
export function updateParts() {
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
  requestRender();
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

export function setView(view, frame) {
  const topologyChanged = !state.view || state.view.nodes.length !== view.nodes.length ||
    state.view.elements.length !== view.elements.length;
  state.view = view;
  if (topologyChanged || frame) buildParts(view, frame || topologyChanged);
  updateParts();
}

export function viewOfScene(scene, positions, forces, reference) {
  return { nodes: scene.nodes, elements: scene.elements, positions: positions || scene.nodes.map((n) => n.x),
    forces: forces || null, reference: reference || null };
}

controls.addEventListener('change', () => { requestRender(); });
function animate() {
  requestAnimationFrame(animate);
  if (!needsRender) return;
  needsRender = false;
  renderer.render(world, camera);
}
animate();
