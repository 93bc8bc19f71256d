"""The mdg package against mdg-run: arrays, files, errors, parameters, generate."""

import pathlib
import time
import warnings

import numpy as np
import pytest

import mdg
import subprocess

from conftest import EXAMPLES, MODE_EXAMPLES, ROOT, json_dump, mdg_run, mdgc_path


def test_installed_package():
    # The tests exercise the installed wheel, not python/mdg in the checkout.
    here = pathlib.Path(mdg.__file__).resolve()
    assert ROOT / "python" not in here.parents, here
    assert hasattr(mdg, "_native") and mdg.__version__


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_arrays_equal_the_json_dump(path, tmp_path):
    program = mdg.compile(path)
    if path.stem in MODE_EXAMPLES:
        with pytest.raises(ValueError, match="mdg-run"):
            program.run()
        assert program.mode != "model"
        return
    assert program.mode == "model"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mdg.MdgWarning)
        model = program.run()
    dump = json_dump(path, tmp_path)
    m = model.vertex_mesh
    want = np.array(dump["vertices"], dtype=np.float32).reshape(-1, 3)
    assert m.positions.dtype == np.float32 and m.positions.shape == want.shape
    assert np.array_equal(m.positions, want)
    tris = np.array(dump["triangles"], dtype=np.uint32).reshape(-1, 3)
    assert np.array_equal(m.triangles, tris)
    assert len(model.lines) == len(dump["lines"])
    for got, line in zip(model.lines, dump["lines"]):
        assert np.array_equal(got, np.array(line["points"], dtype=np.float32).reshape(-1, 3))
    assert model.line_namespaces == [line["namespace"] for line in dump["lines"]]
    assert len(model.isosurfaces) == len(dump["instances"])
    for got, inst in zip(model.isosurfaces, dump["instances"]):
        assert got["name"] == inst["name"]
        assert np.array_equal(np.float32(got["position"]), np.float32(inst["position"]))
        assert np.float32(got["scale"]) == np.float32(inst["scale"])
    stats = model.stats
    for k in ("rule_calls", "vertices", "triangles", "max_depth", "warnings"):
        assert stats[k] == dump["stats"][k], k
    # The whole model: the vertex group comes first, the counts are mdg-run's.
    whole = model.mesh
    n = len(want)
    assert np.array_equal(whole.positions[:n], want)
    assert whole.normals.shape == whole.positions.shape and whole.colors.shape == (len(whole.positions), 4)
    assert whole.triangles.max(initial=0) < max(len(whole.positions), 1)
    # base_mesh plus the placed instances is the whole model.
    inst = model.instances
    per = np.array([len(p.positions) for p in inst.prototypes], dtype=np.int64)
    assert len(model.base_mesh.positions) + per[inst.prototype].sum() == len(whole.positions)


def expand_instances(model):
    """Every placed prototype instance in world space, by the documented TRS."""
    inst = model.instances
    out = []
    for k in range(len(inst)):
        proto = inst.prototypes[inst.prototype[k]].positions.astype(np.float64)
        w, x, y, z = inst.rotation[k].astype(np.float64)
        r = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )
        out.append(inst.translation[k] + (proto * inst.scale[k]) @ r.T)
    return np.concatenate(out) if out else np.zeros((0, 3))


@pytest.mark.parametrize("name", ["parametric_tree", "mirrored_sculpture", "cube_spiral"])
def test_instances_place_the_prototypes_where_the_mesh_has_them(name):
    model = mdg.compile(ROOT / "std" / "examples" / f"{name}.mdg").run()
    inst = model.instances
    assert inst.rotation.shape == (len(inst), 4) and inst.scale.shape == (len(inst), 3)
    assert inst.color.shape == (len(inst), 4) and inst.translation.shape == (len(inst), 3)
    placed = expand_instances(model)
    together = np.concatenate([model.base_mesh.positions, placed])
    whole = model.mesh.positions
    assert len(together) == len(whole)
    # The same points (up to float rounding), in another order.
    a = np.unique(np.round(together, 3), axis=0)
    b = np.unique(np.round(whole.astype(np.float64), 3), axis=0)
    # Rounding can split a point the other side of a step: compare when it did not.
    if len(a) == len(b):
        assert np.allclose(a, b, atol=2e-3)
    span = np.ptp(whole, axis=0).max()
    assert np.allclose(together.min(axis=0), whole.min(axis=0), atol=1e-4 * span + 1e-5)
    assert np.allclose(together.max(axis=0), whole.max(axis=0), atol=1e-4 * span + 1e-5)


def test_many_instances_are_converted_in_order():
    # More than 2 × 65,536 instances: converted on several threads (where there are
    # several CPUs), each writing its own rows; they must come in the model's order.
    src = "@import primitives\nstartshape A\nrule A { 150000 * {x 1 R -0.000005} cube {} }\n"
    model = mdg.compile(src).run(limits={"max_vertices": 10_000_000})
    inst = model.instances
    n = len(inst)
    assert n == 150_000 and len(model.base_mesh.positions) == 0
    assert np.array_equal(np.diff(inst.translation[:, 0]), np.ones(n - 1, np.float32))
    assert np.array_equal(inst.rotation, np.tile(np.float32([1, 0, 0, 0]), (n, 1)))
    assert np.array_equal(inst.prototype, np.zeros(n, np.uint32)) and np.array_equal(inst.bone, np.zeros(n, np.uint32))
    proto = inst.prototypes[0].positions
    placed = inst.translation[:, None, :] + proto[None, :, :] * inst.scale[:, None, :]
    assert np.allclose(placed.reshape(-1, 3), model.mesh.positions, atol=1e-3)
    # The colours in order too (R falls with every copy).
    assert np.all(np.diff(inst.color[:, 0].astype(np.float64)) <= 0) and inst.color[-1, 0] < inst.color[0, 0] - 0.5


def test_instances_that_cannot_be_placed_leave_no_gap():
    # Translations that overflow (x 1e35 per copy) cannot be placed: those instances
    # are expanded into base_mesh, and the rows of the others close up. The rows are
    # converted in chunks of >= 65,536 instances (one thread each, where there are
    # several CPUs); here the first chunk holds the ones that cannot be placed.
    src = "@import primitives\nstartshape A\nrule A { 75000 * {x 1e35} cube {}  75000 * {x 1} cube {} }\n"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mdg.MdgWarning)
        model = mdg.compile(src).run(limits={"max_vertices": 10_000_000})
    inst = model.instances
    first = len(inst) - 75_000
    assert 3_000 < first < 4_000, len(inst)
    assert np.all(inst.translation[:first, 0] >= 1e35) and np.all(np.isfinite(inst.translation))
    assert np.array_equal(inst.translation[first:, 0], np.arange(1, 75_001, dtype=np.float32))
    corners = len(inst.prototypes[0].positions)
    assert len(model.base_mesh.positions) == (75_000 - first) * corners
    assert len(model.positions) == len(model.base_mesh.positions) + len(inst) * corners
    for a in (inst.prototype, inst.translation, inst.rotation, inst.scale, inst.color, inst.bone):
        assert len(a) == len(inst) and a.flags["C_CONTIGUOUS"]


ROWS = "@import primitives\nstartshape A\nrule A { %s 3000 * {x 1 ry 7 s 1.0001 R -0.0002 b 0.0001} cube {} }\n"
# The first instance's translation overflows: it cannot be placed (a gap in the rows).
UNPLACEABLE = "cube {x 1e38 x 1e38 x 1e38 x 1e38}"


def run_quietly(src):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mdg.MdgWarning)
        return mdg.compile(src).run()


def test_instance_rows_are_read_only_views_of_the_records():
    # Where every instance is placed, translation is a strided view of the evaluator's
    # packed instance frames (44 bytes each): nothing copied. color, bone and
    # prototype are views too (a row stride of 0) where every instance shares the
    # value, and contiguous copies where it varies; all of them read-only.
    for inst in (run_quietly(ROWS % "").instances, mdg.compile(ROOT / "std" / "examples" / "cube_spiral.mdg").run().instances):
        assert len(inst) > 0
        assert not inst.translation.flags["OWNDATA"] and inst.translation.strides[0] == 44, inst.translation.strides
        for a in (inst.color, inst.bone, inst.prototype):
            shared = not a.flags["OWNDATA"] and a.strides[0] == 0
            assert shared or a.flags["C_CONTIGUOUS"], a.strides
        for a in (inst.translation, inst.color, inst.bone, inst.prototype):
            assert not a.flags["WRITEABLE"]
            with pytest.raises(ValueError):
                a[0] = 0
        # Computed rows: arrays of their own.
        assert inst.rotation.flags["C_CONTIGUOUS"] and inst.scale.flags["C_CONTIGUOUS"]


def test_views_equal_the_copies():
    # The same 3000 instances, once all placeable (views), once after one that cannot
    # be placed (the copying path: contiguous rows, read-only all the same).
    views = run_quietly(ROWS % "").instances
    copies = run_quietly(ROWS % UNPLACEABLE).instances
    assert len(views) == len(copies) == 3000
    assert copies.translation.flags["C_CONTIGUOUS"] and not copies.translation.flags["WRITEABLE"]
    assert views.translation.strides[0] == 44
    for k in ("prototype", "translation", "rotation", "scale", "color", "bone"):
        a, b = getattr(views, k), getattr(copies, k)
        assert a.dtype == b.dtype and np.array_equal(a, b), k
    # Colours outside 0..1 are clamped in a copy (a view would show the raw ones).
    bright = run_quietly(ROWS.replace("cube {} }", "cube {R 0.5} }") % "").instances
    assert bright.color.flags["C_CONTIGUOUS"] and not bright.color.flags["WRITEABLE"]
    assert bright.color.max() == 1.0 and bright.translation.strides[0] == 44


def test_views_outlive_the_model():
    # The records stay alive while a view of them is held, the Model gone.
    import gc

    model = run_quietly(ROWS % "")
    t, c, b = model.instances.translation, model.instances.color, model.instances.bone
    want = [a.copy() for a in (t, c, b)]
    del model
    gc.collect()
    junk = [np.full(1 << 20, 7.0, np.float32) for _ in range(8)]  # reuse freed memory
    assert all(np.array_equal(a, w) for a, w in zip((t, c, b), want)) and len(junk) == 8


def test_some_example_has_instances_and_a_mirrored_one():
    # The instance tests above mean something only if the examples have instances.
    tree = mdg.compile(ROOT / "std" / "examples" / "tree.mdg").run()
    assert len(tree.instances) > 0
    mirrored = mdg.compile(ROOT / "std" / "examples" / "mirrored_sculpture.mdg").run()
    assert (mirrored.instances.scale[:, 0] < 0).any() or len(mirrored.instances) == 0


def test_arrays_are_views_of_rusts_buffers():
    model = mdg.compile(ROOT / "std" / "examples" / "tree.mdg").run()
    p = model.positions
    # numpy does not own the data: it is the Vec the walk filled, kept alive by `base`.
    assert not p.flags["OWNDATA"] and p.base is not None
    assert p.flags["C_CONTIGUOUS"] and p.shape[1] == 3
    # Made once, then the same array.
    assert model.positions is model.mesh.positions
    assert model.mesh is model.mesh


@pytest.mark.parametrize("ext", ["glb", "obj", "stl", "ply", "json"])
def test_write_is_byte_identical_to_mdg_run(ext, tmp_path):
    # Mirrored prototype instances, isosurfaces and colours, in a small model.
    src = ROOT / "std" / "examples" / "mirrored_sculpture.mdg"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mdg.MdgWarning)
        mdg.compile(src).run(seed=5).write(tmp_path / f"py.{ext}")
    mdg_run(src, "--seed", "5", "-o", tmp_path / f"cli.{ext}")
    assert (tmp_path / f"py.{ext}").read_bytes() == (tmp_path / f"cli.{ext}").read_bytes()


def test_write_instances_and_format_errors(tmp_path):
    src = ROOT / "std" / "examples" / "tree.mdg"
    model = mdg.compile(src).run()
    model.write(tmp_path / "i.glb", instances=True)
    mdg_run(src, "--instances", "-o", tmp_path / "cli.glb")
    assert (tmp_path / "i.glb").read_bytes() == (tmp_path / "cli.glb").read_bytes()
    with pytest.raises(ValueError, match=r"\.glb, \.obj"):
        model.write(tmp_path / "x.fbx")
    with pytest.raises(ValueError, match="format="):
        model.write(tmp_path / "x", format="fbx")
    model.write(tmp_path / "sub" / "x", format="stl")
    assert (tmp_path / "sub" / "x").stat().st_size > 84


def test_compile_error_carries_code_and_line():
    src = "@import primitives\nstartshape A\n\nrule A {\n  cube {s 1}\n  foo\n}\n"
    with pytest.raises(mdg.CompileError) as e:
        mdg.compile(src, name="broken.mdg")
    diags = [d for d in e.value.diagnostics if d.severity == "error"]
    assert diags, e.value.diagnostics
    d = diags[0]
    assert d.code.startswith("E") and len(d.code) == 5
    assert d.file == "broken.mdg"
    assert d.line == 7 and d.column == 1, str(d)
    assert d.code in str(e.value) and "broken.mdg:7" in str(e.value)
    assert str(d).startswith("broken.mdg:7:1: error[")


def test_compile_error_from_a_file_names_the_file(tmp_path):
    f = tmp_path / "bad.mdg"
    f.write_text("@import primitives\nstartshape A\nrule A { cube {} }\nrule B { NOPE {} }\n")
    with pytest.raises(mdg.CompileError) as e:
        mdg.compile(f)
    d = next(d for d in e.value.diagnostics if d.severity == "error")
    assert d.line == 4 and d.file.endswith("bad.mdg"), str(d)
    assert d.code == "E0301" and d.column == 10
    # The same through a str path.
    with pytest.raises(mdg.CompileError):
        mdg.compile(str(f))


def test_bad_arguments_say_what_is_wrong(tmp_path):
    with pytest.raises(OSError, match="missing.mdg"):
        mdg.compile(str(tmp_path / "missing.mdg"))
    tree = ROOT / "std" / "examples" / "parametric_tree.mdg"
    with pytest.raises(ValueError, match="levelz"):
        mdg.compile(tree, params={"levelz": 3})
    program = mdg.compile(tree)
    with pytest.raises(ValueError, match="unknown limit"):
        program.run(limits={"max_vertexes": 10})
    with pytest.raises(ValueError, match="time"):
        program.run(time=-1)
    with pytest.raises(TypeError, match="params"):
        program.run(params={"levels": "three"})
    with pytest.raises(TypeError):
        mdg.compile(42)


def test_params_presets_and_limits():
    tree = ROOT / "std" / "examples" / "parametric_tree.mdg"
    program = mdg.compile(tree)
    names = [p["name"] for p in program.params]
    assert names == ["levels", "forks", "spread"]
    assert program.params[0] == {"name": "levels", "type": "int", "value": 5.0, "min": 1.0, "max": 7.0}
    small = program.run(params={"levels": 2})
    big = program.run(params={"levels": 4})
    assert len(small.positions) < len(big.positions)
    # The same as compiling with the param, and as mdg-run --param.
    again = mdg.compile(tree, params={"levels": 2}).run()
    assert np.array_equal(small.positions, again.positions)
    assert mdg.compile(tree, params={"levels": 2}).params[0]["value"] == 2.0
    with pytest.warns(mdg.MdgWarning, match="vertices"):
        capped = program.run(limits={"max_vertices": 100})
    assert capped.warnings and len(capped.positions) <= 100


def test_params_match_mdg_run(tmp_path):
    tree = ROOT / "std" / "examples" / "parametric_tree.mdg"
    model = mdg.compile(tree).run(params={"levels": 3, "spread": 20.5}, seed=4)
    dump = json_dump(tree, tmp_path, "--param", "levels=3", "--param", "spread=20.5", "--seed", "4")
    assert np.array_equal(model.vertex_mesh.positions, np.array(dump["vertices"], dtype=np.float32).reshape(-1, 3))


def test_animated_model_has_bones_tracks_and_poses(tmp_path):
    src = ROOT / "std" / "examples" / "solar_system.mdg"
    model = mdg.compile(src).run()
    assert len(model.bones) > 1 and model.duration > 0
    assert model.mesh.bones is not None and len(model.mesh.bones) == len(model.positions)
    track = model.tracks[model.bones[1]["tracks"][0]]
    assert track["frames"].shape[1:] == (4, 4) and len(track["frames"]) > 1
    assert model.bones[1]["rest"].shape == (4, 4)
    posed = model.pose(1.5)
    dump = json_dump(src, tmp_path, "--time", "1.5")
    want = np.array(dump["vertices"], dtype=np.float32).reshape(-1, 3)
    timed = mdg.compile(src).run(time=1.5)
    assert np.array_equal(timed.vertex_mesh.positions, want)
    assert not np.array_equal(posed.positions, model.positions)
    # bone_pose: the bones' world transforms that pose() applies to their vertices.
    m = model.bone_pose(1.5)
    assert m.shape == (len(model.bones), 4, 4) and np.array_equal(m[0], np.eye(4, dtype=np.float32))
    b = model.mesh.bones
    moved = np.einsum("nij,nj->ni", m[b][:, :3, :3], model.positions) + m[b][:, :3, 3]
    assert np.allclose(moved, posed.positions, atol=1e-4), np.abs(moved - posed.positions).max()
    with pytest.raises(ValueError, match="time=-1"):
        model.bone_pose(-1.0)
    static = mdg.compile(ROOT / "std" / "examples" / "tree.mdg").run()
    assert static.mesh.bones is None and static.bones == [] and static.tracks == []


def glb_json(path):
    """The JSON chunk of a .glb."""
    import json
    import struct

    data = pathlib.Path(path).read_bytes()
    length, kind = struct.unpack_from("<II", data, 12)
    assert kind == 0x4E4F534A, kind
    return json.loads(data[20 : 20 + length])


def rotation_matrix(wxyz):
    w, x, y, z = np.asarray(wxyz, dtype=np.float64)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def test_camera_is_where_mdg_run_puts_it(tmp_path):
    # mdg-run's .glb holds the camera node in MDG's space (under the z-up root): at
    # t = 0 its translation and rotation, then its keys (STEP) at the camera's fps.
    src = ROOT / "std" / "examples" / "camera_flyaround.mdg"
    model = mdg.compile(src).run()
    glb = tmp_path / "cam.glb"
    mdg_run(src, "-o", glb)
    g = glb_json(glb)
    node_index = next(i for i, n in enumerate(g["nodes"]) if "camera" in n)
    node = g["nodes"][node_index]
    lens = model.camera
    assert set(lens) == {"fov", "near", "far", "fps"}
    assert lens["fov"] == pytest.approx(np.degrees(g["cameras"][0]["perspective"]["yfov"]), rel=1e-5)
    assert (lens["near"], lens["far"], lens["fps"]) == pytest.approx((0.2, 200.0, 30.0))
    t, r = model.camera_pose(0.0)
    assert t.shape == (3,) and r.shape == (4,) and t.dtype == np.float32
    assert np.allclose(t, node["translation"], atol=1e-4)
    x, y, z, w = node["rotation"]
    assert np.allclose(rotation_matrix(r), rotation_matrix([w, x, y, z]), atol=1e-5)
    # Later: the key of the glb's translation channel at that time.
    channel = next(c for c in g["animations"][0]["channels"]
                   if c["target"]["node"] == node_index and c["target"]["path"] == "translation")
    sampler = g["animations"][0]["samplers"][channel["sampler"]]
    times = read_accessor(glb, g, sampler["input"]).ravel()
    values = read_accessor(glb, g, sampler["output"]).reshape(-1, 3)
    for when in (3.0, 7.51):
        k = int(np.searchsorted(times, when + 1e-6)) - 1
        assert np.allclose(model.camera_pose(when)[0], values[k], atol=1e-4), when
    assert not np.allclose(model.camera_pose(3.0)[0], t)
    # It looks at the stones: the centre is in front of it (along its -z axis).
    forward = rotation_matrix(r) @ np.array([0.0, 0.0, -1.0])
    assert forward @ (np.zeros(3) - t) > 0.9 * np.linalg.norm(t)
    assert mdg.compile(ROOT / "std" / "examples" / "tree.mdg").run().camera is None
    assert mdg.compile(ROOT / "std" / "examples" / "tree.mdg").run().camera_pose(0.0) is None
    with pytest.raises(ValueError, match="time=-1"):
        model.camera_pose(-1.0)


def read_accessor(glb, g, index):
    """A float accessor of a .glb as an array."""
    import struct

    data = pathlib.Path(glb).read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    bin_start = 20 + length + 8
    a = g["accessors"][index]
    view = g["bufferViews"][a["bufferView"]]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[a["type"]]
    offset = bin_start + view.get("byteOffset", 0) + a.get("byteOffset", 0)
    return np.frombuffer(data, dtype="<f4", count=a["count"] * width, offset=offset)


def generate_threads():
    """The worker threads of mdg.generate alive in this process (Linux: by name)."""
    tasks = pathlib.Path("/proc/self/task")
    return sum(1 for t in tasks.iterdir() if (t / "comm").read_text().strip() == "mdg-generate")


@pytest.mark.skipif(not pathlib.Path("/proc/self/task").is_dir(), reason="needs Linux's /proc")
def test_generate_abandoned_stops_its_workers():
    # The workers run ahead of the reader by a window of seeds; an iterator dropped
    # half-way stops them (they must not evaluate the other 10,000 seeds, or wait
    # for ever for a reader).
    import gc

    program = mdg.compile(ROOT / "std" / "examples" / "pebbles.mdg", params={"stones": 4})
    g = mdg.generate(program, range(10_000), workers=2)
    seed, model = next(g)
    assert seed == 0 and len(model.positions) > 0
    assert generate_threads() == 2
    del g, model
    gc.collect()
    deadline = time.monotonic() + 30
    while generate_threads() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert generate_threads() == 0, "the workers of a dropped generate() are still running"
    # Read to the end, the workers end by themselves.
    assert [s for s, _ in mdg.generate(program, range(5), workers=3)] == [0, 1, 2, 3, 4]
    deadline = time.monotonic() + 30
    while generate_threads() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert generate_threads() == 0


def test_generate_equals_one_by_one(tmp_path):
    # Random pebbles (isosurface instances), few of them to stay quick.
    program = mdg.compile(ROOT / "std" / "examples" / "pebbles.mdg", params={"stones": 12})
    seeds = [3, 1, 4, 1, 5, 9, 2, 6]
    got = list(mdg.generate(program, seeds, workers=3, write=str(tmp_path / "{seed}.ply")))
    assert [s for s, _ in got] == seeds
    for seed, model in got:
        one = program.run(seed=seed)
        assert model.seed == seed
        assert np.array_equal(model.positions, one.positions)
        assert np.array_equal(model.colors, one.colors)
        assert np.array_equal(model.triangles, one.triangles)
        one.write(tmp_path / f"one-{seed}.ply")
        assert (tmp_path / f"{seed}.ply").read_bytes() == (tmp_path / f"one-{seed}.ply").read_bytes()
    # Seeds give different trees (else the comparison above proves little).
    assert not np.array_equal(got[0][1].positions, got[1][1].positions)
    assert len(mdg.generate(program, range(10))) == 10
    # Without the workers' flattening, the same arrays (made on access).
    (seed, lazy), = mdg.generate(program, [4], workers=2, mesh=False)
    assert seed == 4 and np.array_equal(lazy.positions, program.run(seed=4).positions)
    with pytest.raises(ValueError, match="seed"):
        mdg.generate(program, range(3), write=str(tmp_path / "fixed.glb"))
    with pytest.raises(ValueError, match="workers"):
        mdg.generate(program, range(3), workers=0)
    with pytest.raises(TypeError, match="seeds"):
        mdg.generate(program, ["a"])


def test_to_trimesh():
    trimesh = pytest.importorskip("trimesh")
    model = mdg.compile(ROOT / "std" / "examples" / "icosahedron.mdg").run()
    t = model.to_trimesh()
    assert isinstance(t, trimesh.Trimesh)
    assert np.array_equal(np.asarray(t.vertices, dtype=np.float32), model.positions)
    assert np.array_equal(np.asarray(t.faces), model.triangles.astype(np.int64))
    want = np.round(model.colors * 255).astype(np.uint8)
    assert np.array_equal(np.asarray(t.visual.vertex_colors), want)


def test_compiled_bundle_runs_and_refuses_params(tmp_path):
    src = ROOT / "std" / "examples" / "parametric_tree.mdg"
    bundle = tmp_path / "tree.mdgb"
    subprocess.run([str(mdgc_path()), "build", str(src), "-o", str(bundle)], check=True, capture_output=True)
    program = mdg.compile(bundle)
    assert program.path == bundle and [p["name"] for p in program.params] == ["levels", "forks", "spread"]
    assert np.array_equal(program.run(seed=2).positions, mdg.compile(src).run(seed=2).positions)
    with pytest.raises(ValueError, match="compiled bundle"):
        program.run(params={"levels": 2})
    with pytest.raises(ValueError, match="compiled bundle"):
        mdg.compile(str(bundle), presets=["x"])
