// The live 3D preview inside VS Code: a three.js glTF viewer in a webview. The
// extension (src/preview.ts) has the grammar evaluated (by the language server's
// `mdg/preview`, or `mdg-run`) and posts the `.glb` bytes; this page shows them,
// keeping the camera between models unless the model's size changes a lot (F
// frames it again). Bundled with esbuild into out/webview/preview.js (npm run bundle).
//
// Messages in:  {type: 'model', glb: Uint8Array, name, warnings, seed?, custom?, editAt?, ms?, tree?}
//                 (tree: the derivation inspector's tree of rule calls, lsp/src/preview.rs)
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
//               {type: 'site', rule, file, line, definition?}  (a click on the model: the rule
//                 that drew it; on an inspector row's place, `definition`: its rule's header)
//
// The status keeps, for tests: data-triangles, data-drawn (a count of models
// drawn), data-drawn-at (Date.now() when the last one was drawn), data-latency
// (edit → drawn, ms, when an edit asked for it), data-seed, data-highlighted
// (the triangles lit by the cursor's rule or the inspector's node),
// data-highlighted-instances (the instances among them), data-drawn-triangles
// (what the depth slider leaves drawn), data-tree-nodes.
//
// A guided grammar's `.glb` has nodes `guides` and `bones` (the search's curves and
// the skeleton it grew): they are drawn over the model in colours of their own,
// toggled with the Guides button or the G key. The server's `.glb` (and
// `mdg-run --sites`'s) has in its extras which rule and line made each triangle,
// sweep and instance, at which derivation depth, of which node of the tree
// (`mdg_sites`): a click on the model names it and the extension shows the line;
// the cursor's rule and the inspector's rows light what they made; the depth
// slider cuts the model. The inspector (the Tree button, or T) shows the tree.

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
const treeBox = document.getElementById('tree');
const treeList = document.getElementById('treelist');
const treeNote = document.getElementById('treenote');
const treeButton = document.getElementById('treebutton');
const depthBox = document.getElementById('depthbox');
const depthInput = document.getElementById('depth');
const depthLabel = document.getElementById('depthlabel');

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
    if (o.isMesh && o.geometry && o.visible && !o.userData.mdgHighlight) {
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
  } else if (e.key === 't' || e.key === 'T') {
    treeButton.click();
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

// Sites (`mdg_sites` in the glTF extras, docs/editors.md): runs of
// [first, site, depth, node] over a primitive's triangles, or over an instanced
// node's instances (`instances: true`), or one run on the node of one placed
// instance. `siteSources` lists the model's meshes that carry them.
function siteSources() {
  const list = [];
  if (!model) return list;
  model.traverse((o) => {
    if (!o.isMesh || !o.geometry || o.userData.mdgHighlight) return;
    const sites = o.userData.mdg_sites || o.geometry.userData.mdg_sites;
    if (!sites || !sites.runs || sites.runs.length === 0) return;
    list.push({ o, sites, instances: !!(o.isInstancedMesh && sites.instances) });
  });
  return list;
}
/** The run holding item `t` (a triangle or an instance), by binary search. */
function runAt(runs, t) {
  let lo = 0;
  let hi = runs.length - 1;
  if (hi < 0 || runs[0][0] > t) return null;
  while (lo < hi) {
    const mid = (lo + hi + 1) >> 1;
    if (runs[mid][0] <= t) lo = mid;
    else hi = mid - 1;
  }
  return runs[lo];
}
/** How many items (triangles or instances) `src` had before any cut. */
function itemCount(src) {
  if (src.instances) return src.o.userData.mdgCut ? src.o.userData.mdgCut.count : src.o.count;
  const g = src.o.geometry;
  const index = src.o.userData.mdgCut ? src.o.userData.mdgCut.index : g.index;
  return index ? index.count / 3 : g.getAttribute('position').count / 3;
}

// A click (a press and release that did not drag) on the model: the rule and line
// that made the triangle or instance under the pointer (`siteAt`: the site, and
// whether the item hit is an instance).
const raycaster = new THREE.Raycaster();
let pressed = null;
canvas.addEventListener('pointerdown', (e) => {
  pressed = { x: e.clientX, y: e.clientY, button: e.button };
});
canvas.addEventListener('pointerup', (e) => {
  const p = pressed;
  pressed = null;
  if (!p || p.button !== 0 || Math.hypot(e.clientX - p.x, e.clientY - p.y) > 4 || !model) return;
  const hit = siteAt(e.clientX, e.clientY);
  const site = hit && hit.site;
  if (site) {
    siteLabel.textContent = `${site.rule || '(no rule)'} · ${site.file}:${site.line}`;
    // Whether the item clicked is an instance of an instanced mesh (for tests).
    siteLabel.dataset.instance = String(hit.instance);
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
    if (o.isMesh && o.visible && !o.userData.mdgHighlight) meshes.push(o);
  });
  for (const hit of raycaster.intersectObjects(meshes, false)) {
    const o = hit.object;
    const sites = o.userData.mdg_sites || (o.geometry && o.geometry.userData.mdg_sites);
    if (!sites) return null;
    const cut = o.userData.mdgCut;
    let item;
    const instance = !!(o.isInstancedMesh && sites.instances);
    if (instance) {
      if (hit.instanceId == null) return null;
      item = cut ? cut.order[hit.instanceId] : hit.instanceId;
    } else {
      if (hit.faceIndex == null) return null;
      item = cut && cut.tris ? cut.tris[hit.faceIndex] : hit.faceIndex;
    }
    const run = runAt(sites.runs, item);
    const site = run ? sites.sites[run[1]] || null : null;
    return site ? { site, instance } : null;
  }
  return null;
}

// The depth slider: the model cut at derivation depth N (what activations deeper
// than N made is hidden). A triangle primitive gets an index of the triangles
// kept (the original is kept in userData.mdgCut, with the kept triangles'
// numbers for clicks); an instanced node draws the kept instances first; the
// node of one instance is hidden.
let depthCut = null;
let maxDepth = 0;
function applyCut() {
  for (const src of siteSources()) {
    const { o, sites } = src;
    if (src.instances) {
      let cut = o.userData.mdgCut;
      if (!cut) {
        cut = { count: o.count, matrices: o.instanceMatrix.array.slice(), colors: o.instanceColor ? o.instanceColor.array.slice() : null, order: null };
        o.userData.mdgCut = cut;
      }
      const order = [];
      for (let i = 0; i < cut.count; i++) {
        const run = runAt(sites.runs, i);
        if (depthCut === null || !run || run[2] <= depthCut) order.push(i);
      }
      order.forEach((i, k) => {
        o.instanceMatrix.array.set(cut.matrices.subarray(16 * i, 16 * i + 16), 16 * k);
        if (cut.colors) o.instanceColor.array.set(cut.colors.subarray(3 * i, 3 * i + 3), 3 * k);
      });
      cut.order = order;
      o.count = order.length;
      o.instanceMatrix.needsUpdate = true;
      if (o.instanceColor) o.instanceColor.needsUpdate = true;
      o.computeBoundingSphere();
      continue;
    }
    if (!o.geometry.userData.mdg_sites) {
      // The node of one placed instance.
      o.visible = depthCut === null || sites.runs[0][2] <= depthCut;
      continue;
    }
    const g = o.geometry;
    let cut = o.userData.mdgCut;
    if (!cut) {
      cut = { index: g.index, tris: null };
      o.userData.mdgCut = cut;
    }
    const triangles = itemCount(src);
    if (depthCut === null) {
      g.setIndex(cut.index);
      cut.tris = null;
      continue;
    }
    const keep = [];
    const tris = [];
    const runs = sites.runs;
    for (let r = 0; r < runs.length; r++) {
      if (runs[r][2] > depthCut) continue;
      const end = r + 1 < runs.length ? runs[r + 1][0] : triangles;
      for (let t = runs[r][0]; t < end; t++) {
        tris.push(t);
        for (let k = 0; k < 3; k++) keep.push(cut.index ? cut.index.getX(3 * t + k) : 3 * t + k);
      }
    }
    g.setIndex(new THREE.BufferAttribute(new Uint32Array(keep), 1));
    cut.tris = tris;
  }
  // The pen lines carry no sites: under a cut they are hidden (they would show
  // the skeleton of what the cut hides).
  let lines = false;
  model.traverse((o) => {
    if ((o.isLine || o.isLineSegments) && !overlayKind(o)) {
      o.visible = depthCut === null;
      lines = true;
    }
  });
  const c = counts(model);
  status.dataset.drawnTriangles = String(c.triangles);
  depthLabel.textContent =
    depthCut === null ? `depth ≤ ${maxDepth} (all)` : `depth ≤ ${depthCut}: ${c.triangles} triangles${lines ? ', pen lines hidden' : ''}`;
  requestRender();
}

// Highlights: the cursor's rule (a `highlight` message) or a node of the tree,
// drawn again over the model in amber. `hit(run)` says whether a run's items
// are lit; what the depth slider hides stays hidden.
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
/** The nodes of the tree below (and with) the nodes `roots`, as a Set. */
function subtreeOf(roots) {
  const set = new Set(roots);
  if (!tree) return set;
  // Children come after their parents.
  tree.nodes.forEach((n, i) => {
    if (n.parent != null && set.has(n.parent)) set.add(i);
  });
  return set;
}
/** What the current highlight lights: a test of a run, and its label. */
function highlightTest(sources) {
  if (!highlight) return null;
  if (highlight.node != null) {
    const nodes = subtreeOf([highlight.node]);
    const n = tree && tree.nodes[highlight.node];
    const name = n ? tree.rules[n.rule].rule : '?';
    return { label: `node ${name} (depth ${n ? n.depth : '?'})`, hit: (run) => nodes.has(run[3]) };
  }
  const h = highlight;
  // A rule named under the cursor wins over the lines of the definition around it.
  const named = sources.some((s) => s.sites.sites.some((site) => siteMatches(site, h) === 'rule'));
  if (named) return { label: `rule ${h.rule}`, hit: (run, sites) => siteMatches(sites.sites[run[1]], h) === 'rule' };
  // A rule that draws nothing itself: what its calls made (the tree's nodes of it).
  if (h.rule && tree) {
    const roots = [];
    tree.nodes.forEach((n, i) => {
      const r = tree.rules[n.rule].rule;
      if (r === h.rule || r.endsWith(`.${h.rule}`)) roots.push(i);
    });
    if (roots.length > 0) {
      const nodes = subtreeOf(roots);
      return { label: `rule ${h.rule} (its calls)`, hit: (run) => nodes.has(run[3]) };
    }
  }
  return { label: `lines ${h.from}–${h.to}`, hit: (run, sites) => siteMatches(sites.sites[run[1]], h) === 'lines' };
}
function applyHighlight() {
  for (const m of highlightMeshes) {
    m.parent?.remove(m);
    if (!m.userData.sharedGeometry) m.geometry.dispose();
  }
  highlightMeshes = [];
  let count = 0;
  let instancesLit = 0;
  const sources = siteSources();
  const test = highlightTest(sources);
  const shown = (run) => depthCut === null || run[2] <= depthCut;
  if (model && test) {
    for (const src of sources) {
      const { o, sites } = src;
      const runs = sites.runs;
      const items = itemCount(src);
      if (src.instances) {
        const cut = o.userData.mdgCut;
        const matrices = cut ? cut.matrices : o.instanceMatrix.array;
        const lit = [];
        for (let r = 0; r < runs.length; r++) {
          if (!test.hit(runs[r], sites) || !shown(runs[r])) continue;
          const end = r + 1 < runs.length ? runs[r + 1][0] : items;
          for (let i = runs[r][0]; i < end; i++) lit.push(i);
        }
        if (lit.length === 0) continue;
        const mesh = new THREE.InstancedMesh(o.geometry, highlightMaterial, lit.length);
        lit.forEach((i, k) => mesh.instanceMatrix.array.set(matrices.subarray(16 * i, 16 * i + 16), 16 * k));
        mesh.userData = { mdgHighlight: true, sharedGeometry: true };
        mesh.renderOrder = 5;
        o.add(mesh);
        highlightMeshes.push(mesh);
        count += lit.length * (o.geometry.index ? o.geometry.index.count / 3 : o.geometry.getAttribute('position').count / 3);
        instancesLit += lit.length;
        continue;
      }
      if (!o.geometry.userData.mdg_sites) {
        // The node of one placed instance.
        if (!test.hit(runs[0], sites) || !shown(runs[0])) continue;
        const mesh = new THREE.Mesh(o.geometry, highlightMaterial);
        mesh.userData = { mdgHighlight: true, sharedGeometry: true };
        mesh.renderOrder = 5;
        o.add(mesh);
        highlightMeshes.push(mesh);
        count += items;
        instancesLit += 1;
        continue;
      }
      const pos = o.geometry.getAttribute('position');
      const cut = o.userData.mdgCut;
      const index = cut ? cut.index : o.geometry.index;
      const out = [];
      for (let r = 0; r < runs.length; r++) {
        if (!test.hit(runs[r], sites) || !shown(runs[r])) continue;
        const first = runs[r][0];
        const end = r + 1 < runs.length ? runs[r + 1][0] : items;
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
      mesh.userData = { mdgHighlight: true };
      mesh.renderOrder = 5;
      o.add(mesh);
      highlightMeshes.push(mesh);
    }
  }
  count = Math.round(count);
  status.dataset.highlighted = String(count);
  status.dataset.highlightedInstances = String(instancesLit);
  hlLabel.hidden = count === 0;
  hlLabel.textContent = count === 0 ? '' : `${test.label}: ${count} triangles lit`;
  for (const row of treeBox.querySelectorAll('.row')) {
    row.classList.toggle('lit', highlight != null && highlight.node != null && Number(row.dataset.node) === highlight.node);
  }
  requestRender();
}

// The derivation inspector: the tree of rule calls of the model shown (one row
// per path of rules: calls, depth, share of the triangles), collapsible; a click
// on a row lights up what that path (and everything below it) made, a click on
// its place opens the rule's definition; the slider cuts the model at a depth.
let tree = null;
let treeShown = !!(saved && saved.tree === true);
const collapsed = new Set();
function showTree() {
  treeBox.hidden = !treeShown || !tree;
  treeButton.setAttribute('aria-pressed', String(treeShown));
  const nodes = tree ? tree.nodes : [];
  status.dataset.treeNodes = String(nodes.length);
  treeList.replaceChildren();
  if (!tree) return;
  const children = nodes.map(() => []);
  const roots = [];
  nodes.forEach((n, i) => (n.parent == null ? roots : children[n.parent]).push(i));
  const total = Math.max(tree.triangles, 1);
  const add = (i, level) => {
    const n = nodes[i];
    const rule = tree.rules[n.rule];
    const row = document.createElement('div');
    row.className = 'row';
    row.dataset.node = String(i);
    row.style.paddingLeft = `${level * 12 + 2}px`;
    const caret = document.createElement('span');
    caret.className = 'caret';
    caret.textContent = children[i].length ? (collapsed.has(i) ? '▸' : '▾') : ' ';
    caret.addEventListener('click', (e) => {
      e.stopPropagation();
      if (collapsed.has(i)) collapsed.delete(i);
      else collapsed.add(i);
      showTree();
    });
    const name = document.createElement('span');
    name.className = 'rule';
    name.textContent = rule.rule || '(start)';
    const info = document.createElement('span');
    info.className = 'info';
    const share = ((100 * n.total) / total).toFixed(n.total * 1000 < total ? 2 : 1);
    info.textContent = ` ×${n.calls} · d${n.depth} · ${share}%${n.deeper ? ` · +${n.deeper} deeper` : ''}`;
    info.title = `${n.calls} call(s) at depth ${n.depth}; ${n.triangles} triangles made by its own ops, ${n.total} with everything below it (${share}% of ${tree.triangles})${n.deeper ? `; ${n.deeper} calls below it past the inspector's limits are counted here` : ''}`;
    const place = document.createElement('a');
    place.className = 'place';
    place.textContent = rule.file ? `${rule.file.split('/').pop()}:${rule.line}` : '';
    place.title = 'Open the rule’s definition';
    place.addEventListener('click', (e) => {
      e.stopPropagation();
      vscode.postMessage({ type: 'site', rule: rule.rule, file: rule.file, line: rule.line, definition: true });
    });
    row.append(caret, name, info, place);
    row.addEventListener('click', () => {
      highlight = highlight && highlight.node === i ? null : { node: i };
      applyHighlight();
    });
    treeList.append(row);
    if (!collapsed.has(i)) for (const c of children[i]) add(c, level + 1);
  };
  for (const r of roots) add(r, 0);
  treeNote.textContent = tree.cut ? 'Deeper paths past the inspector’s limits are counted in the node above them (+N deeper).' : '';
  treeNote.hidden = !tree.cut;
  if (highlight && highlight.node != null) applyHighlight();
}
function setTree(t) {
  const same = tree && t && tree.nodes.length === t.nodes.length;
  tree = t || null;
  if (!same) {
    collapsed.clear();
    // Paths deeper than 3 start folded.
    if (tree) tree.nodes.forEach((n, i) => n.depth >= 3 && tree.nodes.some((m) => m.parent === i) && collapsed.add(i));
    if (highlight && highlight.node != null) highlight = null;
  }
  showTree();
}
treeButton.addEventListener('click', () => {
  treeShown = !treeShown;
  showTree();
  vscode.setState({ ...(vscode.getState() || {}), tree: treeShown });
});
depthInput.addEventListener('input', () => {
  const v = Number(depthInput.value);
  depthCut = v >= maxDepth ? null : v;
  applyCut();
  applyHighlight();
});
/** After a new model: the deepest depth its sites name, the slider's range, the cut kept. */
function setupDepth() {
  maxDepth = 0;
  for (const src of siteSources()) for (const run of src.sites.runs) maxDepth = Math.max(maxDepth, run[2]);
  depthInput.max = String(maxDepth);
  if (depthCut !== null && depthCut >= maxDepth) depthCut = null;
  depthInput.value = String(depthCut === null ? maxDepth : depthCut);
  depthBox.hidden = siteSources().length === 0;
  applyCut();
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
  setTree(m.tree);
  setupDepth();
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
    vscode.setState({ camera: { position: camera.position.toArray(), target: controls.target.toArray() }, overlays: overlaysShown, tree: treeShown });
  }
}
requestRender();
vscode.postMessage({ type: 'ready' });
