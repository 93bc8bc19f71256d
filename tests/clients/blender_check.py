"""Imports .glb files into Blender (PyPI `bpy`, headless) and reports what it got.

Run by cli/tests/clients.rs as `python blender_check.py JOBS.json RESULT.json`:
JOBS.json is a list of {"name", "glb", "png", "size": [w, h]}. For each file, from an
empty scene: import it with Blender's own glTF importer, then record the import
time, the mesh objects and their vertex and polygon counts (Blender's importer makes
an object of every EXT_mesh_gpu_instancing instance, all sharing one mesh), the
world bounding box (Blender is z up, like MDG), the actions, and, when `png` is
not null, render it with Cycles on the CPU from
MDG's home view (azimuth 35°, elevation 25°, vertical field of view 40°, the
bounding sphere framed) into `png`, transparent where nothing was hit, "Standard"
view transform (no tone mapping). The light imitates MDG's pictures (display colour
times 0.15 + 0.85·max(n·l, 0), l MDG's default key light): a sun without shadows
from l whose strength shows a lit face in its own colour, and a uniform world of
0.15 in display terms (0.15^2.2 linear). One Blender process for every file. An
import that raises is recorded as an error, not fatal.

With MDG_WASHED_OUT=1 every imported colour c is replaced by linear_to_srgb(c),
which is what a file that stores display colours as glTF's linear ones shows: the
test's tolerance is measured against that.
"""

import json
import math
import os
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
    world = bpy.data.worlds.new("ambient")
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    bg.inputs[0].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs[1].default_value = 0.15**2.2
    scene.world = world
    center = (lo + hi) * 0.5
    radius = max((hi - lo).length * 0.5, 1e-4)
    # MDG's default key light (viewer/src/uniforms.rs, default_light).
    haz, hel = math.radians(35.0), math.radians(25.0)
    toward = Vector((math.cos(hel) * math.sin(haz), -math.cos(hel) * math.cos(haz), math.sin(hel)))
    right = Vector((0.0, 0.0, 1.0)).cross(toward).normalized()
    light_dir = (toward * 0.5 + Vector((0.0, 0.0, 0.8)) - right * 0.1).normalized()
    sun_data = bpy.data.lights.new("key", type="SUN")
    sun_data.energy = math.pi * (1.0 - 0.15**2.2)  # a face towards it: radiance = albedo
    sun_data.use_shadow = False
    sun_data.angle = 0.0
    sun = bpy.data.objects.new("key", sun_data)
    scene.collection.objects.link(sun)
    sun.rotation_euler = (-light_dir).to_track_quat("-Z", "Y").to_euler()
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


def to_srgb(c):
    return c * 12.92 if c <= 0.0031308 else 1.055 * c ** (1.0 / 2.4) - 0.055


def wash_out():
    for me in bpy.data.meshes:
        for attr in me.color_attributes:
            for d in attr.data:
                r, g, b, a = d.color
                d.color = (to_srgb(r), to_srgb(g), to_srgb(b), a)
    for mat in bpy.data.materials:
        if mat.node_tree is None:
            continue
        for node in mat.node_tree.nodes:
            if node.type == "BSDF_PRINCIPLED":
                r, g, b, a = node.inputs["Base Color"].default_value
                node.inputs["Base Color"].default_value = (to_srgb(r), to_srgb(g), to_srgb(b), a)


def check(job):
    reset()
    started = time.monotonic()
    try:
        bpy.ops.import_scene.gltf(filepath=job["glb"])
    except Exception as e:  # the importer's own error, reported to the test
        return {"name": job["name"], "error": str(e)}
    seconds = time.monotonic() - started
    if os.environ.get("MDG_WASHED_OUT") == "1":
        wash_out()
    # The importer adds a mesh (an icosphere) as the custom shape of the bones: not
    # the model's; removed before counting and rendering.
    shapes = {
        pb.custom_shape
        for o in bpy.context.scene.objects
        if o.type == "ARMATURE"
        for pb in o.pose.bones
        if pb.custom_shape is not None
    }
    for o in shapes:
        bpy.data.objects.remove(o, do_unlink=True)
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    tri_objects = [o for o in meshes if len(o.data.polygons) > 0]
    result = {
        "name": job["name"],
        "import_seconds": seconds,
        "mesh_objects": len(meshes),
        # Objects whose mesh data other objects use too (linked duplicates: what the
        # importer makes of EXT_mesh_gpu_instancing's instances), and empties.
        "shared_mesh_objects": len([o for o in meshes if o.data.users > 1]),
        "empties": len([o for o in bpy.context.scene.objects if o.type == "EMPTY"]),
        "vertices": sum(len(o.data.vertices) for o in tri_objects),
        "polygons": sum(len(o.data.polygons) for o in tri_objects),
        "line_edges": sum(len(o.data.edges) for o in meshes if len(o.data.polygons) == 0),
        "actions": sorted(a.name for a in bpy.data.actions),
        "armatures": len([o for o in bpy.context.scene.objects if o.type == "ARMATURE"]),
        "bone_shapes_removed": len(shapes),
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


if __name__ == "__main__":
    main()
