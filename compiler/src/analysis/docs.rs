//! Short documentation for every built-in word: directives, adjustments, drawables,
//! selector and angle modes, preprocessor directives, isosurface entries, program
//! commands, expression functions and variables. Hover and completion read it; a
//! test checks that every name the checker knows has an entry.

/// What kind of built-in word a doc entry describes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DocKind {
    Directive,
    Adjustment,
    Drawable,
    SelectorMode,
    AngleMode,
    Preprocessor,
    IsoEntry,
    ProgramCommand,
    Function,
    Variable,
}

/// One entry: the word, how it is written, and what it does (one or two sentences).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Doc {
    pub kind: DocKind,
    pub name: &'static str,
    pub signature: &'static str,
    pub text: &'static str,
}

const fn d(kind: DocKind, name: &'static str, signature: &'static str, text: &'static str) -> Doc {
    Doc { kind, name, signature, text }
}

use DocKind::*;

/// Every entry, grouped by kind.
pub const DOCS: &[Doc] = &[
    // Directives (reference §3).
    d(Directive, "startshape", "startshape RULE", "The rule evaluated first (depth 0). A file with a `startshape` is a program; without one it is a library."),
    d(Directive, "rule", "rule NAME[(TYPE P [= DEFAULT], …)] [* ITER] [: XF]… [WEIGHT] [maxdepth N [> OTHER]] { BODY }", "A rule definition. A name may have several definitions (all with the same parameters); each call picks one with the rule's selector. WEIGHT defaults to 1. `maxdepth N > OTHER`: this definition runs at most N times on a call's path, then OTHER runs instead (Structure Synth's `md N > OTHER`)."),
    d(Directive, "if", "if (CONDITION) { BODY } [else { BODY } | else if …]", "Runs the first body when the condition is not 0, else the `else` branch. Conditions are any expressions: comparisons, `&&`, `||`, `!`, parameters."),
    d(Directive, "else", "else { BODY } | else if (CONDITION) { BODY }", "The branch of an `if` taken when its condition is 0."),
    d(Directive, "switch", "switch (EXPRESSION) { case A, B..C: ITEMS … else: ITEMS }", "Runs the items of the first arm whose labels hold floor(EXPRESSION): a label A holds floor(A), a range B..C every whole number from floor(B) to floor(C). `else:` (last) runs when no arm does. Context Free's `switch`; the same as an `if` / `else if` chain on floor(EXPRESSION), evaluated once."),
    d(Directive, "case", "case A, B..C: ITEMS", "An arm of a `switch`: its items run when floor of the switch's value equals floor(A), or lies from floor(B) to floor(C), for any of its labels."),
    d(Directive, "let", "let NAME = EXPRESSION;", "A local binding, visible to the items after it in its block; evaluated once when the body reaches it."),
    d(Directive, "loop", "loop NAME = START, END [, STEP] {ADJ} ITEM", "Context Free's loop: ITEM runs for NAME = START, START + STEP, … while below END; the first run is under the frame itself, ADJ applies once more before each further run."),
    d(Directive, "int", "int NAME [= DEFAULT]", "A whole-number parameter (counts, depths). Accepts `int` values only: `floor(x)` converts."),
    d(Directive, "float", "float NAME [= DEFAULT]", "A number parameter. Accepts `int` and `float` values."),
    d(Directive, "bool", "bool NAME [= DEFAULT]", "A truth-value parameter: `true`, `false`, a comparison, `&&`, `||`, `!`."),
    d(Directive, "vector2", "vector2 NAME [= (A, B)]", "A vector parameter (Context Free's; `vector3` … `vector99` likewise): a call passes one vector, `(1, 2)` or a vector name; `NAME[0]` and `NAME[1]` are its components, and `{x NAME}` gives both to the adjustment. Vectors exist while compiling only (reference §14, \"Vectors\")."),
    d(Directive, "vector3", "vector3 NAME [= (A, B, C)]", "A vector parameter of three components (see `vector2`): `{s NAME}` scales by all three, `NAME[2]` is the third."),
    d(Directive, "selector", "selector RULE[, RULE…] MODE", "How a rule's definitions are chosen: random (default), frequency, depth, scale, sequential, pattern, or function F / function { EXPR }."),
    d(Directive, "linerule", "linerule RULE", "The default profile rule swept by MOVETO/LINETO/BLENDTO/SLINETO/ALINETO."),
    d(Directive, "camerarule", "camerarule RULE", "The camera's trajectory: a transform rule whose FRAMEs the camera follows."),
    d(Directive, "namespace", "namespace NS { ITEMS }", "Rules inside are named `NS.NAME`; inside, unqualified calls resolve to `NS.NAME` first. Each namespace has its own pen (`NS.LINETO`)."),
    d(Directive, "maxdepth", "maxdepth N", "A call deeper than N is not made. Default: no limit."),
    d(Directive, "minsize", "minsize S", "A call whose linear scale is below S is not made. Default: no limit."),
    d(Directive, "maxiter", "maxiter N", "At most N rule calls (iterator runs count too) in the whole run. Default 50,000,000."),
    d(Directive, "breadthfirst", "breadthfirst", "Calls run generation by generation, every call at depth d before any at d + 1 (Structure Synth's order), instead of depth first; for `maxobjects`."),
    d(Directive, "maxobjects", "maxobjects N", "With `breadthfirst`: the run ends after the generation in which the N-th object (a rule body that draws) was drawn; the calls still queued are not run, with a warning. Default: no limit."),
    d(Directive, "stacksize", "stacksize N", "At most N pending calls on the VM's stack. Default 100,000."),
    d(Directive, "randseed", "randseed N", "Seed of the random stream (`--seed` overrides). Default 0."),
    d(Directive, "angle", "angle degrees|radians|orbits|arcdegrees|frequency", "The unit of angles written without a suffix. Default degrees."),
    d(Directive, "normal", "normal X Y Z", "The untransformed normal VERTEX emits. Default 0 0 1."),
    d(Directive, "background", "background R G B [A]", "The viewer's background colour."),
    d(Directive, "flat", "flat", "Context Free's flat art: black shapes on white, painted in derivation order (z first), unlit."),
    d(Directive, "color", "color a b c d", "Renames the colour adjustments (default `R G B A`)."),
    d(Directive, "weight", "weight a b c d", "Renames the weight adjustments (default `u v w q`)."),
    d(Directive, "fps", "fps N", "Frames per second of transform rules. Default 30."),
    d(Directive, "duration", "duration SECONDS", "Length of the animation. Default 10."),
    d(Directive, "camerafov", "camerafov DEGREES", "Vertical field of view of the viewer's camera. Default 40."),
    d(Directive, "cameranearplane", "cameranearplane X", "Near clipping plane. Default 0.1."),
    d(Directive, "camerafarplane", "camerafarplane X", "Far clipping plane. Default 1000."),
    d(Directive, "uniform", "uniform NAME x [y [z [w]]]  |  uniform NAME RULE PROP", "A shader uniform: a constant vec4, or a property (pos, dir, conj, color, weight, normal) of a transform rule's current frame."),
    d(Directive, "function", "function NAME { EXPR }", "A named function of x, y, z (and depth, scale), for isosurfaces and selectors."),
    d(Directive, "isosurface", "isosurface NAME { xyz MIN MAX RES ; function { EXPR } }", "Declares the drawable NAME: the surface f(x, y, z) = 0 by marching cubes, inside where f < 0."),
    d(Directive, "program", "program { vertexshader VS fragmentshader FS target screen render }", "The shader program. Without one the viewer uses the std Phong program."),
    // Extension sections (reference §18, SPEC §11).
    d(Directive, "guide", "guide [NAME] { KEY VALUE… ; … }", "A guiding curve for guided search (SOSMC): a cubic Bézier path that the bones made by the skeleton rules are steered along, with its own scales and segment length. Keys: see docs/guided.md."),
    d(Directive, "search", "search [NAME] { KEY VALUE… ; … }", "Guided-search settings (SOSMC): which rules are skeleton rules (their calls form bones and may not draw), the wrap-up productions that replace leftover skeleton calls, and the search's parameters; the curves are `guide` sections. Keys: see docs/guided.md."),
    d(Directive, "creature", "creature [NAME] { KEY VALUE… ; KEY VALUE… { … } }", "A creature grammar: parts (their geometry from MDG rules or imported meshes) with slots, meta-parts and allelic families, structure rules with priority, condition and a probability that may depend on the generation `g`, selection rules and geometry rules. Keys: see docs/creatures.md."),
    d(Directive, "grid", "grid [NAME] { KEY VALUE… ; KEY VALUE… { … } }", "A grid shape grammar (SIGI): voxel shapes, adjacency rules sᵢ → sᵢ sⱼ with a relative placement (matched under quarter turns about the vertical axis), a start shape and generation options. Keys: see docs/grid.md."),
    // Adjustments (reference §5).
    d(Adjustment, "x", "x X [Y [Z]]", "Translate by (X, Y, Z); missing components are 0."),
    d(Adjustment, "y", "y Y", "Translate along y."),
    d(Adjustment, "z", "z Z", "Translate along z."),
    d(Adjustment, "r", "r X [Y [Z]]", "Rotate about x by X, then about y by Y, then about z by Z."),
    d(Adjustment, "rotate", "rotate X [Y [Z]]", "Rotate about x by X, then about y by Y, then about z by Z (same as `r`)."),
    d(Adjustment, "rx", "rx A", "Rotate about the x axis by A."),
    d(Adjustment, "ry", "ry A", "Rotate about the y axis by A."),
    d(Adjustment, "rz", "rz A", "Rotate about the z axis by A."),
    d(Adjustment, "pitch", "pitch A", "Rotate about the x axis by A (same as `rx`)."),
    d(Adjustment, "yaw", "yaw A", "Rotate about the y axis by A (same as `ry`)."),
    d(Adjustment, "roll", "roll A", "Rotate about the z axis by A (same as `rz`)."),
    d(Adjustment, "up", "up [A]", "Rotate about x by +90° (or +A)."),
    d(Adjustment, "down", "down [A]", "Rotate about x by −90° (or −A)."),
    d(Adjustment, "right", "right [A]", "Rotate about y by +90° (or +A)."),
    d(Adjustment, "left", "left [A]", "Rotate about y by −90° (or −A)."),
    d(Adjustment, "rollright", "rollright [A]", "Rotate about z by +90° (or +A)."),
    d(Adjustment, "rollleft", "rollleft [A]", "Rotate about z by −90° (or −A)."),
    d(Adjustment, "s", "s S | s X Y [Z]", "Scale: `s S` multiplies lengths by S; `s X Y Z` scales the frame's own axes by X, Y and Z (Z defaults to 1)."),
    d(Adjustment, "skew", "skew X Y", "Skew by the angles X and Y (Context Free's `skew`): x += tan X · y, y += tan Y · x, z unchanged; a general linear map, carried like a non-uniform scale."),
    d(Adjustment, "f", "f X Y Z", "Reflect across the plane through the origin with normal (X, Y, Z)."),
    d(Adjustment, "fx", "fx", "Reflect across the yz-plane: (x, y, z) → (−x, y, z)."),
    d(Adjustment, "fy", "fy", "Reflect across the xz-plane: (x, y, z) → (x, −y, z)."),
    d(Adjustment, "fz", "fz", "Reflect across the xy-plane: (x, y, z) → (x, y, −z)."),
    d(Adjustment, "fps", "fps N", "Add N to the frames per second of the called rule's transform rules."),
    d(Adjustment, "seed", "seed N", "On a rule call: the call's whole sub-derivation draws from the random stream of (run seed, N); two calls with the same N grow the same sub-tree, and the caller's stream goes on as if the call drew nothing."),
    d(Adjustment, "R", "R N", "Add N to the red colour component (colours start at white, 1 1 1 1)."),
    d(Adjustment, "G", "G N", "Add N to the green colour component."),
    d(Adjustment, "B", "B N", "Add N to the blue colour component."),
    d(Adjustment, "A", "A N", "Add N to the alpha component."),
    d(Adjustment, "hue", "hue H", "Add H degrees to the colour's hue (Context Free's `hue`)."),
    d(Adjustment, "sat", "sat S", "Move the saturation the fraction S (−1..1) of the way to 1 (S > 0) or to 0 (S < 0)."),
    d(Adjustment, "saturation", "saturation S", "Same as `sat`."),
    d(Adjustment, "b", "b S", "Move the brightness the fraction S (−1..1) of the way to 1 (S > 0) or to 0 (S < 0); `B` is blue."),
    d(Adjustment, "brightness", "brightness S", "Same as `b`."),
    d(Adjustment, "u", "u N", "Add N to the first weight component (passed to shaders; starts at 0)."),
    d(Adjustment, "v", "v N", "Add N to the second weight component."),
    d(Adjustment, "w", "w N", "Add N to the third weight component."),
    d(Adjustment, "q", "q N", "Add N to the fourth weight component."),
    // Drawables (reference §9).
    d(Drawable, "VERTEX", "VERTEX {ADJ}", "Emit a vertex at the frame's origin; every three vertices make a triangle (counter-clockwise faces the viewer)."),
    d(Drawable, "FACENORMALS", "FACENORMALS {}", "Replace the normals of the last three vertices by their triangle's normal (flat shading)."),
    d(Drawable, "MOVETO", "[ns.]MOVETO [PROFILE] {ADJ}", "Move the pen to this frame without drawing."),
    d(Drawable, "LINETO", "[ns.]LINETO [PROFILE] {ADJ}", "Draw a segment from the pen to this frame, sweeping the profile rule (or the `linerule`)."),
    d(Drawable, "BLENDTO", "[ns.]BLENDTO [PROFILE] {ADJ}", "Like LINETO along a smooth spline between the two frames."),
    d(Drawable, "SLINETO", "SLINETO [PROFILE] {ADJ}", "Like LINETO with the profile square to the segment at both ends."),
    d(Drawable, "ALINETO", "ALINETO [PROFILE] {ADJ}", "Like LINETO with one averaged profile orientation for both ends."),
    d(Drawable, "NEWLINE", "NEWLINE {}", "Lift the pen: the next MOVETO/LINETO starts a new line."),
    d(Drawable, "RESET", "[ns.]RESET {}", "Set the continuation state to the pen's frame."),
    d(Drawable, "DEBUG", "[ns.]DEBUG {ADJ}", "Print the current frame, colour, weight and depth to stderr."),
    d(Drawable, "FRAME", "FRAME {ADJ}", "Emit an animation frame (in transform rules)."),
    d(Drawable, "ARCTO", "ARCTO(x, y, r | x, y, rx, ry, angle) [large_cw] {ADJ}", "Flat path: an arc to (x, y), counter-clockwise unless `cw`, the shorter unless `large`. A rule with it is a path (reference §9, Flat paths)."),
    d(Drawable, "CURVETO", "CURVETO(x, y, x1, y1[, x2, y2]) [smooth] {ADJ}", "Flat path: a quadratic or cubic Bézier curve to (x, y); `smooth` mirrors the last control point."),
    d(Drawable, "MOVEREL", "MOVEREL(dx, dy) {ADJ}", "Flat path: start a subpath at the current point plus (dx, dy), in the drawable's frame."),
    d(Drawable, "LINEREL", "LINEREL(dx, dy) {ADJ}", "Flat path: a straight segment to the current point plus (dx, dy)."),
    d(Drawable, "ARCREL", "ARCREL(dx, dy, r | dx, dy, rx, ry, angle) [large_cw] {ADJ}", "Flat path: ARCTO to the current point plus (dx, dy)."),
    d(Drawable, "CURVEREL", "CURVEREL(dx, dy, dx1, dy1[, dx2, dy2]) [smooth] {ADJ}", "Flat path: CURVETO with the end and control points from the current point."),
    d(Drawable, "CLOSEPOLY", "CLOSEPOLY [align] {}", "Flat path: close the subpath (`align` moves its last point onto its first)."),
    d(Drawable, "FILL", "FILL [evenodd] {ADJ}", "Flat path: fill it (non-zero winding, or even-odd) as triangles under the adjusted frame."),
    d(Drawable, "STROKE", "STROKE[(width)] [JOIN_CAP] {ADJ}", "Flat path: draw its outline, 0.1 wide by default; miterjoin/roundjoin/beveljoin, buttcap/roundcap/squarecap, iso (a round pen under a stretched frame)."),
    // Selector modes (reference §6).
    d(SelectorMode, "random", "selector R random", "Choose a definition with probability proportional to its weight (the default)."),
    d(SelectorMode, "frequency", "selector R frequency", "Same as `random`."),
    d(SelectorMode, "depth", "selector R depth", "The weight is a depth threshold: the definition with the smallest weight ≥ the current depth, else the largest."),
    d(SelectorMode, "scale", "selector R scale", "The weight is a scale threshold: the definition with the largest weight ≤ the linear scale, else the smallest."),
    d(SelectorMode, "sequential", "selector R sequential", "Use the definitions in order, each `weight` times, then wrap around."),
    d(SelectorMode, "pattern", "selector R pattern", "Use the definitions in order, one each, then again from the first."),
    d(SelectorMode, "function", "selector R function F  |  selector R function { EXPR }", "The value of the function (of x, y, z, depth, scale) selects like depth: smallest weight ≥ value, else the largest."),
    // Angle modes (reference §3).
    d(AngleMode, "degrees", "angle degrees", "Angles without a suffix are degrees (the default)."),
    d(AngleMode, "radians", "angle radians", "Angles without a suffix are radians."),
    d(AngleMode, "orbits", "angle orbits", "Angles without a suffix are full turns: 1 = 360°."),
    d(AngleMode, "arcdegrees", "angle arcdegrees", "Same as `degrees`."),
    d(AngleMode, "frequency", "angle frequency", "Same as `orbits`: 1 = a full turn."),
    // Preprocessor (reference §12).
    d(Preprocessor, "@import", "@import NAME|PATH…", "Include std library files (`@import polyhedra` reads std/polyhedra.mdg) or files relative to this one (`@import lib/x.mdg`)."),
    d(Preprocessor, "@define", "@define NAME [NUMBER]", "Set a flag for `@ifdef`, optionally a constant usable in expressions."),
    d(Preprocessor, "@ifdef", "@ifdef NAME … [@else …] @endif", "Keep the items up to `@else`/`@endif` only if NAME is defined."),
    d(Preprocessor, "@else", "@else", "Starts the items kept when the `@ifdef` name is not defined."),
    d(Preprocessor, "@endif", "@endif", "Ends an `@ifdef`."),
    d(Preprocessor, "@macro", "@macro NAME(a, b) … @endmacro", "Defines a macro: a token body in which each parameter word is replaced by its argument."),
    d(Preprocessor, "@endmacro", "@endmacro", "Ends a macro definition."),
    d(Preprocessor, "@expand", "@expand NAME(arg, …)", "Pastes a macro's body with its parameters replaced; must produce whole items."),
    d(Preprocessor, "@presets", "@presets p1 p2 …", "Declares preset names; `--preset p1` defines `p1`."),
    d(Preprocessor, "@param", "@param int|float NAME DEFAULT [MIN MAX]  |  @param bool NAME true|false", "A parameter overridable with `--param NAME=V` and shown in the viewer."),
    d(Preprocessor, "@vertexshader", "@vertexshader NAME … @endshader", "GLSL vertex shader source kept under NAME for `program`."),
    d(Preprocessor, "@fragmentshader", "@fragmentshader NAME … @endshader", "GLSL fragment shader source kept under NAME for `program`."),
    d(Preprocessor, "@endshader", "@endshader", "Ends a shader block."),
    // Isosurface entries (reference §9).
    d(IsoEntry, "xyz", "xyz MIN MAX RES", "The grid range and resolution (cells) for all three axes."),
    // Program commands (reference §13).
    d(ProgramCommand, "vertexshader", "vertexshader NAME", "Use the `@vertexshader NAME` block."),
    d(ProgramCommand, "fragmentshader", "fragmentshader NAME", "Use the `@fragmentshader NAME` block."),
    d(ProgramCommand, "target", "target screen", "Render to the screen (the only target)."),
    d(ProgramCommand, "render", "render", "Draw the model."),
    // Expression functions (reference §14).
    d(Function, "sin", "sin(a)", "Sine (radians)."),
    d(Function, "cos", "cos(a)", "Cosine (radians)."),
    d(Function, "tan", "tan(a)", "Tangent (radians)."),
    d(Function, "asin", "asin(v)", "Arc sine, in radians."),
    d(Function, "acos", "acos(v)", "Arc cosine, in radians."),
    d(Function, "atan", "atan(v)", "Arc tangent, in radians."),
    d(Function, "atan2", "atan2(y, x)", "Angle of the point (x, y), in radians."),
    d(Function, "sqrt", "sqrt(v)", "Square root."),
    d(Function, "abs", "abs(v)", "Absolute value."),
    d(Function, "min", "min(a, b)", "The smaller of a and b."),
    d(Function, "max", "max(a, b)", "The larger of a and b."),
    d(Function, "pow", "pow(a, b)", "a to the power b."),
    d(Function, "exp", "exp(v)", "e to the power v."),
    d(Function, "log", "log(v)", "Natural logarithm."),
    d(Function, "floor", "floor(v)", "Largest integer ≤ v."),
    d(Function, "ceil", "ceil(v)", "Smallest integer ≥ v."),
    d(Function, "fract", "fract(v)", "Fractional part of v."),
    d(Function, "radians", "radians(deg)", "Degrees to radians: `sin(radians(90))` is 1. Adjustments read degrees; math functions read radians."),
    d(Function, "degrees", "degrees(rad)", "Radians to degrees: `rz (degrees(atan2(y, x)))`."),
    d(Function, "mod", "mod(a, b)", "a modulo b (never negative for positive b)."),
    d(Function, "clamp", "clamp(v, lo, hi)", "v limited to [lo, hi]."),
    d(Function, "mix", "mix(a, b, t)", "Linear interpolation a + (b − a)·t."),
    d(Function, "step", "step(edge, v)", "0 if v < edge, else 1."),
    d(Function, "smoothstep", "smoothstep(e0, e1, v)", "Smooth Hermite step from 0 at e0 to 1 at e1."),
    d(Function, "rand", "rand(a, b)", "A uniform random draw from [a, b); adjustment arguments only, fresh for every evaluation."),
    d(Function, "randn", "randn(mean, sd)", "A normally distributed random draw; adjustment arguments only."),
    d(Function, "if", "if(condition, then, else)", "`then` when the condition is not 0 (nor NaN), else `else`. Only the chosen branch is evaluated, so a `rand` in the other draws nothing."),
    d(Function, "select", "select(i, a, b, …)", "The choice numbered `i` from 0 (`i` is floored and clamped to the choices; NaN takes the last). Only the chosen one is evaluated."),
    d(Function, "let", "let(NAME = VALUE; … ; EXPRESSION)", "Binds each NAME to its VALUE, evaluated once and in order (each sees the earlier ones), then gives EXPRESSION."),
    // Expression variables (reference §14).
    d(Variable, "depth", "depth", "The recursion depth (selector functions)."),
    d(Variable, "scale", "scale", "The current linear scale (selector functions)."),
    d(Variable, "g", "g", "The generation, in creature-grammar conditions."),
];

/// The entry for `name` of `kind`. The isosurface axes `x`, `y`, `z` and the
/// position variables share their adjustments' names, so they are looked up here.
pub fn lookup(kind: DocKind, name: &str) -> Option<&'static Doc> {
    const AXIS_DOCS: &[Doc] = &[
        d(IsoEntry, "x", "x MIN MAX RES", "The grid range and resolution (cells) along x."),
        d(IsoEntry, "y", "y MIN MAX RES", "The grid range and resolution (cells) along y."),
        d(IsoEntry, "z", "z MIN MAX RES", "The grid range and resolution (cells) along z."),
        d(
            IsoEntry,
            "function",
            "function NAME  |  function { EXPR }",
            "The isosurface's function: f(x, y, z) = 0 is the surface, inside where f < 0.",
        ),
        d(Variable, "x", "x", "The x coordinate of the current position."),
        d(Variable, "y", "y", "The y coordinate of the current position."),
        d(Variable, "z", "z", "The z coordinate of the current position."),
    ];
    DOCS.iter().chain(AXIS_DOCS).find(|e| e.kind == kind && e.name == name)
}

/// All entries of one kind.
pub fn of_kind(kind: DocKind) -> impl Iterator<Item = &'static Doc> {
    DOCS.iter().filter(move |e| e.kind == kind)
}

impl Doc {
    /// The entry as Markdown: the signature in a code block, then the text.
    pub fn markdown(&self) -> String {
        format!("```mdg\n{}\n```\n{}", self.signature, self.text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{directive_names, Components, ANGLE_MODES, DRAWABLES, FUNCTIONS, SELECTOR_MODES};

    #[test]
    fn every_builtin_word_has_a_doc() {
        let mut missing = Vec::new();
        let mut want = |kind: DocKind, names: Vec<&str>| {
            for n in names {
                if lookup(kind, n).is_none() {
                    missing.push(format!("{kind:?} {n}"));
                }
            }
        };
        want(Directive, directive_names());
        want(Adjustment, Components::default().all_names());
        want(Drawable, DRAWABLES.to_vec());
        want(SelectorMode, SELECTOR_MODES.to_vec());
        want(AngleMode, ANGLE_MODES.to_vec());
        want(Function, FUNCTIONS.iter().map(|f| f.0).collect());
        want(Function, crate::ast::SPECIAL_FORMS.iter().map(|f| f.0).chain(["let"]).collect());
        want(Variable, crate::check::FUNCTION_VARS.to_vec());
        want(Preprocessor, crate::lexer::PREPROCESSOR_DIRECTIVES.to_vec());
        want(IsoEntry, vec!["x", "y", "z", "xyz", "function"]);
        want(ProgramCommand, vec!["vertexshader", "fragmentshader", "target", "render"]);
        assert!(missing.is_empty(), "no doc for: {missing:?}");
    }

    #[test]
    fn names_are_unique_per_kind() {
        for (i, a) in DOCS.iter().enumerate() {
            assert!(!DOCS[i + 1..].iter().any(|b| a.kind == b.kind && a.name == b.name), "duplicate doc {a:?}");
        }
    }
}
