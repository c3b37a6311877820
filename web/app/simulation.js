// Form finding, the stiffness design and the live simulation, with the node
// picking and dragging of the pointer.
import * as THREE from 'three';

import { $, api, setStatus, showMessage, state } from './common.js';
import { blockIds, drawPicks, gizmo, pickLinkEnd, placeGizmo, refreshEditor } from './editor.js';
import { camera, controls, parts, renderer, setView, updateParts, viewOfScene } from './viewer.js';

// ------------------------------------------------------- form finding -------

export async function formFind() {
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

export async function makeDesign() {
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

export async function startSimulation() {
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

export async function stopSimulation() {
  const sim = state.sim;
  if (!sim) return;
  sim.running = false;
  state.sim = null;
  $('stop').disabled = true;
  // A step request still on its way would find the simulation deleted (404).
  if (sim.inflight) await sim.inflight;
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
      const request = api(`/api/simulation/${sim.id}/step`, { steps, drags });
      sim.inflight = request.catch(() => {});
      r = await request;
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
