"""MDG shape grammars from Python.

Compile a grammar, run it into numpy arrays, write it in every format ``mdg-run``
writes, or generate many seeds in parallel for a dataset::

    import mdg
    program = mdg.compile("std/examples/tree.mdg", params={"levels": 6})
    model = program.run(seed=7)
    model.positions, model.triangles       # numpy arrays (no copy of Rust's buffers)
    model.write("tree.glb")
    for seed, m in mdg.generate(program, range(100), workers=4):
        ...

See docs/python.md for the whole API.
"""

from ._native import (
    CompileError,
    Diagnostic,
    Generation,
    Instances,
    MdgWarning,
    Mesh,
    Model,
    Program,
    __version__,
    compile,
    generate,
)

__all__ = [
    "CompileError",
    "Diagnostic",
    "Generation",
    "Instances",
    "MdgWarning",
    "Mesh",
    "Model",
    "Program",
    "__version__",
    "compile",
    "generate",
]
