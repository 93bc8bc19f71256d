// Loads .glb files with three.js's GLTFLoader under Node (no browser) and reports
// what it got, as JSON on stdout: per file the mesh objects (triangles and lines),
// their vertex and triangle counts as drawn (instances counted once per object),
// the world bounding box (three.js is y up), the animation clips, or the error.
// Used by viewer/tests/clients.rs: node three_check.mjs A.glb B.glb …
import { readFileSync } from "node:fs";
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";

function load(path) {
  const bytes = readFileSync(path);
  const data = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  return new Promise((resolve, reject) => new GLTFLoader().parse(data, "", resolve, reject));
}

const results = [];
for (const path of process.argv.slice(2)) {
  try {
    const gltf = await load(path);
    const scene = gltf.scene;
    scene.updateMatrixWorld(true);
    let meshes = 0, geometry = 0, lines = 0, vertices = 0, triangles = 0, sites = 0;
    // Line segments per glTF node name (`lines`, a search's `guides` and `bones`).
    const namedLines = {};
    const box = new THREE.Box3();
    const p = new THREE.Vector3();
    scene.traverse((o) => {
      if (o.isMesh) {
        meshes += 1;
        // Parts of the `geometry` node (one mesh per primitive); the rest are instances.
        for (let a = o; a; a = a.parent) if (a.name === "geometry") { geometry += 1; break; }
        const g = o.geometry;
        // `mdg-run --sites`: which rule drew each triangle, in the primitive's extras.
        if (g.userData.mdg_sites) sites += g.userData.mdg_sites.runs.length;
        vertices += g.attributes.position.count;
        triangles += (g.index ? g.index.count : g.attributes.position.count) / 3;
        // Skinned meshes: skinned by the bones' poses at t = 0, as drawn.
        const pos = g.attributes.position;
        for (let i = 0; i < pos.count; i++) {
          p.fromBufferAttribute(pos, i);
          if (o.isSkinnedMesh) o.applyBoneTransform(i, p);
          p.applyMatrix4(o.matrixWorld);
          box.expandByPoint(p);
        }
      } else if (o.isLine || o.isLineSegments) {
        lines += 1;
        const name = o.userData.name ?? o.name;
        const g = o.geometry;
        namedLines[name] = (namedLines[name] ?? 0) + (g.index ? g.index.count : g.attributes.position.count) / 2;
      }
    });
    results.push({
      file: path,
      meshes,
      geometry,
      lines,
      named_lines: namedLines,
      sites,
      vertices,
      triangles,
      min: box.isEmpty() ? null : box.min.toArray(),
      max: box.isEmpty() ? null : box.max.toArray(),
      animations: gltf.animations.map((a) => ({ name: a.name, tracks: a.tracks.length, duration: a.duration })),
    });
  } catch (e) {
    results.push({ file: path, error: String(e && e.message ? e.message : e) });
  }
}
process.stdout.write(JSON.stringify({ three: THREE.REVISION, results }) + "\n");
