//! The registry of diagnostic codes: every code the toolchain emits, with its
//! severity, a one-line title, an explanation and an example that triggers it.
//!
//! Call sites keep writing the code as a string (`Diagnostic::error("E0301", …)`);
//! [`Diagnostic::error`](crate::diag::Diagnostic::error) and `warning` check in debug
//! builds that the code is registered here with that severity. `docs/diagnostics.md`
//! is generated from this table ([`markdown`]); `mdgc explain CODE` prints an entry
//! ([`explain`]). Tests check that every example produces its code, that the docs
//! equal the generated text, and that every code in the sources is registered and
//! every registered code is emitted.

use serde::Serialize;

/// How bad a diagnostic is (each code has one severity).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Information about the other diagnostics (N0001: how many were not shown).
    Note,
    Warning,
    Error,
}

impl Severity {
    /// `error`, `warning` or `note`, as the diagnostics print it.
    pub fn name(self) -> &'static str {
        match self {
            Severity::Note => "note",
            Severity::Warning => "warning",
            Severity::Error => "error",
        }
    }
    /// The letter of its codes: `E`, `W`, `N`.
    pub fn letter(self) -> u8 {
        match self {
            Severity::Note => b'N',
            Severity::Warning => b'W',
            Severity::Error => b'E',
        }
    }
}

/// One diagnostic code.
#[derive(Clone, Copy, Debug)]
pub struct Code {
    /// `E0301`, `W0001`, …
    pub code: &'static str,
    pub severity: Severity,
    /// One line, lower case, no final period.
    pub title: &'static str,
    /// Paragraphs of Markdown: what is wrong, the example's point, the fix.
    pub explanation: &'static str,
    pub example: Example,
}

/// A source that triggers a code. It is checked as the file `project/example.mdg`,
/// alone in its project directory, with the std library available; beside the
/// project lies one file, `outside.mdg` (only E0202's example, an import that
/// leaves the project, needs it).
#[derive(Clone, Copy, Debug)]
pub enum Example {
    /// Checked as a library (no start shape required).
    Library(&'static str),
    /// Checked as a program (`mdgc build`: a start shape is required).
    Program(&'static str),
    /// Made by the language server only, for a document it is given; the text says
    /// which (the test of the code is in `lsp/tests`).
    Editor(&'static str),
    /// Made by a command, not by checking a source: the text is the command and what
    /// it is given (`mdgc induce` on a building of no repeated part, say).
    Command(&'static str),
}

impl Example {
    /// The source text.
    pub fn text(&self) -> &'static str {
        match self {
            Example::Library(t) | Example::Program(t) | Example::Editor(t) | Example::Command(t) => t,
        }
    }
    /// Whether it is checked as a program.
    pub fn is_program(&self) -> bool {
        matches!(self, Example::Program(_))
    }
}

/// The creature grammar the `E08xx` examples extend (a torso with a neck and a
/// hip, a head and a leg): `beasts!("…")` appends lines to its `creature` section.
macro_rules! beasts {
    ($tail:literal) => {
        concat!(
            r#"rule blob {
  VERTEX {} VERTEX {x 0.1} VERTEX {y 0.1}
}

creature beasts {
  part body { type torso; category beast; rule blob;
    slot neck { at 0 0 1; normal 0 0 1; size 0.2; accepts head; }
    slot hip_l { at 0.2 0 0; normal 0 0 -1; size 0.2; accepts leg; symmetric hip_r; }
  }
  part head { type head; category beast; rule blob;
    joint { at 0 0 0; normal 0 0 -1; size 0.2; }
  }
  part leg { type leg; category beast; rule blob; support;
    joint { at 0 0 0; normal 0 0 1; size 0.2; }
  }
  shape beast { torso body; attach neck head; attach hip_l leg; }
"#,
            $tail,
            "}\n"
        )
    };
}

use Example::{Command, Editor, Library, Program};
use Severity::{Error, Note, Warning};

/// Every code, sorted.
pub static CODES: &[Code] = &[
    Code {
        code: "E0101",
        severity: Error,
        title: "unexpected token",
        explanation: r#"Syntax error: unexpected token.

In the example: a stray `}` after the last rule.

Fix: Look at the token the caret points at: a missing `;`, `{` or `}` before it is the usual cause."#,
        example: Library(
            r#"startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
}
"#,
        ),
    },
    Code {
        code: "E0102",
        severity: Error,
        title: "unterminated block comment",
        explanation: r#"A `/*` comment runs to the end of the file: it has no closing `*/`. Block comments do not nest.

In the example: a block comment that is never closed.

Fix: Close the comment with `*/`."#,
        example: Library(
            r#"startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}

/* this comment never ends
rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0103",
        severity: Error,
        title: "invalid character",
        explanation: r#"The lexer met a character that starts no token of the language (outside comments and strings).

In the example: `%` is not a character of the language.

Fix: Remove the character; comments start with `//` or `/*`."#,
        example: Library(
            r#"startshape A
%

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0104",
        severity: Error,
        title: "unclosed delimiter",
        explanation: r#"An unclosed `{`, `[` or `(`: at the end of the file ("unexpected end of file"), or before the next top-level `rule` at the start of a line ("unclosed delimiter"). The bracket is taken as closed there and the rest of the file checks normally, so one forgotten `}` gives one error.

In the example: the function's `{` is never closed: the file ends first.

Fix: Close every `{`, `[` and `(` that the file opens."#,
        example: Library(
            r#"startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}

function shape_f { x*x + y*y + z*z - 1
"#,
        ),
    },
    Code {
        code: "E0105",
        severity: Error,
        title: "nesting too deep",
        explanation: r#"Nesting too deep: more than 256 levels of brackets, `@ifdef`, operators in one expression or iterator chain (see `docs/limits.md`).

In the example: an expression nested 300 parentheses deep (the limit is 256 levels).

Fix: Split the expression or the nested blocks into rules, functions or `@define` constants."#,
        example: Library(
            r#"startshape A
rule A { VERTEX {x ((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((1))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))} }
"#,
        ),
    },
    Code {
        code: "E0106",
        severity: Error,
        title: "mismatched closing delimiter",
        explanation: r#"A closing bracket that does not match the innermost open one, such as `]` closing a `{`. As in rustc there is one error, at the closer, with the opener as a secondary label; the closer is read as the one that was meant (a typo for the innermost closer, or an outer closer after forgotten inner ones, whichever leaves fewer repairs), so the rest of the file checks normally.

In the example: `B{x 2 ]` opens an adjustment with `{` and closes it with `]`.

Fix: Use the closer that matches the opener: `B{x 2}` (or `B[x 2]`)."#,
        example: Library(
            r#"rule A {
  B{x 2 ]
  C {}
}
rule B { }
rule C { }
"#,
        ),
    },
    Code {
        code: "E0109",
        severity: Error,
        title: "number too large",
        explanation: r#"A number literal beyond the range of 64-bit floats (about ±1.8e308), which would read as infinity and make geometry, timing or limits meaningless.

In the example: `x 1e999` is too large to be a number.

Fix: Write a number within range."#,
        example: Library(
            r#"rule A { B {x 1e999} }
rule B { }
"#,
        ),
    },
    Code {
        code: "E0110",
        severity: Error,
        title: "Context Free syntax",
        explanation: r#"A construct of Context Free's CFDG 3 language that MDG spells differently. The error names the MDG spelling and, where it is mechanical, offers it as the fix (a quick fix in the editor); the rest of the file is then read as if the fix were made, so one construct gives one error.

| Context Free | MDG |
|---|---|
| `shape X { … }` | `rule X { … }` |
| `shape X` then `rule 0.5 { … } rule { … }` | `rule X 0.5 { … } rule X { … }` |
| `CF::MinimumSize = 0.01` | `minsize 0.01` |
| `CF::Background = [b -1]` | `background 0 0 0` |
| `CF::StartShape = X` | `startshape X` |
| `startshape X(8)`, `startshape X [hue 120]` | `startshape start_X` and `rule start_X { X(8) {} }` |
| `loop 5 [x 1] ITEM` | `5 * [x 1] ITEM` (MDG applies the adjustment before the first run too; `loop i = 0, 5 [x 1] ITEM` starts where Context Free does) |
| `loop i = 5 [x 1] ITEM` | `loop i = 0, 5 [x 1] ITEM` |
| `X(=)` | `X(a, b)`: the calling rule's parameters, written out |
| `SQUARE [[x 1 s 0.5]]` (written order) | `SQUARE {x 1 s 0.5}`: every MDG list keeps the written order |
| `n -- 1` (natural subtraction) | `n - 1` (`--` would read as minus a negative number) |
| `import "x.cfdg"`, `include "x.cfdg"` | `@import x.mdg` |

`path` and the other `CF::` settings (`Tile`, `Symmetry`, `Size`, `MaxShapes`, …) have no MDG equivalent; the error says what to do instead.

In the example: `shape` and `CF::MinimumSize`.

Fix: Take the suggested spelling (`mdgc check` prints it after `help:`); docs/from-context-free.md puts whole programs side by side."#,
        example: Program(
            r#"startshape spiral
CF::MinimumSize = 0.01

shape spiral {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
  spiral {y 0.5 rz 10 s 0.95}
}
"#,
        ),
    },
    Code {
        code: "E0201",
        severity: Error,
        title: "file not found or unreadable",
        explanation: r#"`@import`: file not found or unreadable; any source file over 16 MiB (see `docs/limits.md`).

In the example: there is no std library named `nosuchlib`.

Fix: Check the path (relative to the importing file) or the std library name, and that the file is under 16 MiB."#,
        example: Library(
            r#"@import nosuchlib

startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0202",
        severity: Error,
        title: "import path escapes the project",
        explanation: r#"`@import`: path escapes the project root and the std directory.

In the example: the import path leaves the project root (the directory of the main file). This is the one code whose example needs a second file: `../outside.mdg` must exist, since importing a file that does not exist is E0201 wherever it is (the registry test creates it beside the project).

Fix: Import files under the directory of the main file, or from the std library."#,
        example: Library(
            r#"@import ../outside.mdg

startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0203",
        severity: Error,
        title: "import cycle",
        explanation: r#"`@import` cycle (warning-free skip is not enough: the cycle is reported).

In the example: the file (saved as `example.mdg`) imports itself.

Fix: Remove the import that closes the cycle; move what both files need into a third file."#,
        example: Library(
            r#"@import example.mdg

startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0204",
        severity: Error,
        title: "unknown macro",
        explanation: r#"`@expand` of an unknown macro.

In the example: `@expand` of a macro that was never defined.

Fix: Define the macro with `@macro NAME(args)` … `@endmacro` before expanding it, or fix the name."#,
        example: Library(
            r#"startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}

@expand NO_SUCH_MACRO(1, 2)
"#,
        ),
    },
    Code {
        code: "E0205",
        severity: Error,
        title: "wrong number of macro arguments",
        explanation: r#"Macro called with the wrong number of arguments.

In the example: the macro takes two arguments but is expanded with one.

Fix: Pass as many arguments as the `@macro` line declares."#,
        example: Library(
            r#"@macro TRI(size, adj)
VERTEX {adj}
VERTEX {adj x size}
VERTEX {adj y size}
@endmacro

startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
@expand TRI(1)
}
"#,
        ),
    },
    Code {
        code: "E0206",
        severity: Error,
        title: "unterminated block directive",
        explanation: r#"Unterminated `@macro`, `@ifdef` or shader block.

In the example: `@ifdef` without `@endif`.

Fix: End `@macro` with `@endmacro`, `@ifdef` with `@endif` and a shader block with `@endshader`."#,
        example: Library(
            r#"@define FLAG

startshape A

@ifdef FLAG
rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0207",
        severity: Error,
        title: "`@else` or `@endif` without `@ifdef`",
        explanation: r#"`@else` / `@endif` without `@ifdef`.

In the example: `@else` with no open `@ifdef`.

Fix: Remove the stray directive or add the `@ifdef` it belongs to."#,
        example: Library(
            r#"startshape A

@else
rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0208",
        severity: Error,
        title: "macro expansion nested too deeply",
        explanation: r#"Macro expansion nested too deeply (recursive macro).

In the example: a macro that expands itself, so the expansion never ends.

Fix: A macro that expands itself never ends; expand a different macro, or use a recursive rule instead."#,
        example: Library(
            r#"@macro LOOP(a)
@expand LOOP(a)
@endmacro

startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}

@expand LOOP(1)
"#,
        ),
    },
    Code {
        code: "E0209",
        severity: Error,
        title: "malformed preprocessor line",
        explanation: r#"Malformed `@param`, `@define`, `@presets` or `@import` line.

In the example: `@param` without a default value.

Fix: Follow the forms `@param TYPE NAME DEFAULT`, `@define NAME VALUE`, `@import PATH`."#,
        example: Library(
            r#"@param int steps

startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0210",
        severity: Error,
        title: "unknown preprocessor directive",
        explanation: r#"A line starting with `@` names no preprocessor directive.

In the example: `@include` is not a preprocessor directive (the directive is `@import`).

Fix: Use one of the directives listed in the spec (`@import`, `@define`, `@param`, `@macro`, `@expand`, `@ifdef`, …)."#,
        example: Library(
            r#"@include lib/shapes.mdg

startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0211",
        severity: Error,
        title: "macro defined twice",
        explanation: r#"Two `@macro` definitions have the same name; an `@expand` could not tell which one to use.

In the example: the macro TRI is defined twice.

Fix: Rename one of the macros or remove the duplicate."#,
        example: Library(
            r#"@macro TRI(size)
VERTEX {} VERTEX {x size} VERTEX {y size}
@endmacro

@macro TRI(size)
VERTEX {} VERTEX {y size} VERTEX {x size}
@endmacro

startshape A

rule A {
@expand TRI(1)
}
"#,
        ),
    },
    Code {
        code: "E0212",
        severity: Error,
        title: "imports nest too deeply",
        explanation: r#"A chain of `@import`s (a file importing a file importing a file …) holds more than 64 files.

In the example: `chain/c0.mdg` imports `c1.mdg`, which imports `c2.mdg`, and so on, 65 files deep.

Fix: Import the files from one file (a list of `@import`s) instead of each from the one before."#,
        example: Library(
            r#"@import chain/c0.mdg

startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0301",
        severity: Error,
        title: "unknown rule",
        explanation: r#"A rule call, or a creature part's `rule`, names a rule that no `rule` definition declares (names are case-sensitive).

In the example: the rule `Bee` is called but never defined.

Fix: Define the rule, or fix the name (the message suggests a close one)."#,
        example: Library(
            r#"startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
  Bee {x 1}
}
"#,
        ),
    },
    Code {
        code: "E0302",
        severity: Error,
        title: "unknown directive",
        explanation: r#"A top-level statement names no directive of the language.

In the example: `maxdepht` is not a directive (did you mean `maxdepth`?).

Fix: Fix the spelling (the message suggests a close directive)."#,
        example: Library(
            r#"startshape A
maxdepht 10

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0303",
        severity: Error,
        title: "unknown adjustment",
        explanation: r#"A name in an adjustment list `{ … }` is not an adjustment.

In the example: `rxx` is not an adjustment (did you mean `rx`?).

Fix: Fix the spelling (the message suggests a close adjustment)."#,
        example: Library(
            r#"startshape A

rule A {
  B {rxx 30}
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0304",
        severity: Error,
        title: "unknown selector mode",
        explanation: r#"A `selector` line names a mode the language does not have.

In the example: `randomly` is not a selector mode.

Fix: Use one of the modes the message lists (`random`, `depth`, `sequential`, …)."#,
        example: Library(
            r#"startshape A
selector A randomly

rule A 1 {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
rule A 2 {
  VERTEX {} VERTEX {x 2} VERTEX {y 2}
}
"#,
        ),
    },
    Code {
        code: "E0305",
        severity: Error,
        title: "selector names an undefined rule",
        explanation: r#"A `selector` line names a rule that has no definition.

In the example: the selector names a rule that is not defined.

Fix: Name a rule that has definitions."#,
        example: Library(
            r#"startshape A
selector B depth

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0306",
        severity: Error,
        title: "no `startshape`",
        explanation: r#"No `startshape` (when building or running a program).

In the example: built as a program, but there is no startshape.

Fix: Add `startshape RULE` to the program (a library checked on its own needs none)."#,
        example: Program(
            r#"rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0307",
        severity: Error,
        title: "`startshape` names an undefined rule",
        explanation: r#"The `startshape` directive names a rule that has no definition.

In the example: the start shape names a rule that is not defined.

Fix: Define the rule or fix the name."#,
        example: Library(
            r#"startshape Missing
linerule profile

rule profile {
  8 * {rz 45} VERTEX {x 0.1}
}
"#,
        ),
    },
    Code {
        code: "E0308",
        severity: Error,
        title: "rule reference names an undefined rule",
        explanation: r#"`linerule` / `camerarule` / transform / iterator rule names an undefined rule.

In the example: the linerule names a rule that is not defined.

Fix: Define the rule named by `linerule`, `camerarule`, the transform or iterator rule, or fix the name."#,
        example: Library(
            r#"startshape A
linerule Profile

rule A {
  LINETO {z 1}
}
"#,
        ),
    },
    Code {
        code: "E0309",
        severity: Error,
        title: "namespace declared twice",
        explanation: r#"A `namespace` block with this name was already declared.

In the example: the namespace `parts` is declared twice.

Fix: Put all of the namespace's rules in one `namespace` block."#,
        example: Library(
            r#"startshape A

namespace parts {
  rule leg {
    VERTEX {} VERTEX {x 1} VERTEX {y 1}
  }
}

namespace parts {
}

rule A {
  parts.leg {}
}
"#,
        ),
    },
    Code {
        code: "E0310",
        severity: Error,
        title: "unknown function",
        explanation: r#"A call in an expression names neither a built-in function nor a user `function`.

In the example: `sine` is not a function (did you mean `sin`?).

Fix: Fix the name (the message suggests a close built-in) or define the function."#,
        example: Library(
            r#"startshape A

rule A {
  B {rx (30 * sine(1))}
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0311",
        severity: Error,
        title: "unknown variable",
        explanation: r#"Unknown variable in an expression.

In the example: `angle_step` is neither a @param, a @define constant nor a built-in variable.

Fix: Declare it with `@param` or `@define`, or use a built-in variable."#,
        example: Library(
            r#"startshape A

rule A {
  B {rx (angle_step * 2)}
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0312",
        severity: Error,
        title: "`startshape`, `selector` or directive given twice",
        explanation: r#"`startshape`, `selector` or directive given twice.

In the example: startshape is given twice.

Fix: Keep one of the two."#,
        example: Library(
            r#"startshape A
startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0313",
        severity: Error,
        title: "function or isosurface defined twice",
        explanation: r#"Two `function` (or two `isosurface`) definitions have the same name.

In the example: the function shape_f is defined twice.

Fix: Rename one of them or remove the duplicate."#,
        example: Library(
            r#"startshape A

function shape_f { x*x + y*y + z*z - 1 }
function shape_f { x*x + y*y - 1 }

isosurface BALL {
  xyz -1 1 8 ;
  function shape_f
}

rule A {
  BALL {}
}
"#,
        ),
    },
    Code {
        code: "E0314",
        severity: Error,
        title: "unknown shader",
        explanation: r#"Unknown shader in `program`.

In the example: the program uses a fragment shader that is not defined.

Fix: Define the shader with `@vertexshader`/`@fragmentshader` … `@endshader`, or fix the name."#,
        example: Library(
            r#"startshape A

@vertexshader plain_vs
#version 450
layout(location = 0) in vec3 in_position;
void main() {
    gl_Position = vec4(in_position, 1.0);
}
@endshader

program {
  vertexshader plain_vs
  fragmentshader missing_fs
  target screen
  render
}

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0320",
        severity: Error,
        title: "definitions with different parameters",
        explanation: r#"Two definitions of one rule declare different parameter lists.

A call passes its arguments by position to whichever definition the selector picks, so every definition of a rule takes the same parameters (same names, same types, in the same order).

In the example: the second definition of `tree` has no `len`.

Fix: Give every definition the parameter list of the first."#,
        example: Library(
            r#"rule tree(int n, float len) {
  VERTEX {} VERTEX {x len} VERTEX {y n}
}

rule tree(int n) 0.5 {
  VERTEX {} VERTEX {x 1} VERTEX {y n}
}
"#,
        ),
    },
    Code {
        code: "E0321",
        severity: Error,
        title: "name defined twice in a rule",
        explanation: r#"A parameter, `let` binding or loop variable has the name of another one already in scope.

Bindings cannot shadow each other: a name means one value throughout its scope.

In the example: `let n` inside `tree` names a second `n`.

Fix: Give the new binding another name."#,
        example: Library(
            r#"rule tree(int n) {
  let n = 2;
  VERTEX {} VERTEX {x n} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0322",
        severity: Error,
        title: "wrong number of arguments",
        explanation: r#"A rule call passes more arguments than the rule has parameters, or fewer than its parameters without a default; or a drawable is given arguments.

In the example: `tree` needs `n` (it has no default), and the call passes nothing.

Fix: Pass one argument per parameter, in order; parameters with a default may be left out at the end."#,
        example: Library(
            r#"rule A { tree {} }

rule tree(int n, float len = 1) {
  VERTEX {} VERTEX {x len} VERTEX {y n}
}
"#,
        ),
    },
    Code {
        code: "E0323",
        severity: Error,
        title: "mismatched types",
        explanation: r#"A value of one type where another is expected: a `float` passed to an `int` parameter, a number to a `bool` one, a fractional iteration count.

An `int` is accepted where a `float` is expected; nothing else converts by itself. `floor(x)` and `ceil(x)` make an `int`, a comparison (`x != 0`) makes a `bool`. `/` and `^` always give a `float`.

In the example: `n / 2` is a `float`, and `n` is an `int` parameter.

Fix: Convert the value (the fix shows how), or change the parameter's type."#,
        example: Library(
            r#"rule tree(int n) {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
  if (n > 1) { tree(n / 2) {s 0.5} }
}
"#,
        ),
    },
    Code {
        code: "E0324",
        severity: Error,
        title: "rule needs arguments where none are passed",
        explanation: r#"A rule with a parameter that has no default is used where no call passes arguments: as the start shape, a profile, transform, iterator, line or camera rule.

Those runs start at the rule itself, so every parameter takes its default.

In the example: the start shape `tree` has a parameter `n` without a default.

Fix: Give the parameters defaults (`int n = 8`), or start from a rule that calls `tree(8) {}`."#,
        example: Program(
            r#"startshape tree

rule tree(int n) {
  VERTEX {} VERTEX {x 1} VERTEX {y n}
}
"#,
        ),
    },
    Code {
        code: "E0325",
        severity: Error,
        title: "unknown parameter type",
        explanation: r#"A parameter's type is not `int`, `float` or `bool`.

In the example: `natural` is Context Free's word for a whole number; MDG says `int`.

Fix: Use `int` (whole numbers), `float` (any number) or `bool` (true or false)."#,
        example: Library(
            r#"rule tree(natural n) {
  VERTEX {} VERTEX {x 1} VERTEX {y n}
}
"#,
        ),
    },
    Code {
        code: "E0326",
        severity: Error,
        title: "parameter without default after one with",
        explanation: r#"A parameter without a default follows one that has a default.

Arguments are passed by position and only trailing ones may be left out, so the parameters with defaults come last.

In the example: `n` has no default but comes after `len = 1`.

Fix: Move the parameters with defaults to the end, or give this one a default too."#,
        example: Library(
            r#"rule tree(float len = 1, int n) {
  VERTEX {} VERTEX {x len} VERTEX {y n}
}
"#,
        ),
    },
    Code {
        code: "E0327",
        severity: Error,
        title: "reserved word as a parameter name",
        explanation: r#"A parameter is named with a reserved word (`angle`, `color`, `weight`, `rule`, a section keyword …) or a dotted name.

Reserved words start top-level items, so they cannot be read as values in expressions or adjustment lists.

In the example: `angle` is the directive that sets the angle unit.

Fix: Choose another name (`spread`, `turn`)."#,
        example: Library(
            r#"rule fan(float angle) {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0329",
        severity: Error,
        title: "a name that cannot be bound by `let(…)`",
        explanation: r#"A binding of an expression's `let(NAME = VALUE; …)` uses a reserved name.

`x`, `y`, `z`, `depth`, `scale` and `g` are the variables expressions read, and dotted names are rule and constant names: a binding may not hide them.

In the example: `x` is the position's x coordinate.

Fix: Choose another name (`dx`, `r`)."#,
        example: Library(
            r#"function f(a) { let(x = a * 2; x + 1) }
"#,
        ),
    },
    Code {
        code: "E0330",
        severity: Error,
        title: "a function named like a built-in",
        explanation: r#"A `function` has the name of a math function (`sin`, `mix`, `rand`, …) or of `if` or `select`.

Calls of that name always run the built-in, so the function could never be called.

In the example: `select` is the built-in choice `select(i, a, b, …)`.

Fix: Choose another name (`pick2`, `my_mix`)."#,
        example: Library(
            r#"function select(a, b) { a + b }
"#,
        ),
    },
    Code {
        code: "E0331",
        severity: Error,
        title: "a recursive function that never returns",
        explanation: r#"A function with parameters calls itself (directly, or through other functions that call it back) on every way through its body, so no call of it can ever return.

Functions may be recursive: a call is evaluated with a limit on how deeply calls nest (`--max-call-depth`, 10,000 by default) and on how many calls one evaluation makes (`--max-calls`, 1,000,000), and past either the value is NaN with a warning. A function with no way out would always reach the limit, so it is refused here. `if(…)` and `select(…)` evaluate only the branch they choose, so a branch without the call is a way out; `&&` and `||` evaluate both sides.

In the example: `count` calls itself whatever `n` is.

Fix: Choose a case that returns without the call: `if(n <= 0, 0, 1 + count(n - 1))`."#,
        example: Library(
            r#"function count(n) { 1 + count(n - 1) }
"#,
        ),
    },
    Code {
        code: "E0332",
        severity: Error,
        title: "a vector where a number is expected",
        explanation: r#"A vector (`(a, b)`, a `vector2` parameter, a function that returns one) stands where a single number is needed: a condition, a count, a comparison, an argument of a math function, a number parameter.

Vectors are Context Free's: groups of numbers known while compiling (reference §6, "Vectors"). They may be added and subtracted (same size), multiplied and divided (componentwise, or by a number), indexed with a constant (`v[0]`), passed to `vector2` parameters and spread into adjustments (`x v` is `x v[0] v[1]`); anything else takes one component.

In the example: `sin` takes one number.

Fix: Take the component meant: `sin(v[0])`."#,
        example: Library(
            r#"function f(vector2 v) { sin(v) }
"#,
        ),
    },
    Code {
        code: "E0333",
        severity: Error,
        title: "a vector of the wrong size",
        explanation: r#"A `vector2` (or `vector3`, …) is expected and the value has another number of components, or is a single number; or `+`/`-` join vectors of different sizes, or a vector and a number.

As in Context Free, `+` and `-` take two vectors of one size, and `*` and `/` take two vectors of one size or a vector and a number; an argument passed to a `vectorN` parameter has N components.

In the example: `circ` takes a `vector2`, and `1` is one number.

Fix: Write the components: `circ((1, 1))`; add a vector: `v + (1, 1)`."#,
        example: Library(
            r#"rule circ(vector2 size) { CIRCLE [s size] }
rule A { circ(1) [] }
"#,
        ),
    },
    Code {
        code: "E0334",
        severity: Error,
        title: "a vector index that is not a constant, or out of range",
        explanation: r#"`v[i]` takes component i of a vector, counted from 0. The index must be known while compiling (a number, or arithmetic on numbers), since vectors exist only then, and must be less than the vector's size. Only a vector can be indexed.

In the example: `v` has two components, 0 and 1.

Fix: Use an index in range; to choose a component at run time, write `select(i, v[0], v[1])`."#,
        example: Library(
            r#"function f(vector2 v) { v[2] }
"#,
        ),
    },
    Code {
        code: "E0335",
        severity: Error,
        title: "a function with vectors that calls itself",
        explanation: r#"A function that takes or returns a vector is written out at each of its calls (its vectors are groups of numbers known while compiling), so it cannot call itself, directly or through others.

Recursive functions are compiled once and called at run time, and take and return numbers.

In the example: `walk` returns a `vector2` and calls itself.

Fix: Write the recursion over numbers, one function per component: `function walk_x(n) { if(n <= 0, 0, 1 + walk_x(n - 1)) }`."#,
        example: Library(
            r#"function walk(n) { if(n <= 0, (0, 0), walk(n - 1) + (1, 1)) }
"#,
        ),
    },
    Code {
        code: "E0336",
        severity: Error,
        title: "a call of a function with vectors that writes out too large",
        explanation: r#"A function that takes or returns a vector is written out at each call, each parameter replaced by the argument wherever the body reads it. Calls nested in each other's arguments therefore grow as a power of their depth: a body that reads its argument three times, nested twenty deep, would repeat the innermost argument 3^20 times. Past 200,000 operations for one call, the call is refused.

In the example: `sq` reads each component twice, nested 18 deep.

Fix: Bind a nested call's value first, so it is computed once: `let v = sq(sq(p));` in a rule body, or `let(v = sq(sq(p)); sq(sq(v)))`."#,
        example: Library(
            r#"function sq(vector2 a) { (a[0] * a[0], a[1] * a[1]) }
function deep(vector2 p) { sq(sq(sq(sq(sq(sq(sq(sq(sq(sq(sq(sq(sq(sq(sq(sq(sq(sq(p)))))))))))))))))) }
"#,
        ),
    },
    Code {
        code: "E0401",
        severity: Error,
        title: "wrong number of arguments",
        explanation: r#"Wrong number of arguments (adjustment, directive, function call).

In the example: `normal` takes three numbers.

Fix: Give the number of values the adjustment, directive or function takes (the message says how many)."#,
        example: Library(
            r#"startshape A
normal 0 1

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0402",
        severity: Error,
        title: "iterator divisor is 0",
        explanation: r#"An iterator `N/D * { … }` divides its repetitions by D, which must not be 0.

In the example: an iterator divisor of 0.

Fix: Use a divisor of 1 or more."#,
        example: Library(
            r#"startshape A

rule A {
  3/0 * {rz 90} B {}
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0403",
        severity: Error,
        title: "iterator count not a non-negative integer",
        explanation: r#"Iterator count is negative or not an integer.

In the example: an iterator count must be a non-negative integer.

Fix: Use a whole number of repetitions."#,
        example: Library(
            r#"startshape A

rule A {
  2.5 * {x 1} B {}
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0404",
        severity: Error,
        title: "unit suffix on a value that is not an angle",
        explanation: r#"A unit suffix (`d` degrees, `r` radians, `o` orbits, `t` atan) is only allowed on angles.

In the example: the unit suffix `d` on a translation, which is not an angle.

Fix: Remove the suffix; only angles take one."#,
        example: Library(
            r#"startshape A

rule A {
  B {z 2d}
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0405",
        severity: Error,
        title: "weight does not fit the selector",
        explanation: r#"Weight does not make sense for the rule's selector.

In the example: a sequential selector uses each definition `weight` times, so 2.5 makes no sense.

Fix: Use whole-number weights with a `sequential` selector."#,
        example: Library(
            r#"startshape row
selector tile sequential

rule row {
  6 * {x 1} tile {}
}

rule tile 2.5 {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
rule tile 1 {
  VERTEX {} VERTEX {x 0.5} VERTEX {y 0.5}
}
"#,
        ),
    },
    Code {
        code: "E0406",
        severity: Error,
        title: "bad isosurface grid",
        explanation: r#"Isosurface grid resolution ≤ 0 or min ≥ max.

In the example: the isosurface range has min >= max.

Fix: Give a resolution above 0 and a minimum below the maximum."#,
        example: Library(
            r#"startshape A

isosurface BALL {
  xyz 1 -1 16 ;
  function { x*x + y*y + z*z - 1 }
}

rule A {
  BALL {}
}
"#,
        ),
    },
    Code {
        code: "E0407",
        severity: Error,
        title: "invalid directive value",
        explanation: r#"A directive was given a value outside the ones it accepts (a mode name, a count, a range).

In the example: `gradians` is not an angle mode.

Fix: Use one of the values the directive accepts (the message lists them)."#,
        example: Library(
            r#"startshape A
angle gradians

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0408",
        severity: Error,
        title: "not a compile-time constant",
        explanation: r#"Expression is not a compile-time constant where one is required: an iterator divisor, a parameter default, a directive value.

Iterator counts may be known only at run time (`(n) * {…}` over a parameter), but divisors and defaults are fixed when the grammar is compiled.

In the example: an iterator divisor reads `depth`, which is only known at run time.

Fix: Use literals, `@param`/`@define` constants and functions of them."#,
        example: Library(
            r#"startshape A

rule A {
  4/(depth) * {z 1} B {}
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0409",
        severity: Error,
        title: "random draw not allowed here",
        explanation: r#"`rand`/`randn` where a random draw is not allowed.

In the example: a random draw inside a function (functions must be deterministic; rand is for adjustments).

Fix: Draw random values in adjustments, not in functions or other places that must be deterministic."#,
        example: Library(
            r#"startshape A

function bumpy { x*x + y*y + z*z - 1 + rand(0, 0.1) }

isosurface BLOB {
  xyz -1.5 1.5 16 ;
  function bumpy
}

rule A {
  BLOB {}
}
"#,
        ),
    },
    Code {
        code: "E0410",
        severity: Error,
        title: "malformed colour value",
        explanation: r#"A colour value in an adjustment list is `#` and 3, 4, 6 or 8 hex digits (`#f80`, `#f808`, `#ff8800`, `#ff880080`: red, green, blue and optionally alpha) or a colour name (`#tomato`, CSS's named colours); this one is neither.

In the example: `#ff880` has five hex digits.

Fix: Write 3, 4, 6 or 8 hex digits, or a colour name (the error suggests the nearest)."#,
        example: Library(
            r#"startshape A

rule A {
  CIRCLE {#ff880}
}
"#,
        ),
    },
    Code {
        code: "E0411",
        severity: Error,
        title: "bad flat path option",
        explanation: r#"The word after a flat path's drawable is its options (`FILL evenodd {}`, `ARCTO(1, 0, 1) large_cw {}`, `STROKE(0.1) roundjoin_squarecap {}`: words joined by `_`); this one is not an option of that drawable. In a flat path, `MOVETO` and `LINETO` take no profile rule.

In the example: `cw` is an option of `ARCTO`, not of `FILL`.

Fix: Use the drawable's own words: `ARCTO` large, cw; `CURVETO` smooth; `CLOSEPOLY` align; `FILL` evenodd; `STROKE` miterjoin, roundjoin, beveljoin, buttcap, roundcap, squarecap, iso (one join and one cap)."#,
        example: Library(
            r#"startshape A

rule A {
  MOVETO(0, 0) {} LINETO(1, 0) {} LINETO(0, 1) {}
  FILL cw {}
}
"#,
        ),
    },
    Code {
        code: "E0412",
        severity: Error,
        title: "`seed` outside a rule call",
        explanation: r#"`seed N` re-seeds a rule call: the call's whole sub-derivation draws from a random stream made from the run's seed and N, so two calls with the same N grow the same sub-tree (up to their frames), and the caller's stream goes on as if the call drew nothing. A drawable draws nothing, and an iterator's or a loop's adjustments are its step, so `seed` there means nothing.

In the example: `seed 2` is on `VERTEX`, a drawable.

Fix: Put `seed N` on the rule call it should replay (`6 * {rz 60} arm {seed 7}`), or remove it."#,
        example: Library(
            r#"startshape A

rule A {
  VERTEX {seed 2}
}
"#,
        ),
    },
    Code {
        code: "E0501",
        severity: Error,
        title: "GLSL error in a shader block",
        explanation: r#"GLSL error in a `@vertexshader` / `@fragmentshader` block (from glslang, at its line and column in the `.mdg` file).

In the example: GLSL errors in shader blocks are reported at their line and column in this file.

Fix: Fix the GLSL; the position is glslang's, mapped to the `.mdg` file."#,
        example: Library(
            r#"startshape A

@vertexshader ok_vs
#version 450
layout(location = 0) in vec3 in_position;
void main() {
    gl_Position = vec4(in_position, 1.0);
}
@endshader

@fragmentshader bad_fs
#version 450
layout(location = 0) out vec4 out_color;
void main() {
    out_color = vec4(undeclared_name, 1.0);
}
@endshader

program { vertexshader ok_vs fragmentshader bad_fs target screen render }

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0502",
        severity: Error,
        title: "shader block exceeds a limit of the shader compiler",
        explanation: r#"A `@vertexshader` / `@fragmentshader` block is too large or too complex to give to glslang, or glslang took too long on it. Before compiling, every block is checked against fixed limits (see `docs/limits.md`): at most 256 KiB of text, at most 262,144 tokens after its `#define`s are expanded, at most 2,048 operators in one statement after expansion, and macro calls nested at most 64 deep in macro arguments. A block within them is compiled with a deadline of 5 s. Without these limits a few hundred bytes of GLSL could overflow the compiler's stack or make it run for ever.

In the example: each `#define` uses the one before twice, so 12 levels make `L` 4,096 copies of `x` joined by 4,095 `+`: one statement with more than 2,048 operators.

Fix: Write long expressions as several statements with intermediate variables (or a loop), and use functions instead of macros that repeat their arguments."#,
        example: Library(
            r#"startshape A

@vertexshader doubling_vs
#version 450
#define A x+x
#define B A+A
#define C B+B
#define D C+C
#define E D+D
#define F E+E
#define G F+F
#define H G+G
#define I H+H
#define J I+I
#define K J+J
#define L K+K
void main() {
    float x = 1.0;
    gl_Position = vec4(L);
}
@endshader

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0601",
        severity: Error,
        title: "unknown key",
        explanation: r#"Unknown key in an extension section (`search`, `guide`, `creature`, `evolve`, `grid` and their blocks).

In the example: an unknown key in a shape (did you mean `size`?).

Fix: Fix the spelling (the message suggests a close key)."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a {
    sise 1 1 1;
    blocks stone;
  }
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0602",
        severity: Error,
        title: "value of the wrong form for a key",
        explanation: r#"A key of an extension section given a value of the wrong form (numbers where names belong, a block where values belong, a keyword that is not one of the choices).

In the example: control points are x y z triples.

Fix: Give the key the values its form asks for (the message says which)."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search { skeleton tree; }
guide g {
  points 0 0 0  0 0 1  0 0 2  0 0 3  1;
}
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0603",
        severity: Error,
        title: "key given twice",
        explanation: r#"A key of an extension section given twice.

In the example: a search option given twice.

Fix: Keep one of the two."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search {
  skeleton tree;
  generations 10;
  generations 20;
}
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0701",
        severity: Error,
        title: "a skeleton rule draws",
        explanation: r#"Guided search: a skeleton rule draws (a drawable or isosurface in its body; it must call a drawing rule instead).

In the example: a skeleton rule may not draw; it should call a drawing rule instead.

Fix: Move the drawables into a rule the skeleton rule calls."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search { skeleton tree; }
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule tree {
  tree {z 1 s 0.5}
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "E0702",
        severity: Error,
        title: "wrap-up for a rule that is not a skeleton rule",
        explanation: r#"Guided search: a wrap-up for a rule that is not a skeleton rule.

In the example: only skeleton calls are left over when the search stops, so a wrap-up for a rule that is not a skeleton rule never applies.

Fix: Wrap up only skeleton rules."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search {
  skeleton tree;
  wrapup leaf leaf;
}
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0703",
        severity: Error,
        title: "guide with fewer than 4 control points",
        explanation: r#"Guided search: a guide with fewer than 4 control points (or no `points`).

In the example: a cubic Bézier guide needs at least four control points.

Fix: Give at least four `points` (x y z triples)."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search { skeleton tree; }
guide g {
  points 0 0 0  0 0 1  0 0 2;
}
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0704",
        severity: Error,
        title: "guide points are not 3k + 1",
        explanation: r#"Guided search: a guide whose control points are not 3k + 1 (piecewise cubic Bézier).

In the example: piecewise cubic segments share end points, so a guide has 3k + 1 points.

Fix: Give 4, 7, 10, … control points."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search { skeleton tree; }
guide g {
  points 0 0 0  0 0 1  0 0 2  0 0 3  0 0 4;
}
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0705",
        severity: Error,
        title: "`delta_a` outside [−1, 1]",
        explanation: r#"Guided search: `delta_a` outside [−1, 1].

In the example: the alignment offset is compared with a dot product of unit vectors.

Fix: Use a value between −1 and 1."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search { skeleton tree; }
guide g {
  points 0 0 0  0 0 1  0 0 2  0 0 3;
  delta_a 1.5;
}
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0706",
        severity: Error,
        title: "second `search` section",
        explanation: r#"Guided search: a second `search` section.

In the example: a program has one search.

Fix: Merge the sections into one."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search { skeleton tree; }
search { generations 10; }
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0707",
        severity: Error,
        title: "search value out of range",
        explanation: r#"Guided search: a value out of range (`particles`, `generations`, `expected` not whole numbers in range, a negative heuristic scale, a ramp fraction outside [0, 1], a non-positive `budget` or `segment`, a negative `scale_u`).

In the example: a generation needs at least one particle.

Fix: Use a value in the range the message gives."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search {
  skeleton tree;
  particles 50 0;
}
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0708",
        severity: Error,
        title: "start shape is not a skeleton rule",
        explanation: r#"Guided search: the start shape is not a skeleton rule.

In the example: the search starts by expanding the start shape, so it must be a skeleton rule.

Fix: List the start shape in `skeleton`, or start from a skeleton rule."#,
        example: Library(
            r#"startshape scene
minsize 0.1
search { skeleton tree; }
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule scene { tree {} }
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0709",
        severity: Error,
        title: "wrap-up target is a skeleton rule",
        explanation: r#"Guided search: a wrap-up whose target is a skeleton rule.

In the example: a wrap-up must leave the skeleton (its target is evaluated without search).

Fix: Wrap up into a rule that is not in `skeleton`."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search {
  skeleton tree twig;
  wrapup tree twig;
}
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule tree { twig {} tree {z 1 s 0.5} }
rule twig { leaf {z 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0710",
        severity: Error,
        title: "skeleton rule with transform or iterator rules",
        explanation: r#"Guided search: a skeleton rule with transform rules or an iterator rule (animated or a convolution).

In the example: a skeleton rule runs once per expansion; it cannot be animated by transform rules.

Fix: Remove the transform rule from the skeleton rule, or take the rule out of `skeleton`."#,
        example: Library(
            r#"startshape tree
minsize 0.1
fps 10
duration 1
search { skeleton tree; }
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule tree : sway { leaf {} tree {z 1 s 0.5} }
rule sway { 10 * {rx 1} FRAME {} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0711",
        severity: Error,
        title: "skeleton rule with two wrap-ups",
        explanation: r#"Guided search: a skeleton rule with two wrap-ups.

In the example: a leftover call becomes one rule, so a skeleton rule has one wrap-up.

Fix: Keep one `wrapup` per skeleton rule."#,
        example: Library(
            r#"startshape tree
minsize 0.1
search {
  skeleton tree;
  wrapup tree leaf;
  wrapup tree bud;
}
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule tree { leaf {} bud {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
rule bud { VERTEX {} VERTEX {x 0.5} VERTEX {y 0.5} }
"#,
        ),
    },
    Code {
        code: "E0712",
        severity: Error,
        title: "no skeleton rules",
        explanation: r#"Guided search: no skeleton rules (`guide` sections without a `search` section, or a `search` section without `skeleton`).

In the example: guides steer skeleton rules, which a `search` section declares.

Fix: Add a `search { skeleton RULE; }` section, or remove the guides."#,
        example: Library(
            r#"startshape tree
minsize 0.1
guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }
rule tree { leaf {} tree {z 1 s 0.5} }
rule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
"#,
        ),
    },
    Code {
        code: "E0713",
        severity: Error,
        title: "skeleton rule with parameters",
        explanation: r#"A skeleton rule of a `search` section takes parameters, or passes arguments in a call.

Guided search keeps pending skeleton calls as small records (rule, frame, depth) that carry no arguments, so a skeleton rule cannot take parameters and its calls pass none: the rules it calls run with their defaults.

In the example: the skeleton rule `branch` takes a parameter `n`.

Fix: Drive the skeleton with depth selection or `@define` constants, and pass values to geometry rules from a non-skeleton rule."#,
        example: Library(
            r#"rule branch(int n = 3) {
  branch(n) {y 1 rz 20}
}

search {
  skeleton branch;
}
"#,
        ),
    },
    Code {
        code: "E0714",
        severity: Error,
        title: "skeleton rule with a non-uniform scale",
        explanation: r#"A skeleton rule of a `search` section scales its frame by different factors per axis (`s X Y Z`).

Guided search keeps pending skeleton calls as small records whose frame is a similarity (rotation, one scale, translation), so it cannot carry a non-uniform scale.

In the example: the skeleton rule `branch` calls itself with `s 1 0.8 1`.

Fix: Scale uniformly in the skeleton (`s 0.8`) and stretch the geometry in the rules it calls."#,
        example: Library(
            r#"rule branch {
  branch {y 1 s 1 0.8 1}
}

search {
  skeleton branch;
}
"#,
        ),
    },
    Code {
        code: "E0801",
        severity: Error,
        title: "unknown part type",
        explanation: r#"Creature grammar: unknown part type (in a rule, family, slot's `accepts` or `parts(…)`).

In the example: a rule names a part type no part has.

Fix: Use a `type` that some part declares, or fix the name."#,
        example: Library(beasts!(
            r#"  rule grow { kind increase; predecessor haed; }
"#
        )),
    },
    Code {
        code: "E0802",
        severity: Error,
        title: "torso has no such slot",
        explanation: r#"Creature grammar: a torso part has no slot of that name.

In the example: a creature attaches a part to a slot its torso does not have.

Fix: Use a slot the torso part declares (or its symmetric twin)."#,
        example: Library(beasts!(
            r#"  shape other { torso body; attach nek head; }
"#
        )),
    },
    Code {
        code: "E0803",
        severity: Error,
        title: "unknown part or category",
        explanation: r#"Creature grammar: unknown part or category.

In the example: a creature's torso is a part that was never declared.

Fix: Declare the part or category, or fix the name."#,
        example: Library(beasts!(
            r#"  shape other { torso bdy; }
"#
        )),
    },
    Code {
        code: "E0804",
        severity: Error,
        title: "structure rule can never match",
        explanation: r#"Creature grammar: a structure rule whose predecessor can never match (no creature can have the part, no slot accepts what it inserts, no allelic alternative, no torso to combine with).

In the example: no creature has a tail and no rule adds one, so the rule can never match.

Fix: Give some creature the part the rule looks for, or remove the rule."#,
        example: Library(beasts!(
            r#"  part tail { type tail; category beast; rule blob;
    joint { at 0 0 0; normal 0 -1 0; size 0.1; }
  }
  rule more_tails { kind increase;
    predecessor tail;
  }
"#
        )),
    },
    Code {
        code: "E0805",
        severity: Error,
        title: "probability can leave [0, 1]",
        explanation: r#"Creature grammar: a rule's probability can leave [0, 1] (checked at every generation up to 1000 and every count up to `maxparts`).

In the example: the probability grows past 1 after ten generations.

Fix: Bound the expression (e.g. with `min`/`max`) so it stays in [0, 1]."#,
        example: Library(beasts!(
            r#"  rule grow { kind increase; predecessor head;
    probability (0.4 * exp(0.1 * g));
  }
"#
        )),
    },
    Code {
        code: "E0806",
        severity: Error,
        title: "allelic family mixes incompatible kinds",
        explanation: r#"Creature grammar: an allelic family mixes incompatible kinds (a torso with parts that attach to one), or a type is in two families.

In the example: a torso and a leg cannot replace each other.

Fix: Put only parts that can replace each other (torsos with torsos, attached parts with attached parts) in a family, each type in one family."#,
        example: Library(beasts!(
            r#"  family torso leg;
"#
        )),
    },
    Code {
        code: "E0807",
        severity: Error,
        title: "part does not fit where it is put",
        explanation: r#"Creature grammar: a part does not fit where it is put (the slot does not accept its type; a shape's torso is not a torso).

In the example: the neck slot accepts heads, not legs.

Fix: Attach parts to slots whose `accepts` lists their type."#,
        example: Library(beasts!(
            r#"  shape other { torso body; attach neck leg; }
"#
        )),
    },
    Code {
        code: "E0808",
        severity: Error,
        title: "required key missing",
        explanation: r#"Creature grammar: a required key is missing (`type`, `category`, `rule`/`mesh`, a slot's `at`/`normal`/`size`/`accepts`, a rule's `kind`/`predecessor`, an insert rule's `successor`, a shape's `torso`).

In the example: a structure rule without a kind.

Fix: Add the key the message names."#,
        example: Library(beasts!(
            r#"  rule grow {
    predecessor head; probability 0.5; }
"#
        )),
    },
    Code {
        code: "E0809",
        severity: Error,
        title: "key does not belong here",
        explanation: r#"Creature grammar: a key that does not belong (a rule key of another rule kind, both `rule` and `mesh`, `color` on a rule part).

In the example: `take` is for combine rules.

Fix: Remove the key; it belongs to another kind of rule or part."#,
        example: Library(beasts!(
            r#"  rule grow { kind increase; predecessor head;
    take leg;
  }
"#
        )),
    },
    Code {
        code: "E0810",
        severity: Error,
        title: "mesh cannot be used",
        explanation: r#"Creature grammar: a part's mesh cannot be used (absolute path, outside the project, unreadable, not a usable OBJ file).

In the example: a part's mesh path leaves the project.

Fix: Use a relative path to an OBJ file inside the project."#,
        example: Library(beasts!(
            r#"  part horn { type head; category beast;
    mesh "/etc/horn.obj";
    joint { at 0 0 0; normal 0 0 -1; size 0.2; }
  }
"#
        )),
    },
    Code {
        code: "E0811",
        severity: Error,
        title: "attached part without a joint, or with slots",
        explanation: r#"Creature grammar: a non-torso part without a `joint`, or with slots.

In the example: a head without a joint cannot attach to a torso.

Fix: Give the part a `joint { … }`; only torsos have slots."#,
        example: Library(beasts!(
            r#"  part skull { type head; category beast; rule blob; }
"#
        )),
    },
    Code {
        code: "E0812",
        severity: Error,
        title: "part, slot, shape or rule defined twice",
        explanation: r#"Creature grammar: a part, slot, shape or rule defined twice, or a slot filled twice.

In the example: two parts with one name.

Fix: Rename one of them or remove the duplicate."#,
        example: Library(beasts!(
            r#"  part head { type head; category beast; rule blob;
    joint { at 0 0 0; normal 0 0 -1; size 0.2; }
  }
"#
        )),
    },
    Code {
        code: "E0813",
        severity: Error,
        title: "no parts or no creatures",
        explanation: r#"Creature grammar: no parts, or (in a program) no regular creatures to start from.

In the example: a program with a creature grammar but no regular creature to start from.

Fix: Declare parts and at least one regular `shape` to start from."#,
        example: Program(
            r#"startshape blob

rule blob {
  VERTEX {} VERTEX {x 0.1} VERTEX {y 0.1}
}

creature beasts {
  part body { type torso; category beast; rule blob;
    slot neck { at 0 0 1; normal 0 0 1; size 0.2; accepts torso; }
  }
}
"#,
        ),
    },
    Code {
        code: "E0814",
        severity: Error,
        title: "bad condition or probability expression",
        explanation: r#"Creature grammar: a bad condition or probability expression (unknown name or function, `rand`, `complexity` in a probability, a unit suffix).

In the example: a rule's probability may not draw random numbers.

Fix: Use only the names and functions the message lists, without `rand` or unit suffixes."#,
        example: Library(beasts!(
            r#"  rule grow { kind increase; predecessor head;
    probability (rand(0, 1));
  }
"#
        )),
    },
    Code {
        code: "E0815",
        severity: Error,
        title: "creature value out of range",
        explanation: r#"Creature grammar: a value out of range (zero normal, `up` parallel to the normal, non-positive size, a symmetric slot on the mirror plane, an `evolve` setting out of bounds).

In the example: a slot's normal is the zero vector.

Fix: Use a value in the range the message gives."#,
        example: Library(beasts!(
            r#"  part back { type torso; category beast; rule blob;
    slot tail { at 0 0 0; normal 0 0 0; size 0.1; accepts leg; }
  }
"#
        )),
    },
    Code {
        code: "E0901",
        severity: Error,
        title: "unknown block kind",
        explanation: r#"Grid grammar: a shape's `blocks` name a block kind that is not in the `palette`.

In the example: a shape's blocks name a palette entry that does not exist.

Fix: Add the block kind to the `palette` or fix the name."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a {
    size 2 1 1;
    blocks stone stnoe;
  }
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0902",
        severity: Error,
        title: "unknown shape",
        explanation: r#"Grid grammar: a `match`, `rule`, `start` or a shape's `like` names an unknown shape.

In the example: a rule names a shape that does not exist.

Fix: Declare the shape or fix the name."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape wall { size 1 1 1; blocks stone; }
  rule wall wal at 1 0 0;
  start wall;
}
"#,
        ),
    },
    Code {
        code: "E0903",
        severity: Error,
        title: "block count does not match the size",
        explanation: r#"Grid grammar: a shape's `blocks` list more or fewer cells than its `size` holds.

In the example: a 2×2×1 shape lists five cells.

Fix: List exactly x × y × z cells (`_` for an empty one)."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a {
    size 2 2 1;
    blocks
      stone stone
      stone stone stone;
  }
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0904",
        severity: Error,
        title: "malformed palette entry",
        explanation: r#"Grid grammar: a malformed `palette` entry (no block id, a block id with spaces, a colour that is not R G B, the name `_`).

In the example: a palette entry without the block id it stands for.

Fix: Write entries as `name "block:id";` with an optional R G B colour."#,
        example: Library(
            r#"grid g {
  palette {
    stone "minecraft:stone";
    glass;
  }
  shape a { size 1 1 1; blocks stone; }
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0905",
        severity: Error,
        title: "palette entry or shape defined twice",
        explanation: r#"Grid grammar: a palette entry or shape defined twice.

In the example: two shapes with one name.

Fix: Rename one of them or remove the duplicate."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a { size 1 1 1; blocks stone; }
  shape a { size 2 1 1; blocks stone stone; }
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0906",
        severity: Error,
        title: "`match` does not hold",
        explanation: r#"Grid grammar: a `match` that does not hold (the second shape is not the first turned that many quarter turns).

In the example: `b` is `a` turned once, not twice.

Fix: Give the number of quarter turns that maps the first shape onto the second."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; glass "minecraft:glass"; }
  shape a { size 2 1 1; blocks stone glass; }
  shape b { size 1 1 2; blocks glass stone; }
  match a b turn 2;
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0907",
        severity: Error,
        title: "malformed `rule`, `match`, `start` or `like`",
        explanation: r#"Grid grammar: a malformed `rule`, `match`, `start` or `like` entry.

In the example: a rule without `at` before its offset.

Fix: Follow the forms `rule A B at X Y Z [turn N];`, `match A B turn N;`, `start A;`, `like A [turn N];`."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a { size 1 1 1; blocks stone; }
  rule a a 1 0 0;
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0908",
        severity: Error,
        title: "required grid part missing",
        explanation: r#"Grid grammar: a required part is missing (`palette`, `start`, shapes, a shape's `size` or `blocks`).

In the example: no start shape.

Fix: Add the part the message names."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a { size 1 1 1; blocks stone; }
}
"#,
        ),
    },
    Code {
        code: "E0909",
        severity: Error,
        title: "shape empty or not connected",
        explanation: r#"Grid grammar: a shape with no blocks, or whose blocks are not connected face to face.

In the example: a shape's blocks must touch face to face.

Fix: Make every block touch another one face to face."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a {
    size 3 1 1;
    blocks stone _ stone;
  }
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0910",
        severity: Error,
        title: "bad `plane`",
        explanation: r#"Grid grammar: a bad `plane` (not `x`, `y`, `z` or `none`, or the shape is not one block thick along the axis named).

`none` says that a shape has no plane (a solid, or a flat shape that is not split along one), as induction with `--spec 3d` writes it.

In the example: a 2-wide shape is not flat along x.

Fix: Use `x`, `y` or `z`, along which the shape is one block thick, or `none`."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a {
    size 2 1 1;
    plane x;
    blocks stone stone;
  }
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0911",
        severity: Error,
        title: "second `grid` section",
        explanation: r#"Grid grammar: a second `grid` section.

In the example: a program has one grid grammar.

Fix: Merge the grammars into one `grid` section."#,
        example: Library(
            r#"grid a {
  palette { stone "minecraft:stone"; }
  shape s { size 1 1 1; blocks stone; }
  start s;
}
grid b {
  palette { stone "minecraft:stone"; }
  shape s { size 1 1 1; blocks stone; }
  start s;
}
"#,
        ),
    },
    Code {
        code: "E0912",
        severity: Error,
        title: "grid value out of range",
        explanation: r#"Grid grammar: a value out of range (a turn outside 0..3, a size, offset, colour, `steps`, `seal` or `seed` that is not a whole number in range, `example` past the `examples`).

In the example: a quarter-turn count is 0, 1, 2 or 3.

Fix: Use a value in the range the message gives."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a { size 1 1 1; blocks stone; }
  rule a a at 1 0 0 turn 4;
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0913",
        severity: Error,
        title: "`like` with `size` or `blocks`",
        explanation: r#"Grid grammar: a shape that is a reference (`like A [turn T]`) also gives its own `size` or `blocks`. A reference's size and blocks follow from the shape it refers to.

In the example: `b` is `a` turned, and also lists blocks.

Fix: Remove `size` and `blocks` from the reference, or remove `like` and write the shape in full."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a { size 2 1 1; blocks stone stone; }
  shape b { like a turn 1; blocks stone stone; }
  start a;
}
"#,
        ),
    },
    Code {
        code: "E0914",
        severity: Error,
        title: "cycle of `like`",
        explanation: r#"Grid grammar: shapes that are references (`like`) refer round to themselves, so none of them has blocks. A `like` may refer to another `like`, but the chain must end at a shape written in full.

In the example: `a` is like `b` and `b` is like `a`.

Fix: Write one shape of the cycle in full (`size` and `blocks`)."#,
        example: Library(
            r#"grid g {
  palette { stone "minecraft:stone"; }
  shape a { like b turn 1; }
  shape b { like a turn 3; }
  start a;
}
"#,
        ),
    },
    Code {
        code: "N0001",
        severity: Note,
        title: "more diagnostics than are reported",
        explanation: r#"An analysis reports at most 100 errors and 100 warnings, in the order of the source, like compilers that stop after an error limit. This note comes last and says how many more there were. The limit also bounds memory: the lexer, the parser and the preprocessor stop keeping diagnostics after 100 each, so a file of junk costs no more than a file with 100 errors.

In the example: 150 invalid characters, one per line, are 150 errors; the first 100 are shown.

Fix: Fix the first errors and check again: later errors are often consequences of earlier ones."#,
        example: Library(concat!(
            "% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n",
            "% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n",
            "% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n",
            "% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n",
            "% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n",
            "% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n% \n",
        )),
    },
    Code {
        code: "W0001",
        severity: Warning,
        title: "rule is never used",
        explanation: r#"A rule is defined but nothing calls it: neither the start shape, another rule, a directive nor an extension section.

In the example: the rule `spare` is never used.

Fix: Call the rule, or remove it."#,
        example: Library(
            r#"startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}

rule spare {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0002",
        severity: Warning,
        title: "rule is unreachable from the start shape",
        explanation: r#"A rule is called only from rules that are themselves never used, so the start shape never reaches it.

In the example: `helper` is called only by `spare`, which is never used, so it is unreachable from the start shape.

Fix: Call the rule (directly or indirectly) from the start shape, or remove it."#,
        example: Library(
            r#"startshape A

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}

rule spare {
  helper {}
}

rule helper {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0003",
        severity: Warning,
        title: "recursion can never terminate",
        explanation: r#"Every definition of a recursive rule calls itself again, and nothing (`maxdepth`, `minsize`, a shrinking scale with `minsize`, another definition) can stop the recursion.

In the example: `A` always calls itself and there is no `maxdepth`, `minsize` or other definition to stop it.

Fix: Add a stop: `maxdepth`, `minsize`, a second definition of the rule, or a shrinking adjustment with `minsize`."#,
        example: Library(
            r#"startshape A

rule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} A {z 1} }
"#,
        ),
    },
    Code {
        code: "W0004",
        severity: Warning,
        title: "rule shadows a drawable",
        explanation: r#"A rule has the name of a drawable (`VERTEX`, `LINETO`, …); calls of that name now call the rule, not the drawable.

In the example: a rule named VERTEX shadows the drawable of the same name.

Fix: Rename the rule."#,
        example: Library(
            r#"startshape VERTEX

rule VERTEX {
  MOVETO {}
  LINETO {z 1}
}
"#,
        ),
    },
    Code {
        code: "W0005",
        severity: Warning,
        title: "`selector` has no effect",
        explanation: r#"`selector` on a rule with a single definition has no effect.

In the example: a selector on a rule with a single definition has no effect.

Fix: Remove the selector, or add more definitions of the rule."#,
        example: Library(
            r#"startshape A
selector A random

rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0006",
        severity: Warning,
        title: "parameter or local never used",
        explanation: r#"A rule parameter, `let` binding or loop variable is never read.

In the example: the loop variable `i` is not used in the loop's body.

Fix: Use it, remove it, or start its name with `_` to say it is unused on purpose (`loop _i = 0, 5 …`)."#,
        example: Library(
            r#"rule ring {
  loop i = 0, 5 {rz 72} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0007",
        severity: Warning,
        title: "recursion on a parameter that never stops",
        explanation: r#"A rule calls itself inside an `if` whose condition the call's arguments keep true: `if (n > 0) { R(n + 1) {…} }` recurses for ever.

The checker reports the decidable case: a comparison of a parameter with a constant, and an argument that is the parameter plus or minus a constant moving away from the end. Runs stop at the rule-call limit (`--maxiter`) with a warning.

In the example: `n` grows while `n > 0` requires it to stay above 0.

Fix: Move the parameter towards the end of the condition (`n - 1`), or bound the recursion with `maxdepth N`."#,
        example: Library(
            r#"rule tree(int n) {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
  if (n > 0) { tree(n + 1) {y 1 s 0.9} }
}
"#,
        ),
    },
    Code {
        code: "W0008",
        severity: Warning,
        title: "adjustment order differs from Context Free",
        explanation: r#"A `[ … ]` adjustment list that Context Free 3 would apply in another order.

Context Free reorders a single-bracket list to translate, rotate, scale, flip (only `[[ … ]]` keeps the written order); MDG applies every list, `{ }` or `[ ]`, in the order written. The warning is given where the two orders give different frames: a rotation before a translation off its axis, or a scale or flip before a translation. A program ported from Context Free then silently moves its shapes.

In the example: `[r 45 x 1]` in Context Free moves 1 along x, then turns; MDG turns, then moves along the turned x.

Fix: If the list came from Context Free, take the fix (it writes the Context Free order); if you meant the written order, use `{ }` braces, which Context Free users read as ordered."#,
        example: Library(
            r#"rule A {
  B [r 45 x 1]
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0009",
        severity: Warning,
        title: "trigonometry on a number that looks like degrees",
        explanation: r#"`sin`, `cos` or `tan` of a whole number larger than 2π: it is most likely meant in degrees.

Adjustments read angles in degrees (`rz 90`), and so do Context Free's trigonometric functions; MDG's math functions read radians, as most programming languages do. A program ported from Context Free keeps `sin(90)` and silently changes.

In the example: `sin(90)` is sin of 90 radians, about 0.89, not 1.

Fix: Write `sin(radians(90))`, or the angle in radians."#,
        example: Library(
            r#"rule A {
  VERTEX {} VERTEX {x (sin(90))} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0010",
        severity: Warning,
        title: "profile rule called as a shape",
        explanation: r#"A rule that serves as a profile (`LINETO circle {…}`) is called as a shape.

A profile rule's VERTEX points outline the cross-section that `MOVETO`/`LINETO` sweep; called as a shape, the same points are read three at a time as triangles and draw a fan of slivers. Context Free users expect `CIRCLE` to be a filled shape; MDG's std `circle` is a profile.

In the example: `ring` is the profile of the tube and is also called as a shape.

Fix: Sweep the profile along a path (`MOVETO {} LINETO ring {z 1}`), or call a shape (std `SPHERE`, `disc`)."#,
        example: Library(
            r#"rule A {
  MOVETO {} LINETO ring {z 1}
  ring {}
}

rule ring {
  12 * {rz 30} VERTEX {x 0.2}
}
"#,
        ),
    },
    Code {
        code: "W0011",
        severity: Warning,
        title: "`r` with one angle turns about x",
        explanation: r#"`r A` (or `rotate A`) in a `[ ]` list: with one angle, MDG's `r` turns about the x axis.

MDG's `r X Y Z` turns about x, then y, then z; Context Free's `r A` turns about z, the axis perpendicular to its 2D plane. A list written for Context Free (`[y 1 r 25]`) then folds the shape out of the plane.

In the example: `[y 1 r 25]` tilts the branch about x.

Fix: Write `rz 25` (the fix), or `rx`/`ry` for the axis you mean."#,
        example: Library(
            r#"rule A {
  B [y 1 r 25]
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0012",
        severity: Warning,
        title: "document too large to analyse as you type",
        explanation: r#"The language server analyses an open document on every edit; past 2 MiB (`analysis::MAX_LIVE_BYTES`) it stops: a 15 MB grammar took 5.8 GB of memory and 29 s per analysis, and every feature waited for it. The document gets this one warning at its start; hover, completion and the other features answer nothing for it, and the rest of the workspace is served as usual.

In the example: a 3 MB grammar opened in the editor.

Fix: Check the file with `mdgc check FILE` (which reads up to 16 MiB), split the grammar into files joined with `@import`, or start the server with a larger `MDG_LSP_MAX_LIVE_BYTES` (in bytes)."#,
        example: Editor("a document of more than 2 MiB opened in the editor"),
    },
    Code {
        code: "W0013",
        severity: Warning,
        title: "adjustment argument is not a finite number",
        explanation: r#"An adjustment argument computed at compile time is NaN (not a number: `0/0`, `log(-1)`, `sqrt(-1)`, `asin(2)`, or a function of one, such as `clamp(1, log(-1), 2)`) or infinite (`1e308 * 10`, `1 / 0`, `exp(1000)`). No position, angle or scale can be made of it, so the adjustment uses 0 in its place (the other adjustments of the list still apply); an argument computed at run time that is not a finite number is also used as 0, and the run reports how many there were and where.

In the example: `log(-1)` is NaN, so `y` moves the second triangle by 0.

Fix: Compute a value that exists: keep the argument of `log` and `sqrt` positive (`log(max(v, 1e-9))`), divide by something that is not 0, and keep exponents small."#,
        example: Program(
            r#"startshape A

rule A {
  B {}
  B {y (log(-1)) x 2}
}

rule B {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0014",
        severity: Warning,
        title: "invisible text-direction or line-break character in a comment or string",
        explanation: r#"A comment, string, shader block or preprocessor line holds a character that changes how the text is shown but not how it is read: a bidirectional embedding, override or isolate (U+202A–U+202E, U+2066–U+2069), or a Unicode line break the language does not count as one (U+2028 LINE SEPARATOR, U+2029 PARAGRAPH SEPARATOR, U+0085 NEXT LINE).

Editors and code review tools reorder the text after a right-to-left override, so a comment can appear to end where it does not, or code can appear inside a comment ("Trojan Source", CVE-2021-42574); a line separator shows as a new line that the compiler does not see. The warning names every such code point, at the first one. Rendered diagnostics show them escaped (`\u{202e}`), as they do terminal control characters.

In the example: a right-to-left override in a comment makes `}nimda{` display reversed. (This page shows the invisible character as `\u{202e}`; the example file holds the character itself.)

Fix: Delete the characters, unless the text is right-to-left prose that needs them."#,
        example: Library("rule A {\n  VERTEX {} VERTEX {x 1} VERTEX {y 1} // check \u{202e} }nimda{ \n}\n"),
    },
    Code {
        code: "W0015",
        severity: Warning,
        title: "rule also defined in another file",
        explanation: r#"Definitions of one rule name are alternatives: each call picks one of them at random, by weight. A rule defined in the std library or an imported file and again in your file therefore gets a second, random definition; without this warning that happened in silence (a port of Mondrian's `rule square` under `@import primitives` drew 70 triangles instead of 120, because half of the calls ran std's `square`). The warning is on the definition in the file nearest the main file and points at the other file's definition.

In the example: `@import primitives` defines `square`, and the file defines its own.

Fix: Rename the rule if it is a new one (`rule tile`). If adding a definition to the other file's rule is what you mean, say so: `rule square += { … }` (the weight, if any, after it: `rule square += 0.5 { … }`); the quick fix writes `+=`."#,
        example: Program(
            r#"@import primitives
startshape A

rule A {
  square {}
}

rule square {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0016",
        severity: Warning,
        title: "`+=` on a rule no other file defines",
        explanation: r#"`rule NAME += { … }` says that the definition adds to a rule that the std library or an imported file defines (W0015). No other file defines this rule, so there is nothing to add to: the definition is the rule's own, as if `+=` were not written. Usually the import that defines the rule is missing or the name is misspelt.

In the example: `tile` is defined only here.

Fix: Remove `+=`, or import the file that defines the rule you meant to add to."#,
        example: Program(
            r#"startshape tile

rule tile += {
  VERTEX {} VERTEX {x 1} VERTEX {y 1}
}
"#,
        ),
    },
    Code {
        code: "W0801",
        severity: Warning,
        title: "regular creature cannot pass the stability test",
        explanation: r#"A regular creature (`shape`) is subject to the stability test — its centre of mass must lie over the convex hull of its support points — but none of its parts is a `support` part, so it has no support points and neither it nor any monster evolved from it without legs can stand. Evolution rejects every such offspring; with only such creatures, a generation is empty.

In the example: the fish has a body and a tail, and nothing to stand on.

Fix: A swimmer or a flier says `floats;` in its `shape` (it and its offspring skip the test), or the whole grammar says `stability off;` in `evolve`. A walker needs `support;` parts (legs)."#,
        example: Program(
            r#"startshape blob

rule blob {
  VERTEX {} VERTEX {x 0.1} VERTEX {y 0.1}
}

creature sea {
  part body { type torso; category fish; rule blob;
    slot tail { at 0 0.5 0; normal 0 1 0; size 0.2; accepts tail; }
  }
  part fin { type tail; category fish; rule blob;
    joint { at 0 0 0; normal 0 -1 0; size 0.2; }
  }
  shape fish { torso body; attach tail fin; }
}
"#,
        ),
    },
    Code {
        code: "W0802",
        severity: Warning,
        title: "structure rule whose conditions never hold",
        explanation: r#"Creature grammar: a structure rule's predecessor can match, but its conditions (all of them together) hold for no shape the evolution can make, so the rule never applies.

The checker evaluates the conditions at every generation g = 1..1000 and every value of the counts they read that a shape of at most `maxparts` meta-parts can have (1 ≤ torsos ≤ superparts ≤ metaparts ≤ maxparts, 1 ≤ count ≤ metaparts, parts(…) of a type no creature can have is 0). A condition reading `complexity` (a real number) is not checked.

In the example: with `maxparts 12` no shape has more than 12 super-parts.

Fix: Loosen the condition (or raise `maxparts`), or remove the rule."#,
        example: Program(
            r#"startshape blob

rule blob {
  VERTEX {} VERTEX {x 0.1} VERTEX {y 0.1}
}

creature beasts {
  part body { type torso; category beast; rule blob;
    slot neck { at 0 0 1; normal 0 0 1; size 0.2; accepts head; }
  }
  part head { type head; category beast; rule blob;
    joint { at 0 0 0; normal 0 0 -1; size 0.2; }
  }
  shape beast { torso body; attach neck head; floats; }
  rule more_heads { kind increase; predecessor head; condition (superparts > 20); }
  evolve { maxparts 12; }
}
"#,
        ),
    },
    Code {
        code: "W0901",
        severity: Warning,
        title: "induced grammar only rebuilds its example",
        explanation: r#"`mdgc induce`: no inferred shape matches another, so rules are never shared (paper eq. 6) and a derivation can only add shapes where the example has them: every building the grammar generates is a part of the example.

Fix: Infer smaller, repeated shapes: `--ops both` with a smaller `--alpha`, `--spec rect`, or `--cost kinds`; give several examples (`--share`)."#,
        example: Command("`mdgc induce tower.txt --spec 3d -o s.mdg` on a building whose one solid shape is the whole building"),
    },
    Code {
        code: "W0902",
        severity: Warning,
        title: "shape inference made no move",
        explanation: r#"`mdgc induce`: the hill climbing stopped where it started (no merge, no split): the shapes are the initial segmentation, whatever the cost function's weights. The cost's trade-off between the number of shapes and their entropy did not favour any move from there at this α.

Fix: Try `--alpha` below 1 (splits pay when a cut lowers the entropy by more than α) or `--cost kinds` (mixed shapes cost more)."#,
        example: Command("`mdgc induce house.txt --cost sum --alpha 1 -o s.mdg` on a house whose maximal rectangles are already its best shapes"),
    },
    Code {
        code: "W0903",
        severity: Warning,
        title: "seeds give identical buildings",
        explanation: r#"`mdgc induce`: the grammar was generated with ten seeds (the default options) and every seed gave the same building (up to where it stands): the seed has no effect, so the grammar describes one building, not a style.

Fix: Infer shapes that repeat (see W0901), or generate with more `--steps` or `--random-start`."#,
        example: Command("`mdgc induce hut.txt -o s.mdg` on a building whose shapes fit together only one way"),
    },
];

/// The entry for `code` (`E0301`, `w0001`: case does not matter).
pub fn lookup(code: &str) -> Option<&'static Code> {
    let code = code.to_ascii_uppercase();
    CODES.binary_search_by(|c| c.code.cmp(code.as_str())).ok().map(|i| &CODES[i])
}

/// The text `mdgc explain CODE` prints: the title, the explanation and the example.
pub fn explain(code: &Code) -> String {
    let sev = code.severity.name();
    let mut s = format!("{} ({sev}): {}\n\n{}\n\nExample", code.code, code.title, code.explanation);
    if let Example::Editor(t) | Example::Command(t) = code.example {
        s.push_str(&format!(": {t}\n"));
        return s;
    }
    if code.example.is_program() {
        s.push_str(" (checked as a program)");
    }
    s.push_str(":\n\n");
    for line in crate::text::escape_text(code.example.text()).lines() {
        s.push_str("    ");
        s.push_str(line);
        s.push('\n');
    }
    s
}

/// The introduction of `docs/diagnostics.md`.
const DOC_INTRO: &str = "# Diagnostic codes

Every diagnostic the compiler emits has a code. Errors are `E`, warnings `W`,
notes `N`.
Each code has a test in `tests/check/err/` (or `tests/parse/err/`) that shows its
rendered text. `mdgc explain CODE` prints a code's entry below.

This file is generated from the registry in `compiler/src/codes.rs`; edit the
registry and regenerate it with `MDG_BLESS=1 cargo test -p mdg-compiler codes`.
";

/// `docs/diagnostics.md`: the introduction, the table of codes and one section per
/// code with its explanation and example.
pub fn markdown() -> String {
    let mut s = String::from(DOC_INTRO);
    s.push_str("\n| code | severity | meaning |\n|---|---|---|\n");
    for c in CODES {
        let sev = c.severity.name();
        s.push_str(&format!("| [{0}](#{1}) | {sev} | {2} |\n", c.code, c.code.to_ascii_lowercase(), c.title));
    }
    for c in CODES {
        s.push_str(&format!("\n## {}\n\n**{}**\n\n{}\n\n", c.code, c.title, c.explanation));
        if let Example::Editor(t) | Example::Command(t) = c.example {
            s.push_str(&format!("Example: {t}.\n"));
            continue;
        }
        s.push_str(if c.example.is_program() { "Example (checked as a program):\n" } else { "Example:\n" });
        s.push_str("\n```mdg\n");
        s.push_str(&crate::text::escape_text(c.example.text()));
        s.push_str("```\n");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::CheckOptions;
    use crate::driver::analyze_text;
    use crate::expand::Options;
    use crate::source::FsLoader;
    use std::path::{Path, PathBuf};

    fn workspace() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    #[test]
    fn registry_is_sorted_and_well_formed() {
        for w in CODES.windows(2) {
            assert!(w[0].code < w[1].code, "{} before {}: keep CODES sorted, without duplicates", w[0].code, w[1].code);
        }
        for c in CODES {
            let b = c.code.as_bytes();
            assert!(b.len() == 5 && b[1..].iter().all(u8::is_ascii_digit), "{}: not a code", c.code);
            let letter = c.severity.letter();
            assert_eq!(b[0], letter, "{}: the letter does not match the severity", c.code);
            assert!(!c.title.is_empty() && !c.title.contains('\n') && !c.title.ends_with('.'), "{}: title", c.code);
            assert!(c.explanation.len() > c.title.len() && c.explanation.contains("Fix:"), "{}: explanation", c.code);
            assert!(lookup(c.code).is_some_and(|l| l.code == c.code));
            assert!(lookup(&c.code.to_ascii_lowercase()).is_some());
        }
        assert!(lookup("E9999").is_none() && lookup("").is_none() && lookup("rule").is_none());
    }

    /// Every example, checked as `project/example.mdg` on disk (beside `project/`
    /// lies `outside.mdg`, for E0202; in `project/chain/` a chain of files each
    /// importing the next, one longer than `MAX_IMPORT_DEPTH`, for E0212), produces
    /// its code and no other error (a note's example is all about other errors).
    #[test]
    fn every_example_triggers_its_code() {
        let scratch = std::env::temp_dir().join(format!("mdg-codes-{}", std::process::id()));
        let project = scratch.join("project");
        std::fs::create_dir_all(&project).expect("create the example project");
        std::fs::write(scratch.join("outside.mdg"), "rule outside { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n")
            .expect("write outside.mdg");
        let chain = project.join("chain");
        std::fs::create_dir_all(&chain).expect("create the chain");
        for i in 0..crate::expand::MAX_IMPORT_DEPTH {
            std::fs::write(chain.join(format!("c{i}.mdg")), format!("@import c{}.mdg\nrule c{i} {{ }}\n", i + 1))
                .expect("write a chain file");
        }
        let last = crate::expand::MAX_IMPORT_DEPTH;
        std::fs::write(chain.join(format!("c{last}.mdg")), format!("rule c{last} {{ }}\n")).expect("write the last");
        let path = project.join("example.mdg");
        let opts = Options { std_dir: Some(workspace().join("std")), ..Options::default() };
        let mut failures = Vec::new();
        for c in CODES {
            if matches!(c.example, Example::Editor(_) | Example::Command(_)) {
                continue;
            }
            let text = c.example.text();
            std::fs::write(&path, text).expect("write example.mdg");
            let a = analyze_text(&FsLoader, &path, text, &opts, CheckOptions { require_start: c.example.is_program() });
            let got: Vec<&str> = a.diagnostics.iter().map(|d| d.code).collect();
            let others = c.severity != Note && a.diagnostics.iter().any(|d| d.is_error() && d.code != c.code);
            if !got.contains(&c.code) || others {
                failures.push(format!("{}: the example gives {got:?}", c.code));
            }
        }
        let _ = std::fs::remove_dir_all(&scratch);
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    /// `docs/diagnostics.md` is the generated text; `MDG_BLESS=1` rewrites it.
    #[test]
    fn docs_equal_the_registry() {
        let path = workspace().join("docs/diagnostics.md");
        let want = markdown();
        if std::env::var_os("MDG_BLESS").is_some() {
            std::fs::write(&path, &want).expect("write docs/diagnostics.md");
            return;
        }
        let have = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            have == want,
            "docs/diagnostics.md is not the text generated from compiler/src/codes.rs; \
             regenerate it with `MDG_BLESS=1 cargo test -p mdg-compiler codes`"
        );
    }

    /// The `.rs` files under `dir`, recursively, sorted.
    fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> =
            std::fs::read_dir(dir).expect("read dir").map(|e| e.expect("dir entry").path()).collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                rust_files(&p, out);
            } else if p.extension().is_some_and(|e| e == "rs") {
                out.push(p);
            }
        }
    }

    /// The code literals (`"E0301"`, `"W0001"`) in `text`.
    fn code_literals(text: &str) -> Vec<&str> {
        let b = text.as_bytes();
        let mut v = Vec::new();
        for i in 0..b.len().saturating_sub(6) {
            let w = &b[i..i + 7];
            if w[0] == b'"'
                && w[6] == b'"'
                && matches!(w[1], b'E' | b'W' | b'N')
                && w[2..6].iter().all(u8::is_ascii_digit)
            {
                v.push(&text[i + 1..i + 6]);
            }
        }
        v
    }

    /// Every code literal in the crates' sources is registered, and every registered
    /// code is emitted somewhere outside this file and outside test modules.
    #[test]
    fn sources_and_registry_agree() {
        let mut files = Vec::new();
        for krate in ["compiler", "vm", "export", "guided", "creature", "grid", "lsp", "cli", "viewer"] {
            rust_files(&workspace().join(krate).join("src"), &mut files);
        }
        assert!(files.len() > 20, "found only {} source files", files.len());
        let this = Path::new(file!()).file_name().expect("file name");
        let mut unknown = Vec::new();
        let mut emitted = std::collections::BTreeSet::<String>::new();
        for f in &files {
            let text = std::fs::read_to_string(f).expect("read source");
            if f.file_name() == Some(this) {
                continue; // the registry itself
            }
            for code in code_literals(&text) {
                if lookup(code).is_none_or(|c| c.code != code) {
                    unknown.push(format!("{}: {code}", f.display()));
                }
            }
            // Up to the first inline test module (`#[cfg(test)] mod x;` declarations
            // of test files do not end the live code).
            let live = text
                .match_indices("#[cfg(test)]")
                .find(|(i, m)| text[i + m.len()..].lines().nth(1).is_some_and(|l| l.trim_end().ends_with('{')))
                .map_or(text.as_str(), |(i, _)| &text[..i]);
            emitted.extend(code_literals(live).into_iter().map(str::to_string));
        }
        assert!(unknown.is_empty(), "codes not in compiler/src/codes.rs: {unknown:?}");
        let never: Vec<&str> = CODES.iter().map(|c| c.code).filter(|c| !emitted.contains(*c)).collect();
        assert!(never.is_empty(), "registered codes that nothing emits: {never:?}");
    }

    #[test]
    #[cfg(debug_assertions)]
    #[should_panic(expected = "is not registered")]
    fn unregistered_code_panics_in_debug_builds() {
        let _ = crate::diag::Diagnostic::error("E0000", crate::span::Span::default(), "no such code");
    }

    #[test]
    #[cfg(debug_assertions)]
    #[should_panic(expected = "is not registered as a Warning")]
    fn wrong_severity_panics_in_debug_builds() {
        let _ = crate::diag::Diagnostic::warning("E0301", crate::span::Span::default(), "an error code");
    }
}
