"""Times the Blender extension (issue 40's targets), inside Blender (PyPI `bpy`):

    HOME=$(mktemp -d) BPY_PYTHON blender/bench.py ZIP [--pictures DIR]

ZIP is the extension (blender/build.py; build it with the release profile for real
numbers). Installs it, then measures:

* Add → MDG Model of the 262,144-cube fractal (benches/workloads/cube_fractal.mdg):
  wall time of the operator (compile, evaluate, build the point mesh, the prototype
  and the geometry nodes) and of the first depsgraph evaluation that instances the
  cubes, and the process's peak resident memory after both (target: ≤ 20 s,
  ≤ 1.5 GB);
* changing a `@param` of a std example (parametric_tree's `levels`, 5 → 4 → 5) until
  the object holds the new geometry (target: ≤ 0.5 s), the median of 5.

With --pictures DIR, also renders (Cycles, MDG's home view and light as
tests/clients/blender_check.py sets them up) the fractal and a std example through
the extension into DIR/blender-cube-fractal.png and DIR/blender-city-block.png, and
camera_flyaround through its own `camerarule` camera into
DIR/blender-camera-flyaround.png;
with --mdg-run PATH too, compares the fractal's mean colour with the picture
`mdg-run --png` draws of it (the pixels that are not background, as
blender/tests/test_extension.py compares them).
"""

import argparse
import pathlib
import resource
import statistics
import sys
import time

import bpy
import numpy as np
from mathutils import Vector

ROOT = pathlib.Path(__file__).resolve().parents[1]


def peak_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def clear():
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.node_groups,
                 bpy.data.collections, bpy.data.lights, bpy.data.cameras, bpy.data.worlds):
        for item in list(coll):
            coll.remove(item)


def bounds(obj):
    """World bounds of the base mesh and of the instances (points ⊕ prototype box)."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    if len(obj.data.vertices):
        co = np.empty(3 * len(obj.data.vertices), np.float32)
        obj.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        lo, hi = co.min(axis=0), co.max(axis=0)
    inst = obj.mdg.instancer
    if inst is not None and len(inst.data.vertices):
        me = inst.data
        t = np.empty(3 * len(me.vertices), np.float32)
        me.vertices.foreach_get("co", t)
        t = t.reshape(-1, 3)
        sc = np.empty(3 * len(me.vertices), np.float32)
        me.attributes["scale"].data.foreach_get("vector", sc)
        reach = np.abs(sc.reshape(-1, 3)).max(axis=1, keepdims=True) * 0.87
        lo, hi = np.minimum(lo, (t - reach).min(axis=0)), np.maximum(hi, (t + reach).max(axis=0))
    return Vector(lo), Vector(hi)


def render(obj, path, size):
    sys.path.insert(0, str(ROOT / "tests" / "clients"))
    import blender_check

    lo, hi = bounds(obj)
    blender_check.render(str(path), size, lo, hi)


def mean_colours(mdg_run, src, picture, size):
    import subprocess
    import tempfile

    def pixels(path):
        img = bpy.data.images.load(str(path))
        px = np.array(img.pixels[:], dtype=np.float64).reshape(-1, 4)
        bpy.data.images.remove(img)
        return px

    def mean(px, bg):
        rgb = px[:, :3] * px[:, 3:4] + bg * (1 - px[:, 3:4])
        keep = (np.abs(rgb - bg) > 6 / 255).any(axis=1)
        return rgb[keep].mean(axis=0)

    with tempfile.TemporaryDirectory() as tmp:
        png = pathlib.Path(tmp) / "mdg.png"
        subprocess.run([mdg_run, str(src), "--max-vertices", "20000000", "-o", str(png), "--size",
                        f"{size[0]}x{size[1]}"], check=True, capture_output=True)
        want = pixels(png)
    bg = want[0, :3]
    a, b = mean(want, bg), mean(pixels(picture), bg)
    chroma = lambda c: c / max(c.sum(), 1e-9)  # noqa: E731
    print(f"cube fractal render: mean colour mdg-run --png {a.round(3)}, Blender {b.round(3)}; chromaticities "
          f"{np.abs(chroma(a) - chroma(b)).max():.3f} apart", flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("zip")
    ap.add_argument("--pictures")
    ap.add_argument("--mdg-run")
    args = ap.parse_args(sys.argv[1:])
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.ops.extensions.package_install_files(filepath=args.zip, repo="user_default", enable_on_install=True) == {"FINISHED"}
    before = peak_mib()
    src = ROOT / "benches" / "workloads" / "cube_fractal.mdg"
    started = time.perf_counter()
    assert bpy.ops.mdg.add_model(filepath=str(src)) == {"FINISHED"}
    added = time.perf_counter() - started
    obj = bpy.context.view_layer.objects.active
    deps = bpy.context.evaluated_depsgraph_get()
    deps.update()
    evaluated = time.perf_counter() - started
    n = sum(1 for i in deps.object_instances if i.is_instance)
    print(f"cube fractal: {n} instances; Add > MDG Model {added:.2f} s, with the depsgraph's instancing "
          f"{evaluated:.2f} s; peak memory {peak_mib():.0f} MiB (Blender alone {before:.0f} MiB)", flush=True)
    if args.pictures:
        out = pathlib.Path(args.pictures)
        out.mkdir(parents=True, exist_ok=True)
        render(obj, out / "blender-cube-fractal.png", (640, 480))
        if args.mdg_run:
            mean_colours(args.mdg_run, src, out / "blender-cube-fractal.png", (640, 480))
    clear()
    assert bpy.ops.mdg.add_model(filepath=str(ROOT / "std" / "examples" / "parametric_tree.mdg")) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    times = []
    for levels in (4, 5, 4, 5, 4):
        started = time.perf_counter()
        obj.mdg.params["levels"].value_int = levels
        times.append(time.perf_counter() - started)
    print(f"parametric_tree: levels changed in {statistics.median(times) * 1000:.0f} ms (median of 5; "
          f"{len(obj.data.vertices)} vertices, {len(obj.mdg.instancer.data.vertices)} instances)", flush=True)
    if args.pictures:
        clear()
        assert bpy.ops.mdg.add_model(filepath=str(ROOT / "std" / "examples" / "city_block.mdg")) == {"FINISHED"}
        render(bpy.context.view_layer.objects.active, pathlib.Path(args.pictures) / "blender-city-block.png", (640, 480))
        # Through a grammar's own camera (its camerarule), as mdg-run --png shows it.
        clear()
        assert bpy.ops.mdg.add_model(filepath=str(ROOT / "std" / "examples" / "camera_flyaround.mdg")) == {"FINISHED"}
        obj = bpy.context.view_layer.objects.active
        scratch = pathlib.Path(args.pictures) / "blender-camera-flyaround-home.png"
        render(obj, scratch, (640, 480))  # MDG's light and world (and a picture from the home view)
        scratch.unlink()
        scene = bpy.context.scene
        scene.camera = obj.mdg.camera
        scene.render.filepath = str(pathlib.Path(args.pictures) / "blender-camera-flyaround.png")
        bpy.ops.render.render(write_still=True)


main()
