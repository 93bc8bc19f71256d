//! The grammar the editor benchmarks type into (the language server's latency and
//! typing benches, the compiler's `phases` example): one definition, so their
//! numbers are about the same program.

/// A program of about `lines` lines: chained rules with iterators, a selector and
/// an isosurface, using std.
pub fn grammar(lines: usize) -> String {
    let n_rules = (lines / 6).max(1);
    let mut s = String::from("startshape r0\nmaxdepth 12\n@import primitives\nselector r1 random\n");
    s.push_str("isosurface BLOB { xyz -1 1 8 ; function { x*x + y*y + z*z - 1 } }\n");
    for i in 0..n_rules {
        let next = (i + 1) % n_rules;
        s.push_str(&format!(
            "rule r{i} {{\n  VERTEX {{x 1}} VERTEX {{y 1}} VERTEX {{z 1 R -0.1}}\n  r{next} {{x 1 rz 10 s 0.9}}\n  30/30 * [ry 360] cube {{s 0.1}}\n}}\n\n"
        ));
    }
    s.push_str("rule r1 0.5 { BLOB {} }\n");
    s
}
