"""The Blender extension in Blender 5 (PyPI `bpy`), against mdg-run.

    HOME=$(mktemp -d) BPY_PYTHON blender/tests/test_extension.py ZIP MDG_RUN

ZIP is the extension (blender/build.py); MDG_RUN the mdg-run binary. Run by .ci/run
(with a throw-away HOME: the extension is installed into Blender's user folder).
Installs the extension from the .zip as a user would, then:

* adds every std example with Add → MDG Model; for models, checks the objects, the
  number of instances Blender's depsgraph holds, the vertices (base mesh plus every
  instance's prototype) and the world bounds against the `.ply` mdg-run writes; for
  grammars with an extension section (mdg-run modes), that the add is refused with
  an error naming mdg-run;
* changes a `@param` in the sidebar's properties and sees the geometry change;
* breaks a grammar on disk, regenerates, and sees the error with its file and line;
* ticks Live reload and sees a changed file regenerate the model (one tick of the
  watcher: Blender's timers do not run in background mode);
* adds the animated robot arm and solar system (std/examples) and checks the armature
  (a bone per bone of mdg-run's .glb), the action's constant keys, the skinning, and
  that at times t Blender's evaluated (deformed) mesh has the bounds of the pose
  `mdg-run --time t` writes;
* adds camera_flyaround (a `camerarule`) and checks its camera against the camera
  of mdg-run's .glb (field of view, clipping planes, where it is at several times)
  and that it becomes the scene's camera only when the scene has none;
* renders the cube fractal (benches/workloads/cube_fractal.mdg, 262,144 instances)
  with Cycles and compares its mean colour with `mdg-run --png`'s picture.

Prints one line per check and closes with "blender: N passed, N failed"; exits 1 if
any failed. Its files (about 1 GB) are removed at the end unless MDG_BLENDER_KEEP is
set; MDG_BLENDER_ONLY=WORD runs only the checks whose name holds WORD.
"""

import math
import os
import pathlib
import subprocess
import shutil
import sys
import tempfile
import time
import traceback

import bpy
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODE_EXAMPLES = {"grid_cottage", "guided_tree", "guided_tree_paper", "monsters"}
# cli/tests/clients.rs' colour check: same light, same view, the chromaticities of
# the mean colours within 0.05. Per channel, clients.rs allows 0.2; the fractal
# needs 0.3: its 262,144 cubes fill 35% of their cells, and MDG's rasterised
# picture shows more of the dark gaps than Cycles' (measured at 320×240: MDG
# (0.215, 0.352, 0.323), Blender (0.349, 0.546, 0.526), chromaticities 0.015 apart).
CHROMA_TOLERANCE = 0.05
CHANNEL_TOLERANCE = 0.3
SIZE = (320, 240)
results = []


def check(name):
    def wrap(f):
        def run(*a):
            try:
                f(*a)
                results.append((name, True, ""))
                print(f"ok     {name}", flush=True)
            except Exception as e:  # every failure is reported, the others still run
                results.append((name, False, str(e)))
                print(f"FAILED {name}: {e}", flush=True)
                traceback.print_exc()

        return run

    return wrap


def mdg_run(*args):
    r = subprocess.run([MDG_RUN, *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"mdg-run {' '.join(map(str, args))}: {r.stderr}")


def read_ply(path):
    """Vertex positions and face count of mdg-run's binary PLY."""
    data = pathlib.Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    n = next(int(l.split()[2]) for l in header if l.startswith("element vertex"))
    faces = next(int(l.split()[2]) for l in header if l.startswith("element face"))
    props, in_vertex = [], False
    for l in header:
        if l.startswith("element"):
            in_vertex = l.startswith("element vertex")
        elif l.startswith("property") and in_vertex:
            props.append((l.split()[2], {"float": "<f4", "uchar": "u1", "int": "<i4", "uint": "<u4"}[l.split()[1]]))
    v = np.frombuffer(data, dtype=np.dtype(props), count=n, offset=end)
    return np.stack([v["x"], v["y"], v["z"]], axis=1), faces


def reset():
    """An empty scene, the extension still enabled (factory settings would drop it)."""
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.node_groups,
                 bpy.data.collections, bpy.data.lights, bpy.data.cameras, bpy.data.worlds, bpy.data.images,
                 bpy.data.armatures, bpy.data.actions):
        for item in list(coll):
            coll.remove(item)


def add(path):
    """Add → MDG Model: the operator's result (or the error it reported) and the object."""
    reset()
    try:
        r = bpy.ops.mdg.add_model(filepath=str(path))
    except RuntimeError as e:  # an operator's error report, raised in background mode
        return str(e), None
    return r, bpy.context.view_layer.objects.active


def blender_geometry(obj):
    """Instances, vertices and world bounds of what Blender evaluates for `obj`."""
    deps = bpy.context.evaluated_depsgraph_get()
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    vertices = len(obj.data.vertices)
    if vertices:
        co = np.empty(vertices * 3, np.float32)
        obj.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        lo, hi = np.minimum(lo, co.min(axis=0)), np.maximum(hi, co.max(axis=0))
    instances = 0
    for inst in deps.object_instances:
        if not inst.is_instance or inst.parent is None or inst.parent.original != obj.mdg.instancer:
            continue
        instances += 1
        me = inst.object.data
        vertices += len(me.vertices)
        m = np.array(inst.matrix_world)
        co = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", co)
        w = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
        lo, hi = np.minimum(lo, w.min(axis=0)), np.maximum(hi, w.max(axis=0))
    return instances, vertices, lo, hi


def example_check(path):
    @check(f"add {path.stem}")
    def run():
        r, obj = add(path)
        if path.stem in MODE_EXAMPLES:
            assert isinstance(r, str) and "mdg-run" in r, r
            return
        assert r == {"FINISHED"} and obj is not None and obj.mdg.error == "", (r, obj and obj.mdg.error)
        ply = pathlib.Path(TMP) / f"{path.stem}.ply"
        mdg_run(path, "-o", ply)
        want, _ = read_ply(ply)
        instances, vertices, lo, hi = blender_geometry(obj)
        points = len(obj.mdg.instancer.data.vertices) if obj.mdg.instancer is not None else 0
        assert instances == points, f"{instances} instances in Blender, {points} points"
        assert vertices == len(want), f"{vertices} vertices in Blender, {len(want)} in mdg-run's .ply"
        if len(want):
            span = max(float(np.ptp(want, axis=0).max()), 1e-6)
            tol = 1e-4 * span + 1e-6
            assert np.allclose(lo, want.min(axis=0), atol=tol), (lo, want.min(axis=0))
            assert np.allclose(hi, want.max(axis=0), atol=tol), (hi, want.max(axis=0))
        print(f"       {path.stem}: {vertices} vertices, {instances} instances", flush=True)

    run()


@check("a @param changed in the sidebar regenerates in place")
def param_changes_geometry():
    r, obj = add(ROOT / "std" / "examples" / "parametric_tree.mdg")
    assert r == {"FINISHED"}
    names = [p.name for p in obj.mdg.params]
    assert names == ["levels", "forks", "spread"], names
    before = len(obj.data.vertices)
    mesh = obj.data
    started = time.perf_counter()
    obj.mdg.params["levels"].value_int = 3
    seconds = time.perf_counter() - started
    after = len(obj.data.vertices)
    assert obj.data == mesh and bpy.data.objects.get("parametric_tree") == obj, "not regenerated in place"
    assert after != before and after > 0, (before, after)
    started = time.perf_counter()
    obj.mdg.use_seed = True
    obj.mdg.seed = 11
    print(f"       levels 5 -> 3: {before} -> {after} vertices in {seconds:.3f} s; seed {time.perf_counter() - started:.3f} s")


@check("a grammar error shows with its file and line")
def error_has_line():
    f = pathlib.Path(TMP) / "broken.mdg"
    f.write_text("@import primitives\nstartshape A\nrule A { cube {} }\n")
    r, obj = add(f)
    assert r == {"FINISHED"}
    f.write_text("@import primitives\nstartshape A\nrule A { cube {} }\nrule B { NOPE {} }\n")
    os.utime(f, (time.time() + 5, time.time() + 5))
    try:
        bpy.ops.mdg.regenerate()
        raise AssertionError("regenerating a broken grammar reported no error")
    except RuntimeError as e:  # the report, as background mode raises it
        assert "broken.mdg:4:10: E0301" in str(e), e
    assert "broken.mdg:4:10: E0301: unknown rule `NOPE`" in obj.mdg.error, obj.mdg.error


@check("live reload regenerates when the grammar file changes")
def live_reload():
    import importlib

    f = pathlib.Path(TMP) / "live.mdg"
    f.write_text("@import primitives\nstartshape A\nrule A { cube {} }\n")
    r, obj = add(f)
    assert r == {"FINISHED"}
    before = len(obj.data.vertices) + len(obj.mdg.instancer.data.vertices if obj.mdg.instancer else [])
    obj.mdg.live_reload = True
    # The extension's timer (bpy.app.timers does not fire in background mode): one tick.
    ext = importlib.import_module("bl_ext.user_default.mdg_grammars")
    assert ext.watch() == 0.5, "the watcher stopped with a live object"
    f.write_text("@import primitives\nstartshape A\nrule A { cube {} cube {x 2} cube {x 4} }\n")
    os.utime(f, (time.time() + 5, time.time() + 5))
    ext.watch()
    after = len(obj.data.vertices) + len(obj.mdg.instancer.data.vertices if obj.mdg.instancer else [])
    assert after == 3 * before and obj.mdg.error == "", (before, after, obj.mdg.error)
    obj.mdg.live_reload = False
    assert ext.watch() is None, "the watcher kept running with no live object"


def glb_json(path):
    """The JSON chunk of a .glb."""
    import json
    import struct

    data = pathlib.Path(path).read_bytes()
    length, kind = struct.unpack_from("<II", data, 12)
    assert kind == 0x4E4F534A, kind
    return json.loads(data[20 : 20 + length])


def evaluated_bounds(obj):
    """Vertex count and world bounds of `obj` as the depsgraph evaluates it (after its
    modifiers: the armature's deformation), with its instancer's instances."""
    deps = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(deps)
    me = ev.to_mesh()
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    ev.to_mesh_clear()
    m = np.array(ev.matrix_world)
    co = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    lo, hi, n, total = co.min(axis=0), co.max(axis=0), len(co), co.astype(np.float64).sum(axis=0)
    for inst in deps.object_instances:
        if not inst.is_instance or inst.parent is None or inst.parent.original != obj.mdg.instancer:
            continue
        im = inst.object.data
        c = np.empty(len(im.vertices) * 3, np.float32)
        im.vertices.foreach_get("co", c)
        mw = np.array(inst.matrix_world)
        w = c.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]
        lo, hi, n = np.minimum(lo, w.min(axis=0)), np.maximum(hi, w.max(axis=0)), n + len(w)
        total += w.sum(axis=0)
    centroid = total / max(n, 1)
    return n, lo, hi, centroid


def animated_armature(stem):
    @check(f"animated {stem} comes in as an armature with an action that poses it as mdg-run --time")
    def run():
        armature_check(ROOT / "std" / "examples" / f"{stem}.mdg")

    run()


def armature_check(src):
    r, obj = add(src)
    assert r == {"FINISHED"}, obj and obj.mdg.error
    glb = pathlib.Path(TMP) / f"{src.stem}.glb"
    mdg_run(src, "-o", glb)
    nodes = [n.get("name", "") for n in glb_json(glb)["nodes"]]
    want_bones = sum(1 for n in nodes if n.startswith("bone ") and not n.endswith(" root"))
    arm = obj.parent
    assert arm is not None and arm.type == "ARMATURE", f"no armature parent: {arm}"
    assert len(arm.data.bones) == want_bones and want_bones > 1, (len(arm.data.bones), want_bones, nodes)
    mod = next((m for m in obj.modifiers if m.type == "ARMATURE"), None)
    assert mod is not None and mod.object == arm, "the mesh is not deformed by the armature"
    assert len(obj.vertex_groups) > 0, "no vertex groups (skinning)"
    action = arm.animation_data.action if arm.animation_data else None
    assert action is not None, "no action"
    curves = [fc for layer in action.layers for strip in layer.strips for bag in strip.channelbags for fc in bag.fcurves]
    keys = sum(len(fc.keyframe_points) for fc in curves)
    assert curves and min(len(fc.keyframe_points) for fc in curves) > 1, (len(curves), keys)
    assert all(k.interpolation == "CONSTANT" for fc in curves for k in fc.keyframe_points), "not step keys"
    scene = bpy.context.scene
    fps = scene.render.fps / scene.render.fps_base
    rest = None
    # Times between frame changes of every bone (30, 60 and 120 frames per second).
    for t in (0.0, 0.37, 1.37, 2.71):
        frame = scene.frame_start + t * fps
        scene.frame_set(int(np.floor(frame)), subframe=float(frame - np.floor(frame)))
        n, lo, hi, centroid = evaluated_bounds(obj)
        ply = pathlib.Path(TMP) / f"{src.stem}-{t}.ply"
        mdg_run(src, "--time", t, "-o", ply)
        want, _ = read_ply(ply)
        assert n == len(want), f"t={t}: {n} vertices in Blender, {len(want)} in mdg-run's"
        tol = 1e-4 * float(np.ptp(want, axis=0).max())
        assert np.allclose(lo, want.min(axis=0), atol=tol) and np.allclose(hi, want.max(axis=0), atol=tol), (
            f"t={t}: Blender bounds {lo}..{hi}, mdg-run --time {want.min(axis=0)}..{want.max(axis=0)}"
        )
        # The centroid: every vertex counts, not only the extreme ones.
        want_c = want.astype(np.float64).mean(axis=0)
        assert np.allclose(centroid, want_c, atol=tol), f"t={t}: centroid {centroid}, mdg-run's {want_c}"
        if t == 0.0:
            rest = centroid
        else:
            assert not np.allclose(rest, centroid, atol=10 * tol), f"t={t}: the pose did not move"
        print(f"       t={t}: bounds {lo.round(3)} .. {hi.round(3)} as mdg-run --time {t}")
    print(f"       {src.stem}: {len(arm.data.bones)} bones, {len(curves)} F-curves, {keys} keys")


def read_accessor(glb, g, index):
    """A float accessor of a .glb as a flat array."""
    import struct

    data = pathlib.Path(glb).read_bytes()
    bin_start = 20 + struct.unpack_from("<I", data, 12)[0] + 8
    a = g["accessors"][index]
    view = g["bufferViews"][a["bufferView"]]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[a["type"]]
    offset = bin_start + view.get("byteOffset", 0) + a.get("byteOffset", 0)
    return np.frombuffer(data, dtype="<f4", count=a["count"] * width, offset=offset)


def glb_camera(glb):
    """mdg-run's camera in its .glb (in MDG's space, under the z-up root): yfov, near,
    far, and (translation, rotation (x, y, z, w)) at time t."""
    g = glb_json(glb)
    index = next(i for i, n in enumerate(g["nodes"]) if "camera" in n)
    node, lens = g["nodes"][index], g["cameras"][0]["perspective"]
    channels = {c["target"]["path"]: g["animations"][0]["samplers"][c["sampler"]]
                for c in g.get("animations", [{}])[0].get("channels", []) if c["target"]["node"] == index}

    def at(t):
        out = []
        for path, width, still in (("translation", 3, node["translation"]), ("rotation", 4, node["rotation"])):
            if path not in channels:
                out.append(np.array(still))
                continue
            times = read_accessor(glb, g, channels[path]["input"])
            values = read_accessor(glb, g, channels[path]["output"]).reshape(-1, width)
            out.append(values[int(np.searchsorted(times, t + 1e-6)) - 1])
        return out

    return lens["yfov"], lens["znear"], lens.get("zfar"), at


@check("a camerarule's camera comes in where mdg-run's picture has it, as the scene's camera")
def camera_check():
    from mathutils import Quaternion

    src = ROOT / "std" / "examples" / "camera_flyaround.mdg"
    r, obj = add(src)
    assert r == {"FINISHED"}, obj and obj.mdg.error
    cam = obj.mdg.camera
    assert cam is not None and cam.type == "CAMERA", cam
    scene = bpy.context.scene
    assert scene.camera == cam, scene.camera
    glb = pathlib.Path(TMP) / "camera.glb"
    mdg_run(src, "-o", glb)
    yfov, near, far, at = glb_camera(glb)
    d = cam.data
    assert d.sensor_fit == "VERTICAL" and abs(d.angle_y - yfov) < 1e-5, (d.sensor_fit, d.angle_y, yfov)
    assert abs(d.clip_start - near) < 1e-6 and abs(d.clip_end - far) < 1e-3, (d.clip_start, d.clip_end)
    fps = scene.render.fps / scene.render.fps_base
    for t in (0.0, 3.0, 7.51, 11.9):
        frame = scene.frame_start + t * fps
        scene.frame_set(int(np.floor(frame)), subframe=float(frame - np.floor(frame)))
        m = np.array(cam.matrix_world)
        want_t, (x, y, z, w) = at(t)
        want_r = np.array(Quaternion((w, x, y, z)).to_matrix())
        assert np.allclose(m[:3, 3], want_t, atol=1e-4), f"t={t}: at {m[:3, 3]}, mdg-run's {want_t}"
        assert np.allclose(m[:3, :3], want_r, atol=1e-4), f"t={t}: turned {m[:3, :3]}, mdg-run's {want_r}"
        print(f"       t={t}: camera at {m[:3, 3].round(3)} as mdg-run's")
    # A scene that has a camera keeps it.
    reset()
    mine = bpy.data.objects.new("mine", bpy.data.cameras.new("mine"))
    scene.collection.objects.link(mine)
    scene.camera = mine
    assert bpy.ops.mdg.add_model(filepath=str(src)) == {"FINISHED"}
    added = bpy.context.view_layer.objects.active
    assert added.mdg.camera is not None and scene.camera == mine, scene.camera
    # Without a camerarule: no camera.
    r, obj = add(ROOT / "std" / "examples" / "tree.mdg")
    assert r == {"FINISHED"} and obj.mdg.camera is None and not bpy.data.cameras


def mean_colour(px, bg):
    """Mean RGB of the pixels (composited over bg) that differ from bg by > 6/255."""
    rgb = px[:, :3] * px[:, 3:4] + bg * (1 - px[:, 3:4])
    keep = (np.abs(rgb - bg) > 6 / 255).any(axis=1)
    return rgb[keep].mean(axis=0), int(keep.sum())


def pixels(path):
    img = bpy.data.images.load(str(path))
    px = np.array(img.pixels[:], dtype=np.float64).reshape(-1, 4)
    bpy.data.images.remove(img)
    return px


@check("the cube fractal renders in the colours of mdg-run --png")
def fractal_render():
    sys.path.insert(0, str(ROOT / "tests" / "clients"))
    import blender_check  # the render set-up of cli/tests/clients.rs (MDG's view and light)
    from mathutils import Vector

    src = ROOT / "benches" / "workloads" / "cube_fractal.mdg"
    mdg_png = pathlib.Path(TMP) / "fractal-mdg.png"
    mdg_run(src, "--max-vertices", "20000000", "-o", mdg_png, "--size", f"{SIZE[0]}x{SIZE[1]}")
    started = time.perf_counter()
    r, obj = add(src)
    seconds = time.perf_counter() - started
    assert r == {"FINISHED"}, obj and obj.mdg.error
    instances = len(obj.mdg.instancer.data.vertices)
    assert instances == 262_144, instances
    # The bounds of the instances (from the points' attributes and the prototype's
    # corners), framed as MDG frames them.
    me = obj.mdg.instancer.data
    k = len(me.vertices)
    t, q, sc = np.empty(3 * k, np.float32), np.empty(4 * k, np.float32), np.empty(3 * k, np.float32)
    me.vertices.foreach_get("co", t)
    me.attributes["rotation"].data.foreach_get("value", q)
    me.attributes["scale"].data.foreach_get("vector", sc)
    t, q, sc = t.reshape(-1, 3), q.reshape(-1, 4).astype(np.float64), sc.reshape(-1, 3)
    proto = next(iter(bpy.data.collections[f"{obj.name} prototypes"].objects)).data
    pc = np.empty(3 * len(proto.vertices), np.float32)
    proto.vertices.foreach_get("co", pc)
    pc = pc.reshape(-1, 3)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for corner in np.array(np.meshgrid(*zip(pc.min(axis=0), pc.max(axis=0)))).reshape(3, -1).T:
        v = corner * sc
        w, u = q[:, :1], q[:, 1:]
        c = 2.0 * np.cross(u, v)
        world = t + v + w * c + np.cross(u, c)
        lo, hi = np.minimum(lo, world.min(axis=0)), np.maximum(hi, world.max(axis=0))
    lo, hi = Vector(lo), Vector(hi)
    print(f"       fractal bounds {tuple(lo)} .. {tuple(hi)}")
    out = pathlib.Path(os.environ.get("MDG_BLENDER_PICTURE") or pathlib.Path(TMP) / "fractal-blender.png")
    blender_check.render(str(out), SIZE, lo, hi)
    mdg_px = pixels(mdg_png)
    bg = mdg_px[0, :3]
    want, n_mdg = mean_colour(mdg_px, bg)
    got, n_blender = mean_colour(pixels(out), bg)
    chroma = lambda c: c / max(c.sum(), 1e-9)  # noqa: E731
    print(f"       fractal: added in {seconds:.1f} s; mean colour MDG {want.round(3)} ({n_mdg} px), "
          f"Blender {got.round(3)} ({n_blender} px)")
    assert n_blender > 0.2 * n_mdg, (n_blender, n_mdg)
    assert np.abs(chroma(want) - chroma(got)).max() <= CHROMA_TOLERANCE, (want, got)
    assert np.abs(want - got).max() <= CHANNEL_TOLERANCE, (want, got)


def main():
    global MDG_RUN, TMP
    zip_path, MDG_RUN = sys.argv[1], sys.argv[2]
    TMP = tempfile.mkdtemp(prefix="mdg-blender-")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    r = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
    assert r == {"FINISHED"}, r
    assert hasattr(bpy.ops.mdg, "add_model"), "the extension did not register"
    # MDG_BLENDER_ONLY=WORD: only the checks whose name holds WORD.
    only = os.environ.get("MDG_BLENDER_ONLY", "")
    for path in sorted((ROOT / "std" / "examples").glob("*.mdg")):
        if only in f"add {path.stem}":
            example_check(path)
    for name, f in [("param", param_changes_geometry), ("error", error_has_line), ("reload", live_reload),
                    ("camera", camera_check),
                    ("fractal", fractal_render)]:
        if only in name or not only:
            f()
    for stem in ("robot_arm", "solar_system"):
        if only in f"animated {stem}":
            animated_armature(stem)
    failed = [r for r in results if not r[1]]
    for name, _, why in failed:
        print(f"FAILED {name}: {why}")
    print(f"blender: {len(results) - len(failed)} passed, {len(failed)} failed", flush=True)
    sys.stdout.flush()
    # os._exit skips every clean-up: the fractal's files alone are about 1 GB.
    if not os.environ.get("MDG_BLENDER_KEEP"):
        shutil.rmtree(TMP, ignore_errors=True)
    else:
        print(f"blender: files kept in {TMP}", flush=True)
    os._exit(1 if failed or not results else 0)


main()
