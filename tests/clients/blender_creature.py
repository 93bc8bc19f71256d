"""Imports monster .glb files into Blender (PyPI `bpy`, headless) and reports
their objects: per file, from an empty scene, every object's name, type, parent,
mesh data name, material names and world bounding box (Blender is z up, like
MDG); then, for every object named in the job's "move" list, moves that object by
+1 along x (as an artist drags a torso) and reports every mesh object's world box
again, before putting it back.

Run by tests/tests/creature.rs as `python blender_creature.py JOBS.json RESULT.json`:
JOBS.json is a list of {"name", "glb", "move"?}. One Blender process for every
file; an import that raises is recorded as an error, not fatal.
"""

import json
import math
import sys

import bpy
from mathutils import Matrix, Vector


def bounds(o):
    deps = bpy.context.evaluated_depsgraph_get()
    ev = o.evaluated_get(deps)
    lo = Vector((math.inf,) * 3)
    hi = Vector((-math.inf,) * 3)
    for v in ev.data.vertices:
        w = ev.matrix_world @ v.co
        for k in range(3):
            lo[k] = min(lo[k], w[k])
            hi[k] = max(hi[k], w[k])
    return list(lo), list(hi)


def main():
    jobs = json.load(open(sys.argv[1]))
    results = {}
    for job in jobs:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        try:
            bpy.ops.import_scene.gltf(filepath=job["glb"])
        except Exception as e:  # recorded, not fatal
            results[job["name"]] = {"error": str(e)}
            continue
        objects = []
        for o in bpy.context.scene.objects:
            entry = {"name": o.name, "type": o.type, "parent": o.parent.name if o.parent else None}
            if o.type == "MESH":
                entry["mesh"] = o.data.name
                entry["materials"] = [s.material.name for s in o.material_slots if s.material]
                entry["min"], entry["max"] = bounds(o)
            objects.append(entry)
        moved = {}
        for name in job.get("move", []):
            o = bpy.context.scene.objects.get(name)
            if o is None:
                moved[name] = None
                continue
            before = o.matrix_world.copy()
            o.matrix_world = Matrix.Translation((1.0, 0.0, 0.0)) @ before
            bpy.context.view_layer.update()
            moved[name] = {m.name: bounds(m) for m in bpy.context.scene.objects if m.type == "MESH"}
            o.matrix_world = before
            bpy.context.view_layer.update()
        results[job["name"]] = {"objects": objects, "meshes": len(bpy.data.meshes), "moved": moved}
    json.dump({"results": results}, open(sys.argv[2], "w"))


main()
