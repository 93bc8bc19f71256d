//! A generator of random well-formed MDG programs for the VM target: rules with
//! several definitions, selectors (function selectors too), calls with adjustments
//! (random draws and expressions included), iterators (huge counts too), blocks,
//! continuations, pens and sweeps, isosurfaces, functions (with parameters too),
//! a rule with a parameter (run-time arguments, weight expressions, `if`, counts
//! from the parameter), namespaces, transform and convolution rules, limits. Most
//! programs compile; the VM must run every one within its limits.
//!
//! Expressions call every function of the VM's table (`mdg_vm::expr::FUNCTIONS`, so
//! a function added there is generated too), and their operands are often values
//! that are not finite numbers ([`NON_FINITE`]: `0/0`, `log(-1)`, `sqrt(-1)`,
//! `1e308*10`…), at compile time and, through the parameter, at run time; each
//! program also has a probe calling one function of the table with such arguments
//! only, in an adjustment, a condition, an iteration count and an isosurface.

use crate::rng::Rng;
use mdg_vm::expr::{Func, FUNCTIONS};
use std::fmt::Write as _;

/// Subexpressions whose value is NaN or infinite (the parameter variants add its
/// value, so they are computed at run time, not folded).
pub const NON_FINITE: &[&str] = &[
    "(0/0)",
    "log(-1)",
    "sqrt(-1)",
    "(1e308*10)",
    "(-1e308*10)",
    "(1/0)",
    "log(0)",
    "asin(2)",
    "acos(-2)",
    "exp(1000)",
    "pow(-8, 1/3)",
    "mod(1, 0)",
];

// (No DEBUG: it prints every call; the text targets cover it.)
const DRAWABLES: &[&str] = &["VERTEX", "VERTEX", "VERTEX", "FACENORMALS", "NEWLINE", "RESET"];
const PENS: &[&str] = &["MOVETO", "LINETO", "BLENDTO", "SLINETO", "ALINETO"];
const SELECTORS: &[&str] = &["random", "frequency", "depth", "scale", "sequential", "pattern"];
const VARS: &[&str] = &["x", "y", "z", "depth", "scale", "g"];

struct Gen<'r> {
    rng: &'r mut Rng,
    rules: Vec<String>,
    transforms: Vec<String>,
    profiles: Vec<String>,
    isos: Vec<String>,
    functions: Vec<String>,
    /// Functions with parameters: name and arity.
    helpers: Vec<(String, usize)>,
    /// Names an expression may read besides numbers and `VARS` (the parameter `t`
    /// inside the rule `PT`).
    locals: Vec<String>,
    /// Whether the rule `PT(float t)` is defined (calls to it are generated then).
    param_rule: bool,
    /// Whether expressions may draw random numbers (not in counts and weights).
    no_random: bool,
}

/// A random program (text). Deterministic in the generator's state.
pub fn program(rng: &mut Rng) -> String {
    let n_rules = 1 + rng.below(5);
    let mut g = Gen {
        rng,
        rules: (0..n_rules).map(|i| format!("R{i}")).collect(),
        transforms: Vec::new(),
        profiles: Vec::new(),
        isos: Vec::new(),
        functions: Vec::new(),
        helpers: Vec::new(),
        locals: Vec::new(),
        param_rule: false,
        no_random: false,
    };
    let mut s = String::new();
    let _ = writeln!(s, "startshape R0");
    g.directives(&mut s);
    if g.rng.one_in(3) {
        let _ = writeln!(s, "function F0 {{ {} }}", g.expr(3, true));
        g.functions.push("F0".into());
    }
    if g.rng.one_in(4) {
        // A helper with parameters, inlined and folded by the compiler.
        let f = g.any_function(false);
        let args: Vec<String> = (0..f.arity()).map(|i| ["a", "b", "c"][i % 3].to_string()).collect();
        let params = ["a", "b", "c"][..f.arity().max(1)].join(", ");
        let _ = writeln!(s, "function H0({params}) {{ {}({}) }}", f.name(), args.join(", "));
        g.helpers.push(("H0".into(), f.arity().max(1)));
    }
    g.param_rule = g.rng.one_in(2);
    if g.param_rule {
        g.param_rule_text(&mut s);
    }
    g.probe(&mut s);
    if g.rng.one_in(3) {
        let res = 1 + g.rng.small(0, 12);
        let body = match g.functions.first() {
            Some(f) if g.rng.one_in(2) => format!("function {f}"),
            _ => format!("function {{ {} }}", g.expr(3, true)),
        };
        let _ = writeln!(s, "isosurface ISO {{ xyz -1 1 {res} ; {body} }}");
        g.isos.push("ISO".into());
    }
    if g.rng.one_in(3) {
        let _ = writeln!(s, "rule X0 {{ {} }}", g.transform_body());
        g.transforms.push("X0".into());
        if g.rng.one_in(2) {
            let _ = writeln!(s, "rule X1 {{ FRAME {{}} X1 {{{}}} }}", g.adjs(2));
            g.transforms.push("X1".into());
        }
        let _ = writeln!(s, "fps {}\nduration {}", 1 + g.rng.below(30), g.rng.below(4));
    }
    if g.rng.one_in(4) {
        let _ = writeln!(s, "rule P0 {{ {} * {{rz {}}} VERTEX {{x 0.1}} }}", 1 + g.rng.below(12), g.rng.below(90));
        g.profiles.push("P0".into());
    }
    if g.rng.one_in(4) && g.rules.len() > 1 {
        if g.rng.one_in(4) {
            let _ = writeln!(s, "selector R1 function {{ {} }}", g.expr(2, true));
        } else {
            let sel = g.rng.pick(SELECTORS).copied().unwrap_or("random");
            let _ = writeln!(s, "selector R1 {sel}");
        }
    }
    if g.rng.one_in(6) {
        let _ = writeln!(s, "linerule R0");
    }
    if g.rng.one_in(6) && !g.transforms.is_empty() {
        let _ = writeln!(s, "camerarule {}", g.transforms[0]);
    }
    let rules = g.rules.clone();
    for (i, name) in rules.iter().enumerate() {
        let defs = if i == 1 { 1 + g.rng.below(3) } else { 1 + usize::from(g.rng.one_in(3)) };
        for _ in 0..defs {
            let mut header = format!("rule {name}");
            if i == 0 && !g.transforms.is_empty() && g.rng.one_in(2) {
                let t = g.transforms[g.rng.below(g.transforms.len())].clone();
                if g.rng.one_in(3) {
                    let _ = write!(header, " * {t}");
                } else {
                    let _ = write!(header, " : {t}");
                }
            }
            if g.rng.one_in(2) {
                let _ = write!(header, " {}", 1 + g.rng.below(9));
            }
            let n = 1 + g.rng.below(5);
            let mut body = g.body(2, n);
            if i == 0 {
                // The probe runs in every program.
                body.insert_str(0, "  Q0 {}\n");
            }
            let _ = writeln!(s, "{header} {{\n{body}}}");
        }
    }
    if g.rng.one_in(5) {
        let _ = writeln!(s, "namespace ns {{ rule R0 {{ {} }} }}", g.body(1, 2).replace('\n', " "));
    }
    s
}

impl Gen<'_> {
    /// A function of the table; a random one (`rand`, `randn`) only if `random`.
    fn any_function(&mut self, random: bool) -> Func {
        loop {
            let f = Func::ALL[self.rng.below(FUNCTIONS.len())];
            if random || !f.is_random() {
                return f;
            }
        }
    }

    /// A subexpression that is not a finite number; with the parameter in scope, often
    /// one computed from it at run time.
    fn non_finite(&mut self) -> String {
        let v = NON_FINITE[self.rng.below(NON_FINITE.len())];
        match self.locals.first() {
            Some(t) if self.rng.one_in(2) => {
                ["log(t - 1)", "sqrt(t - 1)", "(t / t)", "(1e308 * 10 + t)", "(0 * (1e308 * 10) + t)"]
                    [self.rng.below(5)]
                .replace('t', t)
            }
            _ => v.to_string(),
        }
    }

    /// `PT(float t)`: one or two definitions with weight expressions over `t`, adjustments,
    /// a condition and an iteration count computed from it, and a recursive call
    /// whose argument is computed (so NaN can arrive from the caller).
    fn param_rule_text(&mut self, s: &mut String) {
        self.locals = vec!["t".into()];
        for _ in 0..1 + self.rng.below(2) {
            // (`/ 1`: a float, whatever the expression's type.)
            self.no_random = true;
            let weight = if self.rng.one_in(2) { format!(" (({}) / 1)", self.expr(2, false)) } else { String::new() };
            let count = self.expr(2, false);
            self.no_random = false;
            let adj = self.bracket();
            let cond = self.expr(2, false);
            let arg = self.expr(2, false);
            let _ = writeln!(s, "rule PT(float t){weight} {{");
            let _ = writeln!(s, "  VERTEX {{}} VERTEX {{x 1}} VERTEX {adj}");
            let _ =
                writeln!(s, "  if ({cond}) {{ VERTEX {{}} VERTEX {{y 1}} VERTEX {{z 1}} }} else {{ VERTEX {{x 2}} }}");
            let _ = writeln!(s, "  (floor({count} + 0 * t)) * {{x 1}} VERTEX {{}}");
            let _ = writeln!(s, "  PT(({arg}) / 1) {{s 0.5}}\n}}");
        }
        self.locals.clear();
    }

    /// One function of the table called with arguments that are not finite numbers
    /// only: in an adjustment, a condition, an iteration count and (when there is
    /// one) an isosurface function, in a rule the start shape calls.
    fn probe(&mut self, s: &mut String) {
        let f = self.any_function(false);
        let call = |g: &mut Self| {
            let args: Vec<String> = (0..f.arity()).map(|_| g.non_finite()).collect();
            format!("{}({})", f.name(), args.join(", "))
        };
        let (a, c, n) = (call(self), call(self), call(self));
        let _ = writeln!(s, "rule Q0 {{ VERTEX {{}} VERTEX {{x 1}} VERTEX {{y ({a}) x 2}}");
        let _ = writeln!(s, "  if ({c} > 0) {{ VERTEX {{}} }} (floor(max(0, min(2, {n})))) * {{x 1}} VERTEX {{}} }}");
        if self.rng.one_in(2) {
            let iso = call(self);
            let _ = writeln!(s, "isosurface QISO {{ xyz -1 1 4 ; function {{ x*x + y*y + z*z - 0.5 + {iso} }} }}");
            self.isos.push("QISO".into());
        }
    }

    fn directives(&mut self, s: &mut String) {
        if self.rng.one_in(2) {
            let _ = writeln!(s, "maxdepth {}", self.rng.small(1, 200));
        }
        if self.rng.one_in(4) {
            let _ = writeln!(s, "minsize {}", ["0.001", "0.1", "0.5", "1e-9"][self.rng.below(4)]);
        }
        if self.rng.one_in(5) {
            let _ = writeln!(s, "maxiter {}", self.rng.small(1, 100_000));
        }
        if self.rng.one_in(6) {
            let _ = writeln!(s, "stacksize {}", self.rng.small(1, 1000));
        }
        if self.rng.one_in(4) {
            let _ = writeln!(s, "randseed {}", self.rng.bits() % 1000);
        }
        if self.rng.one_in(8) {
            let _ =
                writeln!(s, "angle {}", ["degrees", "radians", "orbits", "arcdegrees", "frequency"][self.rng.below(5)]);
        }
        if self.rng.one_in(8) {
            let _ = writeln!(s, "background 0.1 0.2 0.3 1\nnormal 0 0 1");
        }
    }

    fn number(&mut self) -> String {
        match self.rng.below(10) {
            0 => {
                let n = crate::mutate::INTERESTING_NUMBERS[self.rng.below(crate::mutate::INTERESTING_NUMBERS.len())]
                    .trim_start_matches('-')
                    .trim_end_matches(|c: char| c.is_ascii_alphabetic());
                // A literal beyond f64 (`1e309`) is E0109 and the program would not
                // run; infinities come from `NON_FINITE` instead.
                match n.parse::<f64>() {
                    Ok(v) if !v.is_finite() => "1e308".to_string(),
                    _ => n.to_string(),
                }
            }
            1 => format!("{}", self.rng.below(360)),
            _ => format!("{}.{}", self.rng.below(4), self.rng.below(100)),
        }
    }

    fn arg(&mut self) -> String {
        match self.rng.below(12) {
            0 => format!("-{}", self.number()),
            1 => format!("rand({}, {})", self.number(), self.number()),
            2 => format!("randn({}, {})", self.number(), self.number()),
            3 => format!("({})", self.expr(2, false)),
            _ => self.number(),
        }
    }

    fn adjs(&mut self, max: usize) -> String {
        let n = self.rng.below(max + 1);
        let mut v = Vec::new();
        for _ in 0..n {
            let a = match self.rng.below(14) {
                0 => format!("x {}", self.arg()),
                1 => format!("y {}", self.arg()),
                2 => format!("z {}", self.arg()),
                3 => format!("rx {}", self.arg()),
                4 => format!("ry {}", self.arg()),
                5 => format!("rz {}", self.arg()),
                6 => format!("s {}", self.arg()),
                7 => format!("s {}", self.number()),
                8 => ["fx", "fy", "fz", "up", "left", "rollright"][self.rng.below(6)].to_string(),
                9 => format!("{} {}", ["R", "G", "B", "A"][self.rng.below(4)], self.arg()),
                10 => format!("fps {}", self.arg()),
                11 => format!("x {} {} {}", self.arg(), self.arg(), self.arg()),
                12 => format!("r {}", self.arg()),
                _ => format!("{} {}", ["u", "v", "w", "q"][self.rng.below(4)], self.arg()),
            };
            v.push(a);
        }
        v.join(" ")
    }

    /// An expression; `space` allows x, y, z (function bodies), else only constants
    /// and `depth`-free arithmetic.
    fn expr(&mut self, depth: usize, space: bool) -> String {
        if depth == 0 || self.rng.one_in(3) {
            return match self.rng.below(6) {
                0 => self.non_finite(),
                1 if !self.locals.is_empty() => self.locals[self.rng.below(self.locals.len())].clone(),
                _ if space && self.rng.one_in(2) => self.rng.pick(VARS).copied().unwrap_or("x").to_string(),
                _ => self.number(),
            };
        }
        match self.rng.below(7) {
            0 => format!("-{}", self.expr(depth - 1, space)),
            1 | 2 => {
                // Any function of the table (random draws only in rule bodies), each
                // argument a value that is not a finite number one time in three.
                let f = self.any_function(!space && !self.no_random);
                let args: Vec<String> = (0..f.arity())
                    .map(|_| if self.rng.one_in(3) { self.non_finite() } else { self.expr(depth - 1, space) })
                    .collect();
                format!("{}({})", f.name(), args.join(", "))
            }
            3 if !self.helpers.is_empty() => {
                let (h, n) = self.helpers[self.rng.below(self.helpers.len())].clone();
                let args: Vec<String> = (0..n).map(|_| self.expr(depth - 1, space)).collect();
                format!("{h}({})", args.join(", "))
            }
            3 => format!("({})", self.expr(depth - 1, space)),
            _ => {
                let op = ["+", "-", "*", "/", "^", "<", ">=", "=="][self.rng.below(8)];
                format!("({} {op} {})", self.expr(depth - 1, space), self.expr(depth - 1, space))
            }
        }
    }

    fn transform_body(&mut self) -> String {
        format!("{} * {{{}}} FRAME {{{}}}", 1 + self.rng.small(0, 50), self.adjs(2), self.adjs(1))
    }

    fn body(&mut self, depth: usize, n: usize) -> String {
        let mut s = String::new();
        for _ in 0..n {
            s.push_str("  ");
            s.push_str(&self.item(depth));
            if self.rng.one_in(8) {
                s.push_str(" \\");
            }
            s.push('\n');
        }
        s
    }

    fn bracket(&mut self) -> String {
        let a = self.adjs(3);
        if self.rng.one_in(4) {
            format!("[{a}]")
        } else {
            format!("{{{a}}}")
        }
    }

    fn item(&mut self, depth: usize) -> String {
        match self.rng.below(12) {
            0..=3 => {
                let r = self.rules[self.rng.below(self.rules.len())].clone();
                format!("{r} {}", self.bracket())
            }
            4 | 5 => {
                let d = self.rng.pick(DRAWABLES).copied().unwrap_or("VERTEX");
                format!("{d} {}", self.bracket())
            }
            6 => {
                let p = self.rng.pick(PENS).copied().unwrap_or("LINETO");
                let profile = match self.profiles.first() {
                    Some(pr) if p != "MOVETO" && self.rng.one_in(2) => format!(" {pr}"),
                    Some(pr) if p == "MOVETO" && self.rng.one_in(2) => format!(" {pr}"),
                    _ => String::new(),
                };
                format!("{p}{profile} {}", self.bracket())
            }
            7 | 8 if depth > 0 => {
                let count = match self.rng.below(8) {
                    0 => "1000000000000".to_string(),
                    1 => format!("{}/{}", 1 + self.rng.below(50), 1 + self.rng.below(50)),
                    _ => format!("{}", self.rng.small(0, 40)),
                };
                let adj = self.bracket();
                let inner = self.item(depth - 1);
                format!("{count} * {adj} {inner}")
            }
            9 if depth > 0 => {
                let n = 1 + self.rng.below(3);
                format!("{{ {}}}", self.body(depth - 1, n).replace('\n', " "))
            }
            10 if !self.isos.is_empty() => {
                let iso = self.isos[self.rng.below(self.isos.len())].clone();
                format!("{iso} {}", self.bracket())
            }
            11 if self.param_rule && self.rng.one_in(2) => {
                format!("PT(({}) / 1) {}", self.expr(2, false), self.bracket())
            }
            _ => format!("VERTEX {{}} VERTEX {{x 1}} VERTEX {{y {}}}", self.arg()),
        }
    }
}

const GLSL_OPS: &[&str] = &["+", "-", "*", "/", "<", ">", "==", "&&", "||", "?", ":", ".", "%", "<<", "&"];

/// A random GLSL shader for the `glsl_limits` target: `#define` chains (object- and
/// function-like, doubling, self-referring, `#undef`, `#if`), expressions long,
/// deep and mixed, arrays with literal and constant-expression sizes, loops. Some
/// are valid GLSL; the bounds must hold for all.
pub fn glsl(rng: &mut Rng) -> String {
    let mut s = String::from("#version 450\nlayout(location = 0) out vec4 color;\n");
    let n_macros = rng.below(30);
    for i in 0..n_macros {
        let prev = if i == 0 { "x".to_string() } else { format!("M{}", rng.below(i)) };
        match rng.below(7) {
            0 => {
                let _ = writeln!(s, "#define M{i} {prev}+{prev}");
            }
            1 => {
                let _ = writeln!(s, "#define M{i}(a) (a*{prev}+a)");
            }
            2 => {
                let _ = writeln!(s, "#define M{i} M{i}+1");
            }
            3 => {
                let _ = writeln!(s, "#define M{i}(a, b) a b a");
            }
            4 => {
                let _ = writeln!(s, "#undef M{}", rng.below(i + 1));
            }
            5 => {
                let _ = writeln!(s, "#if {} > 1\n#define M{i} ({prev})\n#else\n#define M{i} 2\n#endif", rng.below(3));
            }
            _ => {
                let _ = writeln!(s, "#define M{i} {prev}*{prev}*{prev}");
            }
        }
    }
    if rng.one_in(3) {
        let n = [1u64, 16, 1000, 65_536, 65_537, 1 << 20, 100_000_000][rng.below(7)];
        let size = if rng.one_in(2) { n.to_string() } else { format!("{} * 2", n / 2) };
        let _ = writeln!(s, "float table[{size}];");
    }
    s.push_str("void main() {\n  float x = gl_FragCoord.x;\n");
    for _ in 0..1 + rng.below(4) {
        let terms = [1usize, 10, 100, 2000, 2049, 10_000][rng.below(6)];
        let mut e = String::from("x");
        for t in 0..terms {
            let op = rng.pick(GLSL_OPS).copied().unwrap_or("+");
            if op == "?" || op == ":" || op == "." {
                e.push_str(" + x");
            } else {
                let _ = write!(e, " {op} ");
                if n_macros > 0 && rng.one_in(8) {
                    let m = rng.below(n_macros);
                    let _ = write!(e, "M{m}");
                    if rng.one_in(2) {
                        let _ = write!(e, "(x)");
                    }
                } else {
                    let _ = write!(e, "{}", t % 7);
                }
            }
        }
        let depth = [0usize, 3, 100, 300][rng.below(4)];
        let _ = writeln!(s, "  x = {}{e}{};", "(".repeat(depth), ")".repeat(depth));
        if rng.one_in(4) {
            let _ = writeln!(s, "  for (int i = 0; i < {}; i++) {{ x += float(i); }}", rng.small(1, 1000));
        }
    }
    s.push_str("  color = vec4(x);\n}\n");
    s
}

/// A random project for the `preprocess` target: the main file and up to 300 more
/// (`//@file NAME` lines), importing one another in chains, cycles, diamonds and
/// fans, across directories, with `..` and std imports, some defining macros the
/// others expand.
pub fn imports(rng: &mut Rng) -> String {
    let n = [2usize, 10, 70, 300][rng.below(4)];
    let name = |i: usize| if i == 0 { "main.mdg".to_string() } else { format!("d{}/f{i}.mdg", i % 4) };
    let mut s = String::new();
    for i in 0..n {
        if i > 0 {
            let _ = writeln!(s, "//@file {}", name(i));
        }
        let dir_up = if i == 0 { "" } else { "../" };
        let imports = match rng.below(5) {
            // A chain.
            0 => vec![i + 1],
            // A fan and a diamond.
            1 => vec![i + 1, i + 2, (i + 3).min(n)],
            // A cycle back.
            2 => vec![rng.below(i + 1), i + 1],
            // Itself.
            3 => vec![i],
            _ => vec![rng.below(n + 2)],
        };
        for j in imports {
            if j < n {
                let _ = writeln!(s, "@import {dir_up}{}", name(j));
            } else if j == n {
                s.push_str("@import prims\n");
            } else {
                let _ = writeln!(s, "@import {dir_up}missing{j}.mdg");
            }
        }
        if rng.one_in(3) {
            let _ = writeln!(s, "@macro F{i}(a)\nrule MF{i} {{ VERTEX {{x a}} }}\n@endmacro");
        }
        if i > 0 && rng.one_in(3) {
            let _ = writeln!(s, "@expand F{}(1)", rng.below(i));
        }
        let _ = writeln!(s, "rule R{i} {{ VERTEX {{}} }}");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn most_generated_programs_compile() {
        let mut rng = Rng::new(7);
        let mut ok = 0;
        for _ in 0..200 {
            let text = program(&mut rng);
            let a = mdg_compiler::driver::analyze_text(
                &mdg_compiler::source::MemLoader::default(),
                std::path::Path::new("/gen/main.mdg"),
                &text,
                &Default::default(),
                mdg_compiler::check::CheckOptions { require_start: true },
            );
            ok += usize::from(!a.has_errors());
            assert!(text.len() <= crate::Target::VmRun.max_len(), "{} bytes:\n{text}", text.len());
        }
        assert!(ok > 150, "only {ok} of 200 generated programs compile");
    }

    /// Every function of the VM's table is called with an argument that is not a
    /// finite number (one of [`NON_FINITE`], or one computed from the parameter), and
    /// with nothing but such arguments in the probe (`clamp(log(-1), 0/0, …)` is what
    /// made `f64::clamp` panic); the parameter rule computes them at run time.
    #[test]
    fn every_function_gets_arguments_that_are_not_finite_numbers() {
        let mut rng = Rng::new(11);
        let programs: Vec<String> = (0..400).map(|_| program(&mut rng)).collect();
        let all = programs.join("\n");
        let leaves: Vec<String> = NON_FINITE
            .iter()
            .map(|s| s.to_string())
            .chain(["log(t - 1)", "sqrt(t - 1)", "(t / t)"].map(String::from))
            .collect();
        for (name, arity) in FUNCTIONS {
            let with_one = leaves.iter().any(|l| all.contains(&format!("{name}({l}")));
            assert!(with_one, "`{name}` never gets a first argument that is not a finite number");
            if !Func::from_name(name).is_some_and(Func::is_random) {
                let probed = programs.iter().any(|p| {
                    p.lines().find(|l| l.starts_with("rule Q0 ")).is_some_and(|l| {
                        l.split("VERTEX {y (").nth(1).is_some_and(|call| {
                            call.starts_with(&format!("{name}("))
                                && leaves.iter().filter(|leaf| call.contains(leaf.as_str())).count() >= (*arity).min(2)
                        })
                    })
                });
                assert!(probed, "`{name}` is never probed with non-finite arguments only");
            }
        }
        assert!(all.contains("rule PT(float t)") && all.contains("log(t - 1)"), "no run-time NaN");
    }
}
