"""MDG shape grammars in Blender (a Blender 4.2+ extension built on the `mdg` wheel).

Add → MDG Model reads a `.mdg` grammar (or a compiled `.mdgb` bundle) and makes:

* `NAME`: a mesh object with the model's flat geometry (triangles, sweeps,
  isosurfaces), its colours in the point colour attribute `mdg_color`, which the
  material `MDG vertex colour` reads;
* `NAME instances` (when the model has prototype instances): a mesh of one point per
  instance, with the point attributes `rotation` (quaternion), `scale` (vector),
  `proto` (which prototype) and `mdg_color`, and a geometry-nodes modifier that puts
  an instance of the prototype on every point (Blender draws and renders them
  without an object per copy); the material `MDG instance colour` reads the colour
  from the instancer. The prototypes are objects of the collection `NAME prototypes`,
  which is not linked into the scene.

An animated grammar (model rules with transform rules: bones) also makes
`NAME rig`, an armature with one bone per MDG bone (nested as MDG nests them, each
at its rule's frame, pointing along the frame's z axis), the parent of `NAME`,
which it deforms (an Armature modifier; vertex group per bone, weight 1), and the
action `NAME motion`: per bone, location/rotation/scale keys at every frame index
i = 0..⌊duration·fps⌋ (time i/fps), constant interpolation, so that the pose at
time t is the one `mdg-run --time t` writes (as mdg-run's glTF animation, STEP).
Animated prototype instances are expanded into `NAME` to follow their bones.

A grammar with a `camerarule` also makes `NAME camera`, a camera placed as
mdg-run's picture places it (with the grammar's field of view and clipping planes),
keyed over the duration when it moves (the action `NAME camera motion`); adding the
model makes it the scene's camera when the scene has none.

The sidebar (N panel, tab MDG) shows the seed, the grammar's `@param`s and presets;
changing one regenerates the model in place. `Live reload` watches the file.
Errors show in Blender's report area (and the panel) with the grammar's file and line.
"""

import os
import time

import bpy
import numpy as np
from mathutils import Matrix
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

import mdg

# Compiled programs by (path, modification time); a changed file compiles again.
_programs = {}
# While filling the properties from a grammar, updates must not regenerate.
_loading = set()


def srgb_to_linear(c):
    """MDG's display colours (sRGB) to Blender's scene-linear colours."""
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def colors_linear(rgba):
    out = np.empty_like(rgba, dtype=np.float32)
    out[:, :3] = srgb_to_linear(rgba[:, :3])
    out[:, 3] = rgba[:, 3]
    return out


class MdgError(Exception):
    """A grammar error, with the report text (file:line: code: message)."""


def program_for(path):
    path = bpy.path.abspath(path)
    try:
        mtime = os.path.getmtime(path)
    except OSError as e:
        raise MdgError(f"cannot read {path}: {e.strerror}") from None
    key = (path, mtime)
    if key not in _programs:
        try:
            program = mdg.compile(path)
        except mdg.CompileError as e:
            raise MdgError(first_error(e)) from None
        except (OSError, ValueError) as e:
            raise MdgError(str(e)) from None
        for k in [k for k in _programs if k[0] == path]:
            del _programs[k]
        _programs[key] = program
    return _programs[key]


def first_error(e):
    errors = [d for d in e.diagnostics if d.severity == "error"] or list(e.diagnostics)
    if not errors:
        return str(e)
    d = errors[0]
    more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
    return f"{d.file}:{d.line}:{d.column}: {d.code}: {d.message}{more}"


# ---------------------------------------------------------------------------
# Geometry


def fill_mesh(me, positions, triangles, colors):
    """Replaces `me`'s geometry: vertices, triangles, point colours `mdg_color`."""
    me.clear_geometry()
    n, m = len(positions), len(triangles)
    me.vertices.add(n)
    me.vertices.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).ravel())
    if m:
        me.loops.add(3 * m)
        me.loops.foreach_set("vertex_index", triangles.astype(np.int32).ravel())
        me.polygons.add(m)
        me.polygons.foreach_set("loop_start", np.arange(0, 3 * m, 3, dtype=np.int32))
    me.update(calc_edges=True)
    attr = me.color_attributes.new("mdg_color", "FLOAT_COLOR", "POINT")
    if n:
        attr.data.foreach_set("color", colors_linear(colors).ravel())
    me.color_attributes.active_color = attr
    me.color_attributes.render_color_index = me.color_attributes.active_color_index


def quat_rotate(q, v):
    """Rotates vectors v (n, 3) by unit quaternions q (n, 4: w, x, y, z)."""
    w, u = q[:, :1], q[:, 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def expand(inst, which):
    """Instances `which` (indices) in world space: positions, triangles, colours."""
    pos, tri, col = [], [], []
    base = 0
    for k in which:
        p = inst.prototypes[inst.prototype[k]]
        q = np.repeat(inst.rotation[k : k + 1].astype(np.float64), len(p.positions), axis=0)
        world = inst.translation[k] + quat_rotate(q, p.positions * inst.scale[k])
        pos.append(world.astype(np.float32))
        t = p.triangles.astype(np.int64)
        if np.linalg.det(np.diag(inst.scale[k])) < 0:
            t = t[:, [0, 2, 1]]
        tri.append(t + base)
        col.append(np.clip(inst.color[k] + p.colors, 0.0, 1.0).astype(np.float32))
        base += len(p.positions)
    if not pos:
        return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64), np.zeros((0, 4), np.float32)
    return np.concatenate(pos), np.concatenate(tri), np.concatenate(col)


def material(name, attribute_type):
    """A material whose base colour is the attribute `mdg_color` (of the geometry or
    of the instancer)."""
    mat = bpy.data.materials.get(name)
    if mat is not None:
        return mat
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    bsdf = nodes.get("Principled BSDF")
    attr = nodes.new("ShaderNodeAttribute")
    attr.attribute_type = attribute_type
    attr.attribute_name = "mdg_color"
    attr.location = (-300, 200)
    mat.node_tree.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
    # Matte, as MDG draws and as glTF files come in (roughness 1, not metallic).
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Metallic"].default_value = 0.0
    return mat


def instancer_nodes():
    """The geometry-nodes group that instances the prototypes on the points."""
    ng = bpy.data.node_groups.get("MDG instance on points")
    if ng is not None:
        return ng
    ng = bpy.data.node_groups.new("MDG instance on points", "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Prototypes", in_out="INPUT", socket_type="NodeSocketCollection")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    n, link = ng.nodes, ng.links.new
    gi, go = n.new("NodeGroupInput"), n.new("NodeGroupOutput")
    info = n.new("GeometryNodeCollectionInfo")
    info.inputs["Separate Children"].default_value = True
    info.inputs["Reset Children"].default_value = True
    iop = n.new("GeometryNodeInstanceOnPoints")
    iop.inputs["Pick Instance"].default_value = True

    def named(name, data_type):
        a = n.new("GeometryNodeInputNamedAttribute")
        a.data_type = data_type
        a.inputs["Name"].default_value = name
        return a.outputs["Attribute"]

    link(gi.outputs["Geometry"], iop.inputs["Points"])
    link(gi.outputs["Prototypes"], info.inputs["Collection"])
    link(info.outputs["Instances"], iop.inputs["Instance"])
    link(named("proto", "INT"), iop.inputs["Instance Index"])
    link(named("rotation", "QUATERNION"), iop.inputs["Rotation"])
    link(named("scale", "FLOAT_VECTOR"), iop.inputs["Scale"])
    link(iop.outputs["Instances"], go.inputs["Geometry"])
    return ng


def point_attr(me, name, kind, values, key):
    a = me.attributes.get(name)
    if a is not None:
        me.attributes.remove(a)
    a = me.attributes.new(name, kind, "POINT")
    if len(values):
        a.data.foreach_set(key, np.ascontiguousarray(values).ravel())


def build(obj, model):
    """Puts `model` into `obj` (the base mesh), its instancer child and, for an
    animated model, its armature parent, in place."""
    name = obj.name
    inst = model.instances
    animated = len(model.bones) > 1
    # Instances whose prototype adds colours per vertex cannot take one colour per
    # instance: they are expanded into the base mesh (exact colours). So are the
    # instances of a moving bone: the base mesh's vertices follow the bones.
    deltas = np.array([bool(np.any(p.colors != 0)) for p in inst.prototypes], dtype=bool)
    keep = ~deltas[inst.prototype] if len(inst) else np.zeros(0, dtype=bool)
    if animated and len(inst):
        keep &= inst.bone == 0
    base = model.base_mesh
    pos, tri, col = base.positions, base.triangles.astype(np.int64), base.colors
    bones = base.bones if base.bones is not None else np.zeros(len(pos), np.uint32)
    if len(inst) and not keep.all():
        which = np.nonzero(~keep)[0]
        ep, et, ec = expand(inst, which)
        sizes = np.array([len(inst.prototypes[inst.prototype[k]].positions) for k in which], dtype=np.int64)
        bones = np.concatenate([bones, np.repeat(inst.bone[which], sizes)])
        tri = np.concatenate([tri, et + len(pos)])
        pos, col = np.concatenate([pos, ep]), np.concatenate([col, ec])
    fill_mesh(obj.data, pos, tri, col)
    rig(obj, model, bones if animated else None)
    camera(obj, model)
    if not obj.data.materials:
        obj.data.materials.append(material("MDG vertex colour", "GEOMETRY"))
    inst_obj = obj.mdg.instancer
    kept = np.nonzero(keep)[0]
    if len(kept) == 0:
        if inst_obj is not None:
            inst_obj.hide_viewport = inst_obj.hide_render = True
            inst_obj.data.clear_geometry()
        return
    coll = bpy.data.collections.get(f"{name} prototypes") or bpy.data.collections.new(f"{name} prototypes")
    for o in list(coll.objects):
        me = o.data
        bpy.data.objects.remove(o)
        if me is not None and me.users == 0:
            bpy.data.meshes.remove(me)
    inst_mat = material("MDG instance colour", "INSTANCER")
    for i, p in enumerate(inst.prototypes):
        me = bpy.data.meshes.new(f"{name} prototype {i:04d}")
        fill_mesh(me, p.positions, p.triangles, np.ones((len(p.positions), 4), np.float32))
        me.materials.append(inst_mat)
        # Collection Info lists the children by name: the index is in it.
        coll.objects.link(bpy.data.objects.new(f"{name} prototype {i:04d}", me))
    if inst_obj is None:
        me = bpy.data.meshes.new(f"{name} instances")
        inst_obj = bpy.data.objects.new(f"{name} instances", me)
        for c in obj.users_collection:
            c.objects.link(inst_obj)
        inst_obj.parent = obj
        obj.mdg.instancer = inst_obj
        mod = inst_obj.modifiers.new("MDG instances", "NODES")
        mod.node_group = instancer_nodes()
    inst_obj.hide_viewport = inst_obj.hide_render = False
    mod = inst_obj.modifiers.get("MDG instances")
    mod[mod.node_group.interface.items_tree["Prototypes"].identifier] = coll
    me = inst_obj.data
    me.clear_geometry()
    me.vertices.add(len(kept))
    me.vertices.foreach_set("co", inst.translation[kept].ravel())
    point_attr(me, "rotation", "QUATERNION", inst.rotation[kept], "value")
    point_attr(me, "scale", "FLOAT_VECTOR", inst.scale[kept], "vector")
    point_attr(me, "proto", "INT", inst.prototype[kept].astype(np.int32), "value")
    point_attr(me, "mdg_color", "FLOAT_COLOR", colors_linear(inst.color[kept]), "color")
    me.update()
    inst_obj.update_tag()


# ---------------------------------------------------------------------------
# Animation: an armature and an action


def bone_name(model_bones, b):
    """The Blender name of MDG bone b (rule names repeat; the index makes it unique)."""
    return f"{b:03d} {model_bones[b]['rule']}"


def frame_index(t, fps):
    """⌊t·fps⌋ with the VM's snapping (mdg_vm::anim::frame_index)."""
    x = t * fps
    if not (np.isfinite(x) and x > 0):
        return 0
    k = round(x)
    return int(k if abs(x - k) <= 1e-6 * max(k, 1.0) else np.floor(x))


# The rest matrix of a bone relative to its MDG frame's rotation: Blender bones point
# along their y axis; MDG's limbs mostly grow along z (a turn of 90° about x).
Y_TO_Z = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=np.float64)


def similarity(m):
    """Uniform scale s (negative for a mirror) and rotation R of a 3×3 s·R."""
    det = float(np.linalg.det(m))
    s = float(np.cbrt(det))
    if abs(s) < 1e-12 or not np.isfinite(s):
        return 0.0, np.eye(3)
    return s, m / s


def set_edit_mode(arm, mode):
    """Switches `arm` to `mode` ('EDIT'/'OBJECT'), making it the active object."""
    view_layer = bpy.context.view_layer
    view_layer.objects.active = arm
    with bpy.context.temp_override(active_object=arm, object=arm, selected_objects=[arm]):
        bpy.ops.object.mode_set(mode=mode)


def remove_rig(obj):
    arm = obj.mdg.armature
    if arm is None:
        return
    mod = obj.modifiers.get("MDG armature")
    if mod is not None:
        obj.modifiers.remove(mod)
    world = obj.matrix_world.copy()
    obj.parent = None
    obj.matrix_world = world
    data, action = arm.data, arm.animation_data.action if arm.animation_data else None
    bpy.data.objects.remove(arm)
    if data.users == 0:
        bpy.data.armatures.remove(data)
    if action is not None and action.users == 0:
        bpy.data.actions.remove(action)
    obj.mdg.armature = None
    for g in list(obj.vertex_groups):
        obj.vertex_groups.remove(g)


def rig(obj, model, vertex_bones):
    """The armature `NAME rig` for an animated model (vertex_bones: each vertex of
    obj's mesh's MDG bone), or none for a static one."""
    if vertex_bones is None:
        remove_rig(obj)
        return
    name = obj.name
    mb = model.bones
    arm = obj.mdg.armature
    if arm is None:
        arm = bpy.data.objects.new(f"{name} rig", bpy.data.armatures.new(f"{name} rig"))
        for c in obj.users_collection:
            c.objects.link(arm)
        arm.matrix_world = obj.matrix_world
        obj.parent = arm
        obj.matrix_parent_inverse.identity()
        obj.matrix_basis.identity()
        obj.mdg.armature = arm
    if not arm.users_collection:
        bpy.context.scene.collection.objects.link(arm)
    # The bones, rebuilt: at the rule's frame, rotated so that they point along z.
    active, mode = bpy.context.view_layer.objects.active, bpy.context.mode
    hidden = arm.hide_get(), arm.hide_viewport
    arm.hide_set(False)
    arm.hide_viewport = False
    if mode != "OBJECT" and active is not None:
        with bpy.context.temp_override(active_object=active, object=active):
            bpy.ops.object.mode_set(mode="OBJECT")
    set_edit_mode(arm, "EDIT")
    try:
        eb = arm.data.edit_bones
        for b in list(eb):
            eb.remove(b)
        made = {}
        for b in range(1, len(mb)):
            rest = np.asarray(mb[b]["rest"], dtype=np.float64)
            s, rot = similarity(rest[:3, :3])
            e = eb.new(bone_name(mb, b))
            e.head = (0.0, 0.0, 0.0)
            e.tail = (0.0, max(abs(s), 1e-3) * 0.5, 0.0)
            m = np.eye(4)
            m[:3, :3] = rot @ Y_TO_Z
            m[:3, 3] = rest[:3, 3]
            e.matrix = Matrix([list(r) for r in m])
            parent = int(mb[b]["parent"])
            if parent in made:
                e.parent = made[parent]
            made[b] = e
    finally:
        set_edit_mode(arm, "OBJECT")
        arm.hide_set(hidden[0])
        arm.hide_viewport = hidden[1]
        bpy.context.view_layer.objects.active = active
    # Skinning: a vertex group per bone, weight 1 (MDG's vertices follow one bone).
    for g in list(obj.vertex_groups):
        obj.vertex_groups.remove(g)
    order = np.argsort(vertex_bones, kind="stable")
    sorted_bones = vertex_bones[order]
    for b in np.unique(sorted_bones):
        if b == 0 or b >= len(mb):
            continue
        lo, hi = np.searchsorted(sorted_bones, [b, b + 1])
        obj.vertex_groups.new(name=bone_name(mb, int(b))).add(order[lo:hi].tolist(), 1.0, "REPLACE")
    mod = obj.modifiers.get("MDG armature") or obj.modifiers.new("MDG armature", "ARMATURE")
    mod.object = arm
    mod.use_vertex_groups = True
    mod.use_bone_envelopes = False
    animate(arm, model)


def animate(arm, model):
    """The action `NAME motion`: the bones' local transforms at every frame index."""
    mb = model.bones
    scene = bpy.context.scene
    fps = scene.render.fps / scene.render.fps_base
    start = scene.frame_start
    old = arm.animation_data.action if arm.animation_data else None
    action = bpy.data.actions.new(arm.name.removesuffix(" rig") + " motion")
    arm.animation_data_create()
    arm.animation_data.action = action
    if old is not None and old.users == 0:
        bpy.data.actions.remove(old)
    rest = {b.name: np.array(b.matrix_local, dtype=np.float64) for b in arm.data.bones}
    duration = float(model.duration)
    # The bones' world transforms at every time one of them changes frame.
    steps = {}
    for b in range(1, len(mb)):
        f = float(mb[b]["fps"])
        n = frame_index(duration, f) + 1 if f > 0 and mb[b]["tracks"] else 1
        steps[b] = [(i / f if f > 0 else 0.0) for i in range(n)]
    times = sorted({t for ts in steps.values() for t in ts})
    pose = {t: model.bone_pose(t).astype(np.float64) for t in times}
    for b in range(1, len(mb)):
        name = bone_name(mb, b)
        parent = int(mb[b]["parent"])
        r = rest[name]
        r_inv = np.linalg.inv(r)
        keys = []
        for t in steps[b]:
            m = pose[t]
            try:
                local = np.linalg.solve(m[parent], m[b]) if parent else m[b]
            except np.linalg.LinAlgError:  # a parent scaled to a point: nothing to show
                local = np.eye(4)
            basis = r_inv @ local @ r
            s, rot = similarity(basis[:3, :3])
            q = Matrix([list(row) for row in rot]).to_quaternion()
            keys.append((start + t * fps, *basis[:3, 3], *q, s, s, s))
        keys = np.array(keys, dtype=np.float64)
        path = f'pose.bones["{name}"]'
        for prop, first, count in (("location", 1, 3), ("rotation_quaternion", 4, 4), ("scale", 8, 3)):
            for i in range(count):
                fc = action.fcurve_ensure_for_datablock(arm, f"{path}.{prop}", index=i, group_name=name)
                fc.keyframe_points.add(len(keys))
                co = np.empty((len(keys), 2), np.float32)
                co[:, 0], co[:, 1] = keys[:, 0], keys[:, first + i]
                fc.keyframe_points.foreach_set("co", co.ravel())
                fc.keyframe_points.foreach_set("interpolation", [0] * len(keys))  # CONSTANT
                fc.update()
    last = start + duration * fps
    action.use_frame_range = True
    action.frame_start, action.frame_end = start, max(last, start + 1)
    if scene.frame_end < last:
        scene.frame_end = int(np.ceil(last))


# ---------------------------------------------------------------------------
# The camera of a `camerarule`


def remove_camera(obj):
    cam = obj.mdg.camera
    if cam is None:
        return
    data, action = cam.data, cam.animation_data.action if cam.animation_data else None
    bpy.data.objects.remove(cam)
    if data is not None and data.users == 0:
        bpy.data.cameras.remove(data)
    if action is not None and action.users == 0:
        bpy.data.actions.remove(action)
    obj.mdg.camera = None


def camera(obj, model):
    """The camera `NAME camera` of a grammar with a `camerarule` (none without one):
    placed as mdg-run's picture places it (at the camera frame's origin, looking along
    its -z axis with +y up, as Blender's cameras look), with the grammar's vertical
    field of view and clipping planes; a child of `obj` (the grammar's world). A camera
    that moves gets the action `NAME camera motion`: location and rotation keys at every
    frame index i = 0..⌊duration·fps⌋ of the camera's `fps`, constant interpolation."""
    lens = model.camera
    if lens is None:
        remove_camera(obj)
        return
    name = obj.name
    cam = obj.mdg.camera
    if cam is None:
        cam = bpy.data.objects.new(f"{name} camera", bpy.data.cameras.new(f"{name} camera"))
        for c in obj.users_collection:
            c.objects.link(cam)
        cam.parent = obj
        cam.matrix_parent_inverse.identity()
        obj.mdg.camera = cam
    d = cam.data
    d.type = "PERSP"
    d.lens_unit = "FOV"
    d.sensor_fit = "VERTICAL"
    d.angle_y = float(np.radians(lens["fov"]))
    d.clip_start, d.clip_end = float(lens["near"]), float(lens["far"])
    cam.rotation_mode = "QUATERNION"
    old = cam.animation_data.action if cam.animation_data else None
    if old is not None:
        cam.animation_data.action = None
        if old.users == 0:
            bpy.data.actions.remove(old)
    f, duration = float(lens["fps"]), float(model.duration)
    n = frame_index(duration, f) + 1 if f > 0 and duration > 0 else 1
    poses = [model.camera_pose(i / f if f > 0 else 0.0) for i in range(n)]
    t0, r0 = poses[0]
    cam.location, cam.rotation_quaternion = t0.tolist(), r0.tolist()
    if all(np.array_equal(t, t0) and np.array_equal(r, r0) for t, r in poses):
        return
    scene = bpy.context.scene
    fps = scene.render.fps / scene.render.fps_base
    start = scene.frame_start
    action = bpy.data.actions.new(f"{name} camera motion")
    cam.animation_data_create()
    cam.animation_data.action = action
    times = start + np.arange(n, dtype=np.float64) / f * fps
    values = np.array([np.concatenate([t, r]) for t, r in poses], dtype=np.float64)
    for prop, first, count in (("location", 0, 3), ("rotation_quaternion", 3, 4)):
        for i in range(count):
            fc = action.fcurve_ensure_for_datablock(cam, prop, index=i, group_name="camera")
            fc.keyframe_points.add(n)
            co = np.empty((n, 2), np.float32)
            co[:, 0], co[:, 1] = times, values[:, first + i]
            fc.keyframe_points.foreach_set("co", co.ravel())
            fc.keyframe_points.foreach_set("interpolation", [0] * n)  # CONSTANT
            fc.update()
    last = start + duration * fps
    if scene.frame_end < last:
        scene.frame_end = int(np.ceil(last))


# ---------------------------------------------------------------------------
# Properties


def regenerate(obj, report=None):
    """Runs the grammar with the object's settings and rebuilds it; an error is kept
    in `obj.mdg.error` and given to `report` (an operator's)."""
    s = obj.mdg
    try:
        program = program_for(s.path)
        params = {}
        for p in s.params:
            params[p.name] = {"int": p.value_int, "float": p.value_float}.get(p.kind, p.value_bool)
        presets = [p.name for p in s.presets if p.enabled]
        started = time.perf_counter()
        try:
            model = program.run(
                seed=s.seed if s.use_seed else None,
                params=params or None,
                presets=presets or None,
                limits={"max_vertices": s.max_vertices},
            )
        except mdg.CompileError as e:
            raise MdgError(first_error(e)) from None
        except ValueError as e:
            raise MdgError(str(e)) from None
        build(obj, model)
        s.seconds = time.perf_counter() - started
        s.error = ""
        s.warning = "; ".join(model.warnings)
        if model.warnings and report is not None:
            report({"WARNING"}, model.warnings[0])
        return True
    except MdgError as e:
        s.error = str(e)
        if report is not None:
            report({"ERROR"}, str(e))
        return False


def changed(self, context):
    obj = self.id_data
    if obj.name in _loading:
        return
    regenerate(obj)


class MDG_PG_param(bpy.types.PropertyGroup):
    kind: StringProperty()
    value_int: IntProperty(name="Value", update=changed)
    value_float: FloatProperty(name="Value", update=changed)
    value_bool: BoolProperty(name="Value", update=changed)
    min: FloatProperty()
    max: FloatProperty()
    ranged: BoolProperty()


class MDG_PG_preset(bpy.types.PropertyGroup):
    enabled: BoolProperty(name="Enabled", update=changed)


def reload_changed(self, context):
    if self.live_reload and not bpy.app.timers.is_registered(watch):
        bpy.app.timers.register(watch, first_interval=0.5, persistent=True)


class MDG_PG_settings(bpy.types.PropertyGroup):
    path: StringProperty(name="Grammar", subtype="FILE_PATH")
    use_seed: BoolProperty(name="Seed", description="Use this seed instead of the grammar's randseed", update=changed)
    seed: IntProperty(name="Seed", min=0, update=changed)
    max_vertices: IntProperty(name="Max vertices", default=20_000_000, min=1, update=changed)
    params: CollectionProperty(type=MDG_PG_param)
    presets: CollectionProperty(type=MDG_PG_preset)
    live_reload: BoolProperty(name="Live reload", description="Regenerate when the file changes", update=reload_changed)
    mtime: FloatProperty()
    error: StringProperty()
    warning: StringProperty()
    seconds: FloatProperty()
    instancer: PointerProperty(type=bpy.types.Object)
    armature: PointerProperty(type=bpy.types.Object)
    camera: PointerProperty(type=bpy.types.Object)


def load_settings(obj, path):
    """Fills the object's params and presets from the grammar's declarations."""
    program = program_for(path)
    s = obj.mdg
    _loading.add(obj.name)
    try:
        s.path = path
        s.mtime = os.path.getmtime(bpy.path.abspath(path))
        s.params.clear()
        for d in program.params:
            p = s.params.add()
            p.name, p.kind = d["name"], d["type"]
            if d["min"] is not None and d["max"] is not None:
                p.min, p.max, p.ranged = d["min"], d["max"], True
            if p.kind == "int":
                p.value_int = int(d["value"])
            elif p.kind == "float":
                p.value_float = d["value"]
            else:
                p.value_bool = bool(d["value"])
        s.presets.clear()
        for name in program.presets:
            s.presets.add().name = name
    finally:
        _loading.discard(obj.name)


def watch():
    """Live reload: regenerates every MDG object whose grammar file changed."""
    any_live = False
    for obj in bpy.data.objects:
        s = getattr(obj, "mdg", None)
        if s is None or not s.path or not s.live_reload:
            continue
        any_live = True
        try:
            mtime = os.path.getmtime(bpy.path.abspath(s.path))
        except OSError:
            continue
        if mtime != s.mtime:
            s.mtime = mtime
            regenerate(obj)
    return 0.5 if any_live else None


# ---------------------------------------------------------------------------
# Operators and UI


class MDG_OT_add_model(bpy.types.Operator):
    """Add a model generated by an MDG grammar (.mdg or .mdgb)"""

    bl_idname = "mdg.add_model"
    bl_label = "MDG Model"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(subtype="FILE_PATH")
    filter_glob: StringProperty(default="*.mdg;*.mdgb", options={"HIDDEN"})

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        try:
            program_for(self.filepath)
        except MdgError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        name = os.path.splitext(os.path.basename(self.filepath))[0]
        me = bpy.data.meshes.new(name)
        obj = bpy.data.objects.new(name, me)
        context.collection.objects.link(obj)
        load_settings(obj, self.filepath)
        if not regenerate(obj, self.report):
            return {"CANCELLED"}
        # The grammar's camera becomes the scene's camera when the scene has none.
        if obj.mdg.camera is not None and context.scene.camera is None:
            context.scene.camera = obj.mdg.camera
        for o in context.view_layer.objects:
            o.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        return {"FINISHED"}


class MDG_OT_regenerate(bpy.types.Operator):
    """Run the grammar again (reloading the file)"""

    bl_idname = "mdg.regenerate"
    bl_label = "Regenerate"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.object is not None and bool(context.object.mdg.path)

    def execute(self, context):
        return {"FINISHED"} if regenerate(context.object, self.report) else {"CANCELLED"}


class MDG_PT_panel(bpy.types.Panel):
    bl_label = "MDG"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "MDG"

    @classmethod
    def poll(cls, context):
        return context.object is not None and bool(context.object.mdg.path)

    def draw(self, context):
        s = context.object.mdg
        col = self.layout.column()
        col.prop(s, "path")
        row = col.row(align=True)
        row.prop(s, "use_seed", text="")
        sub = row.row()
        sub.enabled = s.use_seed
        sub.prop(s, "seed")
        for p in s.params:
            label = f"{p.name} ({p.min:g}..{p.max:g})" if p.ranged else p.name
            col.prop(p, {"int": "value_int", "float": "value_float"}.get(p.kind, "value_bool"), text=label)
        if len(s.presets):
            col.label(text="Presets")
            for p in s.presets:
                col.prop(p, "enabled", text=p.name)
        col.prop(s, "max_vertices")
        col.prop(s, "live_reload")
        col.operator("mdg.regenerate")
        if s.error:
            box = col.box()
            box.alert = True
            box.label(text=s.error, icon="ERROR")
        elif s.warning:
            col.label(text=s.warning, icon="INFO")
        else:
            col.label(text=f"generated in {s.seconds:.2f} s")


def menu(self, context):
    self.layout.operator(MDG_OT_add_model.bl_idname, icon="MESH_ICOSPHERE")


classes = (MDG_PG_param, MDG_PG_preset, MDG_PG_settings, MDG_OT_add_model, MDG_OT_regenerate, MDG_PT_panel)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Object.mdg = PointerProperty(type=MDG_PG_settings)
    bpy.types.VIEW3D_MT_add.append(menu)


def unregister():
    bpy.types.VIEW3D_MT_add.remove(menu)
    del bpy.types.Object.mdg
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
