// The live 3D preview inside VS Code: a three.js glTF viewer in a webview. The
// extension (src/preview.ts) has the grammar evaluated (by the language server's
// `mdg/preview`, or `mdg-run`) and posts the `.glb` bytes; this page shows them,
// keeping the camera between models unless the model's size changes a lot (F
// frames it again). Bundled with esbuild into out/webview/preview.js (npm run bundle).
//
// Messages in:  {type: 'model', glb: Uint8Array, name, warnings, seed?, custom?, editAt?, ms?}
//               {type: 'error', message}  {type: 'busy'}
//               {type: 'params', params: [{name, type, value, min, max, range: {min, max, step}}]}
//               {type: 'highlight', rule, file, from, to}  (the editor's cursor: light up
//                 the triangles drawn by rule `rule`'s ops, else by the ops on lines
//                 from..to of `file`)
// Messages out: {type: 'ready'}  {type: 'shown', triangles, vertices, animations, guides, bones}
//               {type: 'drawn', at, latency}  (the new model's first frame is drawn)
//               {type: 'param', name, value}  (a slider moved)
//               {type: 'seed', seed}  {type: 'variation', delta}  {type: 'keep'}  {type: 'sheet'}
// Messages in (the contact sheet): {type: 'sheet', name, items: [{seed, glb: Uint8Array, warnings}]}
//               {type: 'site', rule, file, line}  (a click on the model: the rule that drew it)
//
// The status keeps, for tests: data-triangles, data-drawn (a count of models
// drawn), data-drawn-at (Date.now() when the last one was drawn), data-latency
// (edit → drawn, ms, when an edit asked for it), data-seed, data-highlighted
// (the triangles lit by the cursor's rule).
//
// A guided grammar's `.glb` has nodes `guides` and `bones` (the search's curves and
// the skeleton it grew): they are drawn over the model in colours of their own,
// toggled with the Guides button or the G key. `mdg-run --sites` puts in the
// geometry's extras which rule and line drew each triangle (`mdg_sites`): a click
// on the model names it and the extension shows the line.

import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

const vscode = acquireVsCodeApi();
const canvas = document.getElementById('view');
const status = document.getElementById('status');
const errorBox = document.getElementById('error');
const play = document.getElementById('play');
const timeLabel = document.getElementById('time');
const paramsBox = document.getElementById('params');
const guidesButton = document.getElementById('guides');
const siteLabel = document.getElementById('site');
const warnBox = document.getElementById('warn');
const hlLabel = document.getElementById('hl');
const sheetBox = document.getElementById('sheet');
const seedBox = document.getElementById('seedbox');
const seedInput = document.getElementById('seed');

const renderer = new THREE.WebGLRenderer({ canvas, antialias: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1e2228);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404050, 2.2));
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(3, 6, 4);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 1000);
camera.position.set(3, 2, 4);
// Left drag orbits, right drag (or shift) pans, the wheel zooms.
const controls = new OrbitControls(camera, canvas);
controls.enableDamping = true;
controls.screenSpacePanning = true;
controls.addEventListener('change', () => requestRender());

const loader = new GLTFLoader();
const clock = new THREE.Clock();
let model = null;
let mixer = null;
let duration = 0;
let playing = true;
// The camera is placed once, on the first model (or restored from the saved
// state); later models are shown from wherever the user left it.
const saved = vscode.getState();
let framed = false;
if (saved && saved.camera) {
  camera.position.fromArray(saved.camera.position);
  controls.target.fromArray(saved.camera.target);
  framed = true;
}

// Frames are drawn on demand (a new model, the camera moving, an animation
// playing), so an idle panel costs nothing.
let scheduled = false;
function requestRender() {
  if (!scheduled) {
    scheduled = true;
    requestAnimationFrame(tick);
  }
}
new ResizeObserver(() => requestRender()).observe(canvas);

function resize() {
  const w = canvas.clientWidth;
  const h = canvas.clientHeight;
  if (canvas.width !== Math.floor(w * renderer.getPixelRatio()) || canvas.height !== Math.floor(h * renderer.getPixelRatio())) {
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
  }
}

function frameObject(object) {
  const box = new THREE.Box3().setFromObject(object);
  if (box.isEmpty()) return;
  const sphere = box.getBoundingSphere(new THREE.Sphere());
  const size = sphere.radius * 2;
  const center = sphere.center;
  const dir = new THREE.Vector3(0.6, 0.45, 0.8).normalize();
  // Far enough for the bounding sphere to fit the narrower field of view.
  const halfFov = THREE.MathUtils.degToRad(camera.fov / 2);
  const fit = Math.min(halfFov, Math.atan(Math.tan(halfFov) * Math.max(camera.aspect, 1e-3)));
  controls.target.copy(center);
  camera.position.copy(center).addScaledVector(dir, (sphere.radius / Math.sin(fit)) * 1.05 + 0.01);
  camera.near = Math.max(size / 1000, 1e-4);
  camera.far = size * 100 + 10;
  camera.updateProjectionMatrix();
  controls.update();
}

let lastSphere = null;
function boundsOf(object) {
  const box = new THREE.Box3().setFromObject(object);
  return box.isEmpty() ? null : box.getBoundingSphere(new THREE.Sphere());
}
function bigChange(a, b) {
  const ratio = Math.max(a.radius, 1e-9) / Math.max(b.radius, 1e-9);
  return ratio > 3 || ratio < 1 / 3 || a.center.distanceTo(b.center) > 2 * Math.max(a.radius, b.radius);
}

function counts(object) {
  let triangles = 0;
  let vertices = 0;
  object.traverse((o) => {
    if (o.isMesh && o.geometry) {
      // An instanced mesh (EXT_mesh_gpu_instancing) draws its geometry `count` times.
      const copies = o.isInstancedMesh ? o.count : 1;
      const pos = o.geometry.getAttribute('position');
      const n = pos ? pos.count : 0;
      vertices += n * copies;
      triangles += (o.geometry.index ? o.geometry.index.count / 3 : n / 3) * copies;
    }
  });
  return { triangles: Math.round(triangles), vertices };
}

// Guides and bones: over the model (no depth test), guides amber, bones cyan.
const OVERLAYS = { guides: 0xffb040, bones: 0x40d8ff };
let overlays = [];
let overlaysShown = saved && saved.overlays === false ? false : true;
function styleOverlays(object) {
  overlays = [];
  object.traverse((o) => {
    const kind = o.isLineSegments || o.isLine ? overlayKind(o) : null;
    if (!kind) return;
    o.material = new THREE.LineBasicMaterial({ color: OVERLAYS[kind], depthTest: false, transparent: true, opacity: 0.95 });
    o.renderOrder = kind === 'bones' ? 11 : 10;
    o.visible = overlaysShown;
    overlays.push({ kind, object: o, segments: o.geometry.index ? o.geometry.index.count / 2 : 0 });
  });
}
/** 'guides' or 'bones' for the lines of those glTF nodes (the node, or its parent
 * when the mesh has several primitives). */
function overlayKind(o) {
  for (let n = o; n; n = n.parent) {
    // (GLTFLoader keeps a node's glTF name in userData.name and may suffix `name`.)
    for (const name of [n.userData && n.userData.name, n.name && n.name.replace(/_\d+$/, '')]) {
      if (name && Object.hasOwn(OVERLAYS, name)) return name;
    }
  }
  return null;
}
function setOverlays(on) {
  overlaysShown = on;
  for (const ov of overlays) ov.object.visible = on;
  guidesButton.textContent = on ? 'Hide guides' : 'Show guides';
  guidesButton.setAttribute('aria-pressed', String(on));
  requestRender();
}
guidesButton.addEventListener('click', () => setOverlays(!overlaysShown));
window.addEventListener('keydown', (e) => {
  if (e.target instanceof HTMLInputElement || e.ctrlKey || e.metaKey || e.altKey) return;
  if ((e.key === 'g' || e.key === 'G') && overlays.length > 0) {
    setOverlays(!overlaysShown);
  } else if ((e.key === 'f' || e.key === 'F') && model) {
    frameObject(model);
    requestRender();
  } else if (!seedBox.hidden && (e.key === ']' || e.key === 'n' || e.key === 'N')) {
    vscode.postMessage({ type: 'variation', delta: 1 });
  } else if (!seedBox.hidden && (e.key === '[' || e.key === 'p' || e.key === 'P')) {
    vscode.postMessage({ type: 'variation', delta: -1 });
  } else if (!seedBox.hidden && (e.key === 'k' || e.key === 'K')) {
    vscode.postMessage({ type: 'keep' });
  } else if (!seedBox.hidden && (e.key === 's' || e.key === 'S')) {
    vscode.postMessage({ type: 'sheet' });
  } else if (e.key === 'Escape' && sheet) {
    closeSheet();
  }
});
document.getElementById('sheetbutton').addEventListener('click', () => vscode.postMessage({ type: 'sheet' }));

// The contact sheet: nine variations side by side (one viewport each, framed on
// its own model, seen from the main camera's direction); a click on one chooses
// its seed, Esc goes back.
let sheet = null;
const sheetScene = new THREE.Scene();
sheetScene.background = scene.background;
sheetScene.add(new THREE.HemisphereLight(0xffffff, 0x404050, 2.2));
const sheetSun = new THREE.DirectionalLight(0xffffff, 2.0);
sheetSun.position.set(3, 6, 4);
sheetScene.add(sheetSun);
const sheetCamera = new THREE.PerspectiveCamera(45, 1, 0.01, 1000);
function closeSheet() {
  if (!sheet) return;
  for (const item of sheet) {
    item.model?.traverse((o) => {
      if (o.geometry) o.geometry.dispose();
      if (o.material) [].concat(o.material).forEach((m) => m.dispose());
    });
  }
  sheet = null;
  sheetBox.hidden = true;
  sheetBox.replaceChildren();
  delete status.dataset.sheet;
  requestRender();
}
function showSheet(m) {
  closeSheet();
  const items = m.items.map((it) => ({ seed: it.seed, warnings: it.warnings, model: null }));
  let left = items.length;
  m.items.forEach((it, i) => {
    const g = it.glb;
    const bytes = g.byteOffset === 0 && g.byteLength === g.buffer.byteLength ? g : g.slice();
    loader.parse(
      bytes.buffer,
      '',
      (gltf) => {
        gltf.scene.traverse((o) => {
          if (o.isMesh && o.material) for (const mat of [].concat(o.material)) mat.side = THREE.DoubleSide;
        });
        items[i].model = gltf.scene;
        items[i].sphere = boundsOf(gltf.scene);
        if (--left === 0) ready();
      },
      () => {
        if (--left === 0) ready();
      },
    );
  });
  function ready() {
    sheet = items;
    sheetBox.replaceChildren(
      ...items.map((it) => {
        const cell = document.createElement('div');
        cell.dataset.seed = it.seed;
        cell.title = `seed ${it.seed}: click to choose it`;
        const label = document.createElement('span');
        label.textContent = `seed ${it.seed}${it.warnings ? ' ⚠' : ''}`;
        cell.append(label);
        cell.addEventListener('click', () => {
          vscode.postMessage({ type: 'seed', seed: it.seed });
          closeSheet();
        });
        return cell;
      }),
    );
    sheetBox.hidden = false;
    status.textContent = `${m.name}: 9 variations from seed ${items[0].seed} (click one to choose it, Esc to go back)`;
    status.dataset.sheet = String(items.filter((it) => it.model).length);
    requestRender();
  }
}
function renderSheet() {
  const area = canvas.getBoundingClientRect();
  const dir = camera.position.clone().sub(controls.target).normalize();
  renderer.setScissorTest(true);
  const cells = sheetBox.children;
  sheet.forEach((item, i) => {
    const cell = cells[i];
    if (!cell) return;
    const r = cell.getBoundingClientRect();
    const x = r.left - area.left;
    const y = area.bottom - r.bottom;
    renderer.setViewport(x, y, r.width, r.height);
    renderer.setScissor(x, y, r.width, r.height);
    if (!item.model || !item.sphere) {
      renderer.setClearColor(0x1e2228);
      renderer.clear();
      return;
    }
    sheetCamera.aspect = r.width / Math.max(r.height, 1);
    const halfFov = THREE.MathUtils.degToRad(sheetCamera.fov / 2);
    const fit = Math.min(halfFov, Math.atan(Math.tan(halfFov) * sheetCamera.aspect));
    const dist = item.sphere.radius / Math.sin(fit) * 1.05 + 0.01;
    sheetCamera.position.copy(item.sphere.center).addScaledVector(dir, dist);
    sheetCamera.near = Math.max(item.sphere.radius / 500, 1e-4);
    sheetCamera.far = dist + item.sphere.radius * 4 + 10;
    sheetCamera.lookAt(item.sphere.center);
    sheetCamera.updateProjectionMatrix();
    sheetScene.add(item.model);
    renderer.render(sheetScene, sheetCamera);
    sheetScene.remove(item.model);
  });
  renderer.setScissorTest(false);
  renderer.setViewport(0, 0, canvas.clientWidth, canvas.clientHeight);
}
document.getElementById('next').addEventListener('click', () => vscode.postMessage({ type: 'variation', delta: 1 }));
document.getElementById('prev').addEventListener('click', () => vscode.postMessage({ type: 'variation', delta: -1 }));
document.getElementById('keep').addEventListener('click', () => vscode.postMessage({ type: 'keep' }));
seedInput.addEventListener('keydown', (e) => {
  if (e.key === 'Enter') {
    vscode.postMessage({ type: 'seed', seed: seedInput.value });
    seedInput.blur();
  }
});

// A click (a press and release that did not drag) on the model: the rule and line
// that drew the triangle under the pointer, from the geometry's `mdg_sites`.
const raycaster = new THREE.Raycaster();
let pressed = null;
canvas.addEventListener('pointerdown', (e) => {
  pressed = { x: e.clientX, y: e.clientY, button: e.button };
});
canvas.addEventListener('pointerup', (e) => {
  const p = pressed;
  pressed = null;
  if (!p || p.button !== 0 || Math.hypot(e.clientX - p.x, e.clientY - p.y) > 4 || !model) return;
  const site = siteAt(e.clientX, e.clientY);
  if (site) {
    siteLabel.textContent = `${site.rule || '(no rule)'} · ${site.file}:${site.line}`;
    siteLabel.hidden = false;
    vscode.postMessage({ type: 'site', rule: site.rule, file: site.file, line: site.line });
  } else {
    siteLabel.hidden = true;
  }
});
function siteAt(clientX, clientY) {
  const r = canvas.getBoundingClientRect();
  const ndc = new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
  raycaster.setFromCamera(ndc, camera);
  const meshes = [];
  model.traverse((o) => {
    if (o.isMesh && o.visible) meshes.push(o);
  });
  for (const hit of raycaster.intersectObjects(meshes, false)) {
    const sites = hit.object.geometry && hit.object.geometry.userData.mdg_sites;
    if (!sites || hit.faceIndex == null) return null;
    // The run holding the triangle: the last whose first triangle is at most it.
    const runs = sites.runs;
    let lo = 0;
    let hi = runs.length - 1;
    if (hi < 0 || runs[0][0] > hit.faceIndex) return null;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (runs[mid][0] <= hit.faceIndex) lo = mid;
      else hi = mid - 1;
    }
    return sites.sites[runs[lo][1]] || null;
  }
  return null;
}

// Cursor → geometry: the triangles whose site (the op that drew them, from
// `mdg_sites`) matches the editor's cursor, drawn again over the model in amber.
// Sites are recorded for VERTEX triangles only (not sweeps, isosurfaces or
// instances; docs/decisions.md).
const highlightMaterial = new THREE.MeshBasicMaterial({
  color: 0xffa020,
  transparent: true,
  opacity: 0.75,
  side: THREE.DoubleSide,
  polygonOffset: true,
  polygonOffsetFactor: -2,
  polygonOffsetUnits: -2,
});
let highlight = null;
let highlightMeshes = [];
function siteMatches(site, h) {
  if (h.rule && site.rule && (site.rule === h.rule || site.rule.endsWith(`.${h.rule}`))) return 'rule';
  return site.file === h.file && site.line >= h.from && site.line <= h.to ? 'lines' : null;
}
function applyHighlight() {
  for (const m of highlightMeshes) {
    m.parent?.remove(m);
    m.geometry.dispose();
  }
  highlightMeshes = [];
  let count = 0;
  let byRule = false;
  if (model && highlight) {
    const meshes = [];
    model.traverse((o) => {
      if (o.isMesh && o.geometry && o.geometry.userData.mdg_sites) meshes.push(o);
    });
    // A rule named under the cursor wins over the lines of the definition around it.
    const anyNamed = meshes.some((o) => o.geometry.userData.mdg_sites.sites.some((s) => siteMatches(s, highlight) === 'rule'));
    for (const o of meshes) {
      const sites = o.geometry.userData.mdg_sites;
      const kinds = sites.sites.map((s) => siteMatches(s, highlight));
      const hit = kinds.map((k) => (anyNamed ? k === 'rule' : k !== null));
      const pos = o.geometry.getAttribute('position');
      const index = o.geometry.index;
      const triangles = index ? index.count / 3 : pos.count / 3;
      const out = [];
      for (let r = 0; r < sites.runs.length; r++) {
        const [first, site] = sites.runs[r];
        const end = r + 1 < sites.runs.length ? sites.runs[r + 1][0] : triangles;
        if (!hit[site]) continue;
        for (let t = first; t < end; t++) {
          for (let k = 0; k < 3; k++) {
            const v = index ? index.getX(3 * t + k) : 3 * t + k;
            out.push(pos.getX(v), pos.getY(v), pos.getZ(v));
          }
        }
        count += end - first;
      }
      if (out.length === 0) continue;
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(out, 3));
      const mesh = new THREE.Mesh(g, highlightMaterial);
      mesh.renderOrder = 5;
      o.add(mesh);
      highlightMeshes.push(mesh);
    }
    byRule = anyNamed;
  }
  status.dataset.highlighted = String(count);
  hlLabel.hidden = count === 0;
  hlLabel.textContent = count === 0 ? '' : `${byRule ? `rule ${highlight.rule}` : `lines ${highlight.from}–${highlight.to}`}: ${count} triangles lit`;
  requestRender();
}

function showError(message) {
  errorBox.textContent = message;
  errorBox.hidden = false;
  status.textContent = model ? 'showing the last model that evaluated' : 'no model';
}

// The model waiting for its first frame: the drawn report goes out after it.
let pendingDrawn = null;
let drawnCount = 0;

function showWarnings(warnings) {
  const list = (warnings || []).filter((w) => w);
  warnBox.textContent = list.map((w) => `⚠ ${w}`).join('\n');
  warnBox.hidden = list.length === 0;
}

function show(gltf, name, m) {
  closeSheet();
  if (model) {
    scene.remove(model);
    model.traverse((o) => {
      if (o.geometry) o.geometry.dispose();
      if (o.material) [].concat(o.material).forEach((m) => m.dispose());
    });
  }
  model = gltf.scene;
  // Two-sided: a flat triangle seen from below is lit as from above (three.js
  // turns the normal of a back face), not dark on the dark background.
  model.traverse((o) => {
    if (o.isMesh && o.material) for (const m of [].concat(o.material)) m.side = THREE.DoubleSide;
  });
  scene.add(model);
  styleOverlays(model);
  guidesButton.hidden = overlays.length === 0;
  if (overlays.length > 0) setOverlays(overlaysShown);
  resize();
  // Framed on the first model, and again when the model's size changes by more
  // than 3 times or it moves out of view (a different grammar, not an edit of
  // the same); otherwise the camera stays where the user left it.
  const sphere = boundsOf(model);
  if (!framed || (sphere && lastSphere && bigChange(lastSphere, sphere))) {
    frameObject(model);
    framed = true;
  }
  if (sphere) lastSphere = sphere;
  mixer = null;
  duration = 0;
  if (gltf.animations.length > 0) {
    mixer = new THREE.AnimationMixer(model);
    for (const clip of gltf.animations) {
      mixer.clipAction(clip).play();
      duration = Math.max(duration, clip.duration);
    }
  }
  play.hidden = !mixer;
  timeLabel.hidden = !mixer;
  const c = counts(model);
  errorBox.hidden = true;
  const anim = gltf.animations.length ? ` · ${gltf.animations.length} animation(s), ${duration.toFixed(1)} s` : '';
  const seg = (kind) => overlays.filter((o) => o.kind === kind).reduce((n, o) => n + o.segments, 0);
  const guides = seg('guides');
  const bones = seg('bones');
  const guided = overlays.length ? ` · ${bones} bones, ${guides} guide segments` : '';
  const took = m.ms ? ` · ${Math.round(m.ms.total)} ms` : '';
  status.textContent = `${name}: ${c.triangles} triangles · ${c.vertices} vertices${anim}${guided}${took}`;
  showWarnings(m.warnings);
  if (typeof m.seed === 'string') {
    seedBox.hidden = false;
    if (document.activeElement !== seedInput) seedInput.value = m.seed;
    status.dataset.seed = m.seed;
  } else {
    seedBox.hidden = true;
  }
  pendingDrawn = { editAt: m.editAt };
  applyHighlight();
  status.dataset.triangles = String(c.triangles);
  status.dataset.bones = String(bones);
  status.dataset.guides = String(guides);
  clock.getDelta();
  requestRender();
  vscode.postMessage({ type: 'shown', triangles: c.triangles, vertices: c.vertices, animations: gltf.animations.length, guides, bones });
}

// One slider per `@param` (a checkbox for a bool), rebuilt only when the
// declarations change (names, types, ranges), so dragging one is not interrupted
// by the model it asked for. The extension debounces the re-evaluation.
let paramsKey = '';
function fmt(p, v) {
  return p.type === 'int' ? String(Math.round(v)) : String(Number(v.toPrecision(4)));
}
function showParams(params) {
  const key = JSON.stringify(params.map((p) => [p.name, p.type, p.min, p.max]));
  if (key !== paramsKey) {
    paramsKey = key;
    paramsBox.replaceChildren();
    for (const p of params) {
      const label = document.createElement('label');
      label.textContent = p.name;
      const input = document.createElement('input');
      input.dataset.name = p.name;
      input.id = `param-${p.name}`;
      label.htmlFor = input.id;
      const out = document.createElement('output');
      if (p.type === 'bool') {
        input.type = 'checkbox';
        input.addEventListener('change', () => {
          out.textContent = input.checked ? 'true' : 'false';
          vscode.postMessage({ type: 'param', name: p.name, value: input.checked ? 1 : 0 });
        });
      } else {
        const r = p.range;
        input.type = 'range';
        input.min = String(r.min);
        input.max = String(r.max);
        input.step = String(r.step);
        input.addEventListener('input', () => {
          out.textContent = fmt(p, Number(input.value));
          vscode.postMessage({ type: 'param', name: p.name, value: Number(input.value) });
        });
      }
      paramsBox.append(label, input, out);
    }
  }
  for (const p of params) {
    const input = paramsBox.querySelector(`input[data-name="${CSS.escape(p.name)}"]`);
    if (!input || document.activeElement === input) continue;
    if (p.type === 'bool') input.checked = p.value !== 0;
    else input.value = String(p.value);
    input.nextElementSibling.textContent = p.type === 'bool' ? (p.value ? 'true' : 'false') : fmt(p, p.value);
  }
  paramsBox.hidden = params.length === 0;
}

window.addEventListener('message', (event) => {
  const m = event.data;
  if (m.type === 'model') {
    const g = m.glb;
    // Its own buffer (a view into a larger one is copied out).
    const bytes = g.byteOffset === 0 && g.byteLength === g.buffer.byteLength ? g : g.slice();
    loader.parse(bytes.buffer, '', (gltf) => show(gltf, m.name, m), (e) => showError(`cannot read the model: ${e.message ?? e}`));
  } else if (m.type === 'error') {
    showError(m.message);
  } else if (m.type === 'params') {
    showParams(m.params);
  } else if (m.type === 'sheet') {
    showSheet(m);
  } else if (m.type === 'highlight') {
    highlight = m;
    applyHighlight();
  } else if (m.type === 'busy') {
    status.textContent = m.what || 'evaluating…';
  }
});

play.addEventListener('click', () => {
  playing = !playing;
  play.textContent = playing ? 'Pause' : 'Play';
  clock.getDelta();
  requestRender();
});

let lastSave = 0;
function tick() {
  scheduled = false;
  resize();
  const dt = clock.getDelta();
  let again = false;
  if (mixer && playing) {
    mixer.update(dt);
    timeLabel.textContent = `${(mixer.time % Math.max(duration, 1e-6)).toFixed(2)} s`;
    again = true;
  }
  // With damping the camera keeps moving a little after the mouse stops.
  again = controls.update() || again;
  if (sheet) renderSheet();
  else renderer.render(scene, camera);
  if (pendingDrawn) {
    // The new model's first frame: say when (the editor measures edit → frame).
    const at = Date.now();
    const latency = pendingDrawn.editAt ? at - pendingDrawn.editAt : null;
    pendingDrawn = null;
    drawnCount += 1;
    status.dataset.drawn = String(drawnCount);
    status.dataset.drawnAt = String(at);
    if (latency !== null) status.dataset.latency = String(latency);
    vscode.postMessage({ type: 'drawn', at, latency });
  }
  if (again) requestRender();
  const now = performance.now();
  if (now - lastSave > 500) {
    lastSave = now;
    vscode.setState({ camera: { position: camera.position.toArray(), target: controls.target.toArray() }, overlays: overlaysShown });
  }
}
requestRender();
vscode.postMessage({ type: 'ready' });
