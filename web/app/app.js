// The browser side of `tensegrity serve`: drawing, editing the character file
// and driving the API. Every solve, design and simulation step runs in the
// server's library (docs/WEB.md); the page only shows results and sends edits.
// This module starts the app; common.js (state, API), viewer.js (3-D view),
// editor.js (character editing) and simulation.js (form finding, design,
// simulation, dragging) hold the rest.
import * as THREE from 'three';

import { $, api, setStatus, showMessage, state } from './common.js';
import { characterChanged, emptyCharacter, optionList, refreshEditor, wireEditor } from './editor.js';
import { formFind, makeDesign, startSimulation, stopSimulation } from './simulation.js';
import { camera, renderer, setView, updateParts, viewOfScene, world } from './viewer.js';

// ------------------------------------------------------------- export -------

function download(name, text, type) {
  const a = document.createElement('a');
  a.href = typeof text === 'string' && text.startsWith('data:') ? text : URL.createObjectURL(new Blob([text], { type }));
  a.download = name;
  a.click();
  return true;  // the exporters below answer whether there was something to export
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
