// Loads .glb files with three.js's GLTFLoader under Node (no browser) and reports
// what it got, as JSON on stdout: per file the mesh objects (triangles and lines),
// their vertex and triangle counts as stored (an InstancedMesh counted once) and as
// drawn (an InstancedMesh counted once per instance), the InstancedMesh objects
// (EXT_mesh_gpu_instancing: instance count, instanceMatrix.count, whether
// instanceColor is set), the world bounding box with every instance placed (three.js
// is y up), the animation clips, or the error.
// Used by cli/tests/clients.rs: node three_check.mjs A.glb B.glb …
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
    let drawnVertices = 0, drawnTriangles = 0;
    const instanced = [];
    const m = new THREE.Matrix4();
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
        const pos = g.attributes.position;
        const tris = (g.index ? g.index.count : pos.count) / 3;
        vertices += pos.count;
        triangles += tris;
        if (o.isInstancedMesh) {
          // Every instance: its matrix, then the object's world matrix.
          instanced.push({
            name: o.name,
            count: o.count,
            matrices: o.instanceMatrix.count,
            color: o.instanceColor != null,
            vertices: pos.count,
            triangles: tris,
          });
          drawnVertices += pos.count * o.count;
          drawnTriangles += tris * o.count;
          for (let k = 0; k < o.count; k++) {
            o.getMatrixAt(k, m);
            m.premultiply(o.matrixWorld);
            for (let i = 0; i < pos.count; i++) {
              box.expandByPoint(p.fromBufferAttribute(pos, i).applyMatrix4(m));
            }
          }
          return;
        }
        drawnVertices += pos.count;
        drawnTriangles += tris;
        // Skinned meshes: skinned by the bones' poses at t = 0, as drawn.
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
      drawn_vertices: drawnVertices,
      drawn_triangles: drawnTriangles,
      instanced,
      min: box.isEmpty() ? null : box.min.toArray(),
      max: box.isEmpty() ? null : box.max.toArray(),
      animations: gltf.animations.map((a) => ({ name: a.name, tracks: a.tracks.length, duration: a.duration })),
    });
  } catch (e) {
    results.push({ file: path, error: String(e && e.message ? e.message : e) });
  }
}
process.stdout.write(JSON.stringify({ three: THREE.REVISION, results }) + "\n");
