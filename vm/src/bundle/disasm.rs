//! The disassembler: a bundle as readable text (`mdgc disasm`), snapshot-tested.

use super::*;
use std::fmt::Write;

fn composite(c: &Composite) -> String {
    let f = |v: &[f32]| v.iter().map(|x| format!("{x:.6}")).collect::<Vec<_>>().join(" ");
    let mut s = format!("q=({}) q̂=({}) u=({})", f(&c.q), f(&c.qh), f(&c.u));
    if c.color != [0.0; 4] {
        let _ = write!(s, " color+=({})", f(&c.color));
    }
    if c.weight != [0.0; 4] {
        let _ = write!(s, " weight+=({})", f(&c.weight));
    }
    if c.fps != 0.0 {
        let _ = write!(s, " fps+={}", c.fps);
    }
    s
}

/// Renders the whole bundle.
pub fn disassemble(b: &Bundle) -> String {
    let mut o = String::new();
    let s = &b.settings;
    let _ = writeln!(o, "; MDG bundle, format version {VERSION}");
    let _ = writeln!(o, "startshape {}", b.string(b.rules.get(s.startshape as usize).map(|r| r.name).unwrap_or(0)));
    let _ = writeln!(
        o,
        "settings maxdepth={} minsize={} maxiter={} stacksize={} randseed={} fps={} duration={}",
        s.maxdepth, s.minsize, s.maxiter, s.stacksize, s.randseed, s.fps, s.duration
    );
    let ns: Vec<&str> = s.namespaces.iter().map(|n| b.string(*n)).collect();
    let _ = writeln!(o, "namespaces {:?}", ns);
    let _ = writeln!(o, "\n; transforms");
    for (i, t) in b.transforms.iter().enumerate() {
        match t {
            Transform::Const(c) => {
                let _ = writeln!(o, "X{i:<4} {}", composite(c));
            }
            Transform::Dynamic { adjs, divisor } => {
                let _ = writeln!(o, "X{i:<4} dynamic /{divisor} {:?}", adjs);
            }
        }
    }
    if !b.exprs.is_empty() {
        let _ = writeln!(o, "\n; expressions");
        for (i, e) in b.exprs.iter().enumerate() {
            let _ = writeln!(o, "E{i:<4} {:?}", e);
        }
    }
    let _ = writeln!(o, "\n; rules");
    for (i, r) in b.rules.iter().enumerate() {
        let defs: Vec<String> = r.defs.iter().map(|d| format!("@{} w={}", d.start, d.weight)).collect();
        let _ = writeln!(o, "R{i:<4} {} {:?} [{}]", b.string(r.name), r.selector, defs.join(", "));
    }
    let _ = writeln!(o, "\n; code");
    let mut last_src = None;
    for (pc, op) in b.code.iter().enumerate() {
        let src = b.source_of(pc as u32);
        if src != last_src {
            if let Some((f, l)) = src {
                let _ = writeln!(o, "        ; {f}:{l}");
            }
            last_src = src;
        }
        let operands: Vec<String> = op
            .operands()
            .into_iter()
            .map(|(n, v)| match (op, n) {
                (Op::Call { .. }, "rule") => b.string(b.rules.get(v as usize).map(|r| r.name).unwrap_or(0)).to_string(),
                (Op::Draw { .. }, "kind") => ops::DRAWABLE_KINDS.get(v as usize).unwrap_or(&"?").to_string(),
                (_, "xf" | "step") => format!("X{v}"),
                (_, "profile") if v == NONE as u64 => "-".to_string(),
                _ => format!("{n}={v}"),
            })
            .collect();
        let _ = writeln!(o, "{pc:>6}  {:<8} {}", op.mnemonic(), operands.join(" "));
    }
    for (i, iso) in b.isosurfaces.iter().enumerate() {
        let _ = writeln!(
            o,
            "\nI{i} isosurface {} min={:?} max={:?} res={:?} f=E{}",
            b.string(iso.name),
            iso.min,
            iso.max,
            iso.res,
            iso.function
        );
    }
    for (i, sh) in b.shaders.iter().enumerate() {
        let stage = if sh.vertex { "vertex" } else { "fragment" };
        let _ = writeln!(o, "\nS{i} {stage} shader {} ({} SPIR-V words)", b.string(sh.name), sh.spirv.len());
    }
    if let Some(p) = &b.program {
        let name = |i: u32| if i == NONE { "-".to_string() } else { format!("S{i}") };
        let _ = writeln!(o, "\nprogram vertex={} fragment={}", name(p.vertex), name(p.fragment));
    }
    for u in &b.uniforms {
        match u.source {
            UniformSource::Const(v) => {
                let _ = writeln!(o, "uniform {} {:?}", b.string(u.name), v);
            }
            UniformSource::Frame { rule, prop } => {
                let rule = b.string(b.rules.get(rule as usize).map(|r| r.name).unwrap_or(0));
                let prop = UNIFORM_PROPS.get(prop as usize).unwrap_or(&"?");
                let _ = writeln!(o, "uniform {} {rule} {prop}", b.string(u.name));
            }
        }
    }
    o
}
