"""The README's picture: MDG's own picture of an example beside Blender's render of
the `.glb` MDG wrote for it, made the way viewer/tests/clients.rs checks colours.

    mdg-run std/examples/tree.mdg -o /tmp/tree.glb --png /tmp/tree.png --size 400x300
    ~/.cache/mdg/bpy-venv/bin/python tests/clients/readme_picture.py \\
        /tmp/tree.glb /tmp/tree.png docs/img/tree-mdg-vs-blender.png

Blender's render (transparent film) is composited over the MDG picture's background
colour (its corner pixel), and the two are written side by side, MDG on the left.
"""

import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_check  # noqa: E402


def load(path):
    img = bpy.data.images.load(path)
    w, h = img.size
    px = np.array(img.pixels[:], dtype=np.float32).reshape(h, w, 4)
    return px


def main():
    glb, mdg_png, out = sys.argv[1:4]
    mdg = load(mdg_png)
    h, w = mdg.shape[:2]
    render = os.path.splitext(out)[0] + ".blender.tmp.png"
    blender_check.reset()
    bpy.ops.import_scene.gltf(filepath=glb)
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH" and len(o.data.polygons) > 0]
    lo, hi = blender_check.world_bounds(meshes)
    blender_check.render(render, (w, h), lo, hi)
    b = load(render)
    os.remove(render)
    bg = mdg[h - 1, 0, :3]  # Blender's pixel rows start at the bottom; any corner is background
    a = b[:, :, 3:4]
    over = np.concatenate([b[:, :, :3] * a + bg * (1 - a), np.ones_like(a)], axis=2)
    both = np.concatenate([mdg, over], axis=1)
    img = bpy.data.images.new("both", 2 * w, h, alpha=True)
    img.pixels[:] = both.ravel()
    img.filepath_raw = out
    img.file_format = "PNG"
    img.save()


main()
