//! `mdgc`: check, build, format and disassemble MDG grammars.
fn main() {
    let path = std::env::args().nth(1).unwrap_or_default();
    let text = std::fs::read_to_string(&path).unwrap_or_default();
    let mut s = mdg_compiler::source::Sources::default();
    let f = s.add(&path, &path, text);
    let p = mdg_compiler::parse::parse_file(&s, f);
    print!("{}", mdg_compiler::dump::dump_file(&p.file));
    eprint!("{}", mdg_compiler::diag::render_plain(&p.diagnostics, &s));
}
