// Editing the character file: blocks, their transforms (fields and the
// move/rotate/scale handle), links (fields and shift-click picks), undo and
// redo; every edit is rebuilt by the server.
import * as THREE from 'three';
import { TransformControls } from 'three/addons/controls/TransformControls.js';

import { $, api, setStatus, showMessage, state } from './common.js';
import { camera, controls, renderer, requestRender, setView, viewOfScene, world } from './viewer.js';

export function blockIds() { return state.character ? state.character.blocks.map((b) => b.id) : []; }
function blockById(id) { return state.character.blocks.find((b) => b.id === id); }

export function emptyCharacter() {
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

export async function characterChanged(frame = false) {
  $('character-json').value = JSON.stringify(state.character, null, 2);
  $('suggestions').replaceChildren();  // ranked for the character before the edit
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

export function optionList(select, values, selected) {
  select.replaceChildren(...values.map(([value, label]) => new Option(label, value, false, value === selected)));
}

export function refreshEditor() {
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

export function wireEditor() {
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
    addLink(type, end('a', a), end('b', b));
  };
  $('suggest-link').onclick = suggestLinks;
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

function addLink(type, endA, endB) {
  return editCharacter((c) => {
    const ids = new Set(c.links.map((l) => l.id));
    let id = `${endA.block}-${endB.block}`;
    for (let k = 2; ids.has(id); ++k) id = `${endA.block}-${endB.block}-${k}`;
    c.links.push({ id, type, a: endA, b: endB });
  });
}

// The links between the two chosen blocks, ranked by the server as
// `tensegrity suggest-link` ranks them; a row shows its ends, Apply adds it.
let suggestRequests = 0;
async function suggestLinks() {
  const a = $('link-a-block').value, b = $('link-b-block').value;
  if (!a || !b || a === b) return showMessage('pick two different blocks to link');
  const want = $('suggest-want').value;
  const axis = { x: [1, 0, 0], y: [0, 1, 0], z: [0, 0, 1] }[want];
  const body = { character: state.character, a, b, range: Number($('suggest-range').value),
    ...(axis ? { axis } : { stiff: true }) };
  const request = ++suggestRequests;
  $('suggestions').replaceChildren();
  setStatus(`ranking the links between ${a} and ${b}...`);
  try {
    const ranking = await api('/api/suggest-link', body);
    if (request !== suggestRequests) return;
    showSuggestions(ranking, !axis);
    setStatus(`${ranking.candidates.length} links between ${a} and ${b} ranked (${axis ? `hinge about ${want}` : 'stiffest'})`);
    showMessage('');
  } catch (err) {
    if (request !== suggestRequests) return;
    setStatus('no link suggestions');
    showMessage(err.message);
  }
}

function showSuggestions(ranking, stiff) {
  const cell = (tag, text) => Object.assign(document.createElement(tag), { textContent: text });
  const row = (tag, texts) => {
    const tr = document.createElement('tr');
    tr.append(...texts.map((t) => cell(tag, t)));
    return tr;
  };
  const head = document.createElement('thead');
  head.append(row('th', ['#', 'type', ranking.a, ranking.b, ...(stiff ? ['k_min', ''] : ['k_axis', 'k_perp']), '']));
  const rows = document.createElement('tbody');
  const k = (x) => x.toPrecision(4);
  ranking.candidates.forEach((c, i) => {
    const figures = !c.measured ? [c.status, ''] : stiff ? [k(c.principal_stiffness[0]), ''] : [k(c.about_axis), k(c.perpendicular)];
    const tr = row('td', [String(i + 1), c.type, c.a, c.b, ...figures]);
    const apply = cell('button', 'Apply');
    apply.className = 'apply-suggestion';
    apply.disabled = !c.measured;
    apply.onclick = (ev) => { ev.stopPropagation(); addLink(c.link.type, c.link.a, c.link.b); };
    tr.append(Object.assign(document.createElement('td'), { className: 'apply' }));
    tr.lastChild.append(apply);
    tr.onclick = () => showLinkEnds(c.link);
    rows.append(tr);
  });
  $('suggestions').replaceChildren(head, rows);
  $('suggestions').title = `rotational stiffness in ${ranking.units}`;
}

// The ends of `link` in the link fields, drawn on the blocks.
function showLinkEnds(link) {
  $('link-type').value = link.type;
  for (const side of ['a', 'b']) {
    $(`link-${side}-block`).value = link[side].block;
    refreshLinkParts(side);
    $(`link-${side}-part`).value = link[side][link.type === 'face' ? 'face' : 'cable'];
  }
  drawPicks();
}

// The move/rotate/scale handle of the selected block: its translation,
// rotation R = Rz Ry Rx (three.js Euler order 'ZYX') and uniform scale.
export const gizmo = new TransformControls(camera, renderer.domElement);
const gizmoTarget = new THREE.Object3D();
world.add(gizmoTarget, gizmo.getHelper());
gizmo.addEventListener('change', () => { requestRender(); });
gizmo.addEventListener('dragging-changed', (ev) => {
  controls.enabled = !ev.value;
  if (!ev.value) applyGizmo();
});
const round = (x, digits) => Number(x.toFixed(digits));

export function placeGizmo() {
  const b = state.selectedBlock && !state.sim && state.character && blockById(state.selectedBlock);
  const mode = $('gizmo-mode').value;
  if (!b || mode === 'off') {
    gizmo.detach();
    requestRender();
    return;
  }
  gizmoTarget.position.fromArray(b.translation || [0, 0, 0]);
  const r = (b.rotation_deg || [0, 0, 0]).map(THREE.MathUtils.degToRad);
  gizmoTarget.rotation.set(r[0], r[1], r[2], 'ZYX');
  const scale = b.scale ?? 1;
  gizmoTarget.scale.set(scale, scale, scale);
  gizmo.setMode(mode);
  gizmo.attach(gizmoTarget);
  requestRender();
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

// Shift-click on a node picks a link end: its block and the first face (or
// cable) of the block through that node; shift-clicking the same node again
// cycles through the others. Ends a and b alternate.
let lastPick = null;
export function pickLinkEnd(block, blockNode) {
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
export function drawPicks() {
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
  requestRender();
}
