//! A generator of random well-formed MDG programs for the VM target: rules with
//! several definitions, selectors, calls with adjustments (random draws and
//! expressions included), iterators (huge counts too), blocks, continuations, pens
//! and sweeps, isosurfaces, functions, namespaces, transform and convolution rules,
//! limits. Most programs compile; the VM must run every one within its limits.

use crate::rng::Rng;
use std::fmt::Write as _;

// (No DEBUG: it prints every call; the text targets cover it.)
const DRAWABLES: &[&str] = &["VERTEX", "VERTEX", "VERTEX", "FACENORMALS", "NEWLINE", "RESET"];
const PENS: &[&str] = &["MOVETO", "LINETO", "BLENDTO", "SLINETO", "ALINETO"];
const SELECTORS: &[&str] = &["random", "frequency", "depth", "scale", "sequential", "pattern"];
const FUNCS1: &[&str] = &["sin", "cos", "sqrt", "abs", "exp", "log", "floor", "fract", "tan", "asin", "acos", "atan"];
const FUNCS2: &[&str] = &["min", "max", "pow", "mod", "atan2", "step"];
const VARS: &[&str] = &["x", "y", "z", "depth", "scale", "g"];

struct Gen<'r> {
    rng: &'r mut Rng,
    rules: Vec<String>,
    transforms: Vec<String>,
    profiles: Vec<String>,
    isos: Vec<String>,
    functions: Vec<String>,
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
    };
    let mut s = String::new();
    let _ = writeln!(s, "startshape R0");
    g.directives(&mut s);
    if g.rng.one_in(3) {
        let _ = writeln!(s, "function F0 {{ {} }}", g.expr(3, true));
        g.functions.push("F0".into());
    }
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
        let sel = g.rng.pick(SELECTORS).copied().unwrap_or("random");
        let _ = writeln!(s, "selector R1 {sel}");
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
            let body = g.body(2, n);
            let _ = writeln!(s, "{header} {{\n{body}}}");
        }
    }
    if g.rng.one_in(5) {
        let _ = writeln!(s, "namespace ns {{ rule R0 {{ {} }} }}", g.body(1, 2).replace('\n', " "));
    }
    s
}

impl Gen<'_> {
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
            0 => crate::mutate::INTERESTING_NUMBERS[self.rng.below(crate::mutate::INTERESTING_NUMBERS.len())]
                .trim_start_matches('-')
                .trim_end_matches(|c: char| c.is_ascii_alphabetic())
                .to_string(),
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
            return if space && self.rng.one_in(2) {
                self.rng.pick(VARS).copied().unwrap_or("x").to_string()
            } else {
                self.number()
            };
        }
        match self.rng.below(6) {
            0 => format!("-{}", self.expr(depth - 1, space)),
            1 => {
                let f = self.rng.pick(FUNCS1).copied().unwrap_or("sin");
                format!("{f}({})", self.expr(depth - 1, space))
            }
            2 => {
                let f = self.rng.pick(FUNCS2).copied().unwrap_or("min");
                format!("{f}({}, {})", self.expr(depth - 1, space), self.expr(depth - 1, space))
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
            10 if !self.isos.is_empty() => format!("ISO {}", self.bracket()),
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
        }
        assert!(ok > 150, "only {ok} of 200 generated programs compile");
    }
}
