// What every part of the app shares: the page's elements by id, the app's
// state and the server's API.
export const $ = (id) => document.getElementById(id);

export const state = {
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

export async function api(path, body, method = 'POST') {
  const res = await fetch(path, {
    method,
    headers: body === undefined ? {} : { 'Content-Type': 'application/json' },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  const text = await res.text();
  if (!res.ok) throw new Error(text.trim());
  return JSON.parse(text);
}

export function showMessage(text) { $('message').textContent = text || ''; }

export function setStatus(text) { $('status-line').textContent = text; }
