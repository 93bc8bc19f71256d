"""Imports monster .glb files into Blender (PyPI `bpy`, headless) and reports
their objects: per file, from an empty scene, every object's name, type, parent,
mesh data name and world bounding box (Blender is z up, like MDG).

Run by tests/tests/creature.rs as `python blender_creature.py JOBS.json RESULT.json`:
JOBS.json is a list of {"name", "glb"}. One Blender process for every file; an
import that raises is recorded as an error, not fatal.
"""

import json
import math
import sys

import bpy
from mathutils import Vector


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
                entry["min"], entry["max"] = bounds(o)
            objects.append(entry)
        results[job["name"]] = {"objects": objects, "meshes": len(bpy.data.meshes)}
    json.dump({"results": results}, open(sys.argv[2], "w"))


main()
