"""Imports .glb files into Blender (PyPI `bpy`, headless) and reports what it got.

Run by viewer/tests/clients.rs as `python blender_check.py JOBS.json RESULT.json`:
JOBS.json is a list of {"name", "glb", "png", "size": [w, h]}. For each file, from an
empty scene: import it with Blender's own glTF importer, then record the import
time, the mesh objects and their vertex and polygon counts, the world bounding box
(Blender is z up, like MDG), the actions, and render it with Cycles on the CPU from
MDG's home view (azimuth 35°, elevation 25°, vertical field of view 40°, the
bounding sphere framed) into `png`, transparent where nothing was hit, lit only by
a uniform white world (so a surface shows its own colour), "Standard" view
transform (no tone mapping). One Blender process for every file. An import that
raises is recorded as an error, not fatal.
"""

import json
import math
import sys
import time

import bpy
from mathutils import Vector


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def world_bounds(objs):
    lo = Vector((math.inf,) * 3)
    hi = Vector((-math.inf,) * 3)
    deps = bpy.context.evaluated_depsgraph_get()
    for o in objs:
        ev = o.evaluated_get(deps)
        mesh = ev.to_mesh()
        mw = ev.matrix_world
        for v in mesh.vertices:
            p = mw @ v.co
            for k in range(3):
                lo[k] = min(lo[k], p[k])
                hi[k] = max(hi[k], p[k])
        ev.to_mesh_clear()
    return lo, hi


def render(path, size, lo, hi):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 2
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    world = bpy.data.worlds.new("white")
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    bg.inputs[0].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs[1].default_value = 1.0
    scene.world = world
    center = (lo + hi) * 0.5
    radius = max((hi - lo).length * 0.5, 1e-4)
    flat = (hi.z - lo.z) < radius * 0.01
    az, el = (0.0, 89.0) if flat else (35.0, 25.0)
    az, el = math.radians(az), math.radians(el)
    fov = math.radians(40.0)
    aspect = size[0] / size[1]
    half = min(fov * 0.5, math.atan(math.tan(fov * 0.5) * aspect))
    dist = radius / math.sin(half) * 1.05
    d = Vector((math.cos(el) * math.sin(az), -math.cos(el) * math.cos(az), math.sin(el)))
    cam_data = bpy.data.cameras.new("check")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = fov
    cam_data.clip_start = max(dist - radius * 1.5, dist * 1e-3)
    cam_data.clip_end = dist + radius * 1.5
    cam = bpy.data.objects.new("check", cam_data)
    scene.collection.objects.link(cam)
    cam.location = center + d * dist
    cam.rotation_euler = (-d).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def check(job):
    reset()
    started = time.monotonic()
    try:
        bpy.ops.import_scene.gltf(filepath=job["glb"])
    except Exception as e:  # the importer's own error, reported to the test
        return {"name": job["name"], "error": str(e)}
    seconds = time.monotonic() - started
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    tri_objects = [o for o in meshes if len(o.data.polygons) > 0]
    result = {
        "name": job["name"],
        "import_seconds": seconds,
        "mesh_objects": len(meshes),
        "vertices": sum(len(o.data.vertices) for o in tri_objects),
        "polygons": sum(len(o.data.polygons) for o in tri_objects),
        "line_edges": sum(len(o.data.edges) for o in meshes if len(o.data.polygons) == 0),
        "actions": sorted(a.name for a in bpy.data.actions),
        "armatures": len([o for o in bpy.context.scene.objects if o.type == "ARMATURE"]),
        "color_attributes": sum(len(o.data.color_attributes) for o in tri_objects),
    }
    if tri_objects:
        lo, hi = world_bounds(tri_objects)
        result["min"], result["max"] = list(lo), list(hi)
        if job.get("png"):
            render(job["png"], job["size"], lo, hi)
    return result


def main():
    jobs = json.load(open(sys.argv[1]))
    results = [check(j) for j in jobs]
    json.dump({"blender": bpy.app.version_string, "results": results}, open(sys.argv[2], "w"), indent=1)


main()
