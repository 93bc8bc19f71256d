"""Type stubs of mdg._native (the Rust half of the mdg package; docs/python.md)."""

import os
import pathlib
from typing import Any, Iterable, Iterator, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

ParamValue = Union[int, float, bool]
Limits = Mapping[str, Optional[Union[int, float]]]

class CompileError(Exception):
    """A grammar did not compile. str() is the rendered errors (code, file, line, snippet)."""

    diagnostics: list[Diagnostic]

class MdgWarning(UserWarning):
    """A warning from compiling or running a grammar (a limit reached, a compiler warning)."""

class Diagnostic:
    """One compiler diagnostic."""

    code: str
    """`E0301`, `W0001`, … (docs/diagnostics.md)."""
    severity: str
    """"error", "warning" or "note"."""
    message: str
    file: str
    line: int
    """1-based."""
    column: int
    """1-based, in characters."""
    end_line: int
    end_column: int

def compile(
    source: Union[str, os.PathLike[str]],
    *,
    std: Optional[Union[str, os.PathLike[str]]] = None,
    params: Optional[Mapping[str, ParamValue]] = None,
    presets: Optional[Sequence[str]] = None,
    name: Optional[str] = None,
) -> Program:
    """Compiles a grammar.

    `source` is a path (an os.PathLike, or a one-line str ending in .mdg or .mdgb) or
    the source text itself (then named `name` in diagnostics, default
    "<source>.mdg"; its @imports resolve from the current directory and `std`).
    `std`: where `@import NAME` looks (default: $MDG_STD, else the std library built
    into the package). `params` override `@param`s, `presets` choose `@presets`.

    Raises CompileError (with .diagnostics) for errors in the grammar, ValueError for
    a param or preset the grammar does not declare, OSError for a missing file.
    Compiler warnings are issued as MdgWarning.
    """

class Program:
    """A compiled grammar; run it any number of times, from any thread."""

    @property
    def params(self) -> list[dict[str, Any]]:
        """The `@param`s: dicts with name, type ("int", "float", "bool"), value, min, max."""
    @property
    def presets(self) -> list[str]:
        """The presets declared with `@presets`."""
    @property
    def warnings(self) -> list[Diagnostic]:
        """The compiler's warnings."""
    @property
    def path(self) -> Optional[pathlib.Path]:
        """The file compiled (None for source text)."""
    @property
    def mode(self) -> str:
        """"model", or the mdg-run mode of an extension section: "search", "creatures", "grid"."""
    def run(
        self,
        *,
        seed: Optional[int] = None,
        params: Optional[Mapping[str, ParamValue]] = None,
        presets: Optional[Sequence[str]] = None,
        time: Optional[float] = None,
        limits: Optional[Limits] = None,
    ) -> Model:
        """Evaluates the grammar (the GIL is released meanwhile).

        `seed` overrides `randseed`; `params`/`presets` recompile (the last variant is
        cached); `time` poses an animated model at that many seconds (as `mdg-run
        --time`); `limits`: max_vertices, max_frames, max_iso_cells, max_iter,
        max_stack (ints), time_budget (seconds). Limits reached are issued as
        MdgWarning and listed in Model.warnings. Grammars with an extension section
        (mode != "model") raise ValueError: run them with mdg-run.
        """

class Mesh:
    """A triangle mesh as numpy arrays (views of the buffers Rust filled: no copy)."""

    positions: npt.NDArray[np.float32]
    """(n, 3)."""
    normals: npt.NDArray[np.float32]
    """(n, 3), unit length."""
    colors: npt.NDArray[np.float32]
    """(n, 4) RGBA in 0..1; for a prototype, the deltas added to the instance colour."""
    triangles: npt.NDArray[np.uint32]
    """(m, 3), counter-clockwise seen from outside."""
    bones: Optional[npt.NDArray[np.uint32]]
    """(n,) bone per vertex, None for a model without bones."""

class Instances:
    """Placed prototype instances: instance k draws prototypes[prototype[k]] at
    translation + rotation · (scale ⊙ p), in colour color[k] (plus the prototype's
    per-vertex colour deltas, clamped to 0..1).

    prototype, translation, color and bone are read-only (writing raises
    ValueError; np.array(a) gives a writable copy). Where every instance is placed
    (and, for color, every colour is already in 0..1) they are strided views of the
    evaluator's own instance records (row stride 80 bytes, not C-contiguous), kept
    alive by the array's base; otherwise (an instance that cannot be placed, an
    isosurface in the model, a colour outside 0..1) they are contiguous copies.
    rotation and scale are computed: contiguous arrays of their own."""

    prototypes: list[Mesh]
    names: list[str]
    prototype: npt.NDArray[np.uint32]
    """(k,) index into prototypes."""
    translation: npt.NDArray[np.float32]
    """(k, 3)."""
    rotation: npt.NDArray[np.float32]
    """(k, 4) unit quaternion (w, x, y, z)."""
    scale: npt.NDArray[np.float32]
    """(k, 3) per axis; x negative for a mirrored instance."""
    color: npt.NDArray[np.float32]
    """(k, 4) RGBA in 0..1."""
    bone: npt.NDArray[np.uint32]
    """(k,)."""
    def __len__(self) -> int: ...

class Model:
    """One evaluation. Arrays are made on first access and then kept."""

    @property
    def mesh(self) -> Mesh:
        """Everything flattened, every instance expanded: what .obj/.ply/.stl hold."""
    @property
    def vertex_mesh(self) -> Mesh:
        """The VERTEX triangles (prototype instances expanded): the JSON dump's."""
    @property
    def base_mesh(self) -> Mesh:
        """Everything except the placed prototype instances (see instances)."""
    @property
    def instances(self) -> Instances: ...
    @property
    def positions(self) -> npt.NDArray[np.float32]:
        """mesh.positions."""
    @property
    def normals(self) -> npt.NDArray[np.float32]:
        """mesh.normals."""
    @property
    def colors(self) -> npt.NDArray[np.float32]:
        """mesh.colors."""
    @property
    def triangles(self) -> npt.NDArray[np.uint32]:
        """mesh.triangles."""
    @property
    def lines(self) -> list[npt.NDArray[np.float32]]:
        """Pen lines: (n, 3) points each."""
    @property
    def line_namespaces(self) -> list[str]: ...
    @property
    def isosurfaces(self) -> list[dict[str, Any]]:
        """Isosurface placements (name, position, scale), as the JSON dump lists them."""
    @property
    def stats(self) -> dict[str, Any]:
        """rule_calls, vertices, triangles, max_depth, elapsed_ms, warnings."""
    @property
    def warnings(self) -> list[str]: ...
    @property
    def debug(self) -> list[str]:
        """What DEBUG {} items reported."""
    @property
    def background(self) -> tuple[float, float, float, float]: ...
    @property
    def seed(self) -> Optional[int]: ...
    @property
    def duration(self) -> float:
        """Seconds of animation (0 when static)."""
    @property
    def bones(self) -> list[dict[str, Any]]:
        """rule, parent, rest (4×4 row-major), fps, tracks (indices into tracks)."""
    @property
    def tracks(self) -> list[dict[str, Any]]:
        """rule, complete, frames ((n, 4, 4) row-major float32)."""
    def bone_pose(self, time: float) -> npt.NDArray[np.float32]:
        """(n, 4, 4) row-major world transform of every bone at `time` (bone 0: identity);
        vertex v of bone b is at bone_pose(t)[b] @ (v, 1), as in pose(t)."""
    def pose(self, time: float) -> Model:
        """The model posed at `time` seconds (as mdg-run --time)."""
    @property
    def camera(self) -> Optional[dict[str, float]]:
        """The `camerarule` camera (None without one): fov (vertical, degrees), near, far,
        fps, as mdg-run's pictures use them."""
    def camera_pose(
        self, time: float
    ) -> Optional[tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]]:
        """(translation (3,), rotation (4,) unit quaternion w, x, y, z) of the camera at
        `time` seconds, as mdg-run's picture places it; it looks along its -z axis with +y
        up. None without a camera."""
    def write(
        self, path: Union[str, os.PathLike[str]], *, format: Optional[str] = None, instances: bool = False
    ) -> None:
        """Writes glb, obj, stl, ply or json (from the extension or `format`), byte for
        byte as mdg-run; `instances=True`: glb with EXT_mesh_gpu_instancing."""
    def to_trimesh(self) -> Any:
        """A trimesh.Trimesh of `mesh` (needs trimesh); pen lines are left out, with a warning."""

class Generation(Iterator[tuple[int, Model]]):
    def __iter__(self) -> Generation: ...
    def __next__(self) -> tuple[int, Model]: ...
    def __len__(self) -> int: ...

def generate(
    program: Program,
    seeds: Iterable[int],
    *,
    workers: Optional[int] = None,
    params: Optional[Mapping[str, ParamValue]] = None,
    presets: Optional[Sequence[str]] = None,
    time: Optional[float] = None,
    limits: Optional[Limits] = None,
    write: Optional[str] = None,
    format: Optional[str] = None,
    mesh: bool = True,
) -> Generation:
    """Runs every seed on `workers` threads (default: the CPUs; the GIL is released),
    yielding (seed, Model) in the order of `seeds`: the same models as
    program.run(seed=s) one by one. With `write` ("out/{seed}.glb"), each worker also
    writes its model (format from the extension or `format`). `mesh`: the workers
    also make each model's `mesh` arrays (False when only files are wanted)."""
