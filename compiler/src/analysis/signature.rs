//! Signature help: inside the argument list of a rule call (`tree(3, |`), the rule's
//! parameters with the one being typed highlighted; inside a math function's
//! (`atan2(y, |`), its arguments.
//!
//! Read from the main file's tokens, not the tree, so it works while the call is
//! still incomplete (the usual state when help is asked for).

use super::Document;
use crate::lexer::Tok;

/// What to show: the signature as text, each parameter's byte range in it, and the
/// parameter the cursor is in.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SignatureHelp {
    pub label: String,
    pub params: Vec<(u32, u32)>,
    pub active: usize,
    /// Markdown: where the rule is defined, or what the function does.
    pub doc: String,
}

/// The argument names of math functions without documented names.
fn function_params(name: &str, arity: usize) -> Vec<String> {
    let named: &[&str] = match name {
        "atan2" => &["y", "x"],
        "min" | "max" => &["a", "b"],
        "pow" => &["base", "exponent"],
        "mod" => &["a", "m"],
        "clamp" => &["x", "lo", "hi"],
        "mix" => &["a", "b", "t"],
        "step" => &["edge", "x"],
        "smoothstep" => &["edge0", "edge1", "x"],
        "rand" => &["lo", "hi"],
        "randn" => &["mean", "sd"],
        _ => &["x"],
    };
    named.iter().take(arity).map(|s| s.to_string()).collect()
}

impl Document {
    /// Signature help at byte `offset` of the main file.
    pub fn signature_help(&self, offset: u32) -> Option<SignatureHelp> {
        let toks = &self.index().tokens;
        let before: Vec<_> = toks.iter().filter(|t| t.span.end <= offset).collect();
        let mut depth = 0usize;
        // Inside `v[…]` (an index) read backwards: `]` seen, its `[` not yet.
        let mut index = 0usize;
        let mut commas = 0usize;
        let mut name = None;
        for (i, t) in before.iter().enumerate().rev() {
            match t.kind {
                Tok::RBracket if depth == 0 && matches!(opener_of(&before, i), Some(Tok::IndexOpen)) => index += 1,
                Tok::IndexOpen if index > 0 => index -= 1,
                _ if index > 0 => {}
                Tok::RParen => depth += 1,
                Tok::LParen | Tok::CallOpen if depth > 0 => depth -= 1,
                Tok::Comma if depth == 0 => commas += 1,
                Tok::CallOpen => {
                    // `rule tree(` declares; it is not a call.
                    if i > 0 && before[i - 1].kind == Tok::KwRule {
                        return None;
                    }
                    let text = self.span_text(t.span);
                    name = Some(text[..text.len() - 1].to_string());
                    break;
                }
                Tok::LParen => {
                    // `ns.tree (` or `tree (`: the word before the parenthesis.
                    let prev = i.checked_sub(1).map(|j| before[j])?;
                    if matches!(prev.kind, Tok::CallOpen | Tok::Comma | Tok::LParen) {
                        // Inside a vector or a grouping that is itself an argument:
                        // the help is the call's, for the argument that holds it.
                        commas = 0;
                        continue;
                    }
                    if !matches!(prev.kind, Tok::Ident | Tok::Dotted | Tok::KwIf) {
                        return None;
                    }
                    if i > 1 && before[i - 2].kind == Tok::KwRule {
                        return None;
                    }
                    name = Some(self.span_text(prev.span).to_string());
                    break;
                }
                Tok::LBrace | Tok::RBrace | Tok::LBracket | Tok::RBracket | Tok::Semi if depth == 0 => return None,
                _ => {}
            }
        }
        let name = name?;
        let sym = &self.analysis.checked.symbols;
        let full = sym.resolve(&name, None).or_else(|| {
            // A call inside a namespace names its rules without the prefix.
            sym.signatures.keys().find(|k| k.rsplit_once('.').is_some_and(|(_, n)| n == name)).cloned()
        });
        let (names, doc) = match full.as_ref().and_then(|f| sym.signatures.get(f).map(|s| (f, s))) {
            Some((f, sig)) => {
                let names = crate::types::param_labels(&sig.params);
                let defs = sym.rules.get(f).map(|d| d.len()).unwrap_or(0);
                (names, format!("rule `{f}`, {defs} definition(s); arguments by position, defaults may be left out"))
            }
            None if name == "if" => (
                ["condition", "then", "else"].map(String::from).to_vec(),
                "`if(…)`: only the chosen branch is evaluated".to_string(),
            ),
            None if name == "select" => (
                ["i", "a", "b", "…"].map(String::from).to_vec(),
                "`select(…)`: the choice numbered i from 0, floored and clamped; only it is evaluated".to_string(),
            ),
            None => {
                let (fname, arity) = crate::check::FUNCTIONS.iter().find(|(n, _)| *n == name)?;
                (function_params(fname, *arity), format!("math function `{fname}`"))
            }
        };
        let mut label = format!("{name}(");
        let mut params = Vec::new();
        for (i, n) in names.iter().enumerate() {
            if i > 0 {
                label.push_str(", ");
            }
            let start = label.len() as u32;
            label.push_str(n);
            params.push((start, label.len() as u32));
        }
        label.push(')');
        let active = commas.min(params.len().saturating_sub(1));
        Some(SignatureHelp { label, params, active, doc })
    }
}

/// The kind of the `[` that the `]` at `before[i]` closes.
fn opener_of(before: &[&crate::lexer::Token], i: usize) -> Option<Tok> {
    let mut depth = 0usize;
    for t in before[..i].iter().rev() {
        match t.kind {
            Tok::RBracket => depth += 1,
            Tok::LBracket | Tok::IndexOpen if depth == 0 => return Some(t.kind),
            Tok::LBracket | Tok::IndexOpen => depth -= 1,
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc;

    #[test]
    fn help_inside_a_rule_call_and_a_function_call() {
        let src = "rule A { tree(3, 0.5) {} VERTEX {x (atan2(1, 2))} }\nrule tree(int n, float len = 1) { VERTEX {x len} VERTEX {y n} VERTEX {} }";
        let (d, _) = doc(src);
        let at = |needle: &str| d.text().find(needle).expect("needle in the text") as u32;
        let h = d.signature_help(at("3, 0.5") + 1).expect("in the call");
        assert_eq!(h.label, "tree(int n, float len = 1)");
        assert_eq!(h.active, 0);
        let p = h.params[1];
        assert_eq!(&h.label[p.0 as usize..p.1 as usize], "float len = 1");
        assert_eq!(d.signature_help(at(" 0.5) {}") + 2).expect("second").active, 1);
        let f = d.signature_help(at("1, 2))") + 3).expect("in atan2");
        assert_eq!((f.label.as_str(), f.active), ("atan2(y, x)", 1));
        // The lazy forms: `if`'s third argument, `select`'s choices.
        let (d2, _) = doc("rule A { VERTEX {x if(depth > 1, 2, 3) y select(depth, 1, 2, 3)} }");
        let at2 = |needle: &str| d2.text().find(needle).expect("needle in the text") as u32;
        let h = d2.signature_help(at2("3) y")).expect("in if");
        assert_eq!((h.label.as_str(), h.active), ("if(condition, then, else)", 2));
        let h = d2.signature_help(at2("2, 3)}")).expect("in select");
        assert_eq!((h.label.as_str(), h.active), ("select(i, a, b, …)", 2));
        // Outside any call, and on the definition's own list: none.
        assert_eq!(d.signature_help(at("VERTEX {x len}")), None);
        assert_eq!(d.signature_help(at("int n") + 3), None);
    }

    /// A vector parameter is one parameter (`vector2 at = (0, 1)`), and a vector or
    /// an index among the arguments does not shift the count.
    #[test]
    fn help_with_vector_parameters_and_arguments() {
        let src = "rule A { let v = (1, 2); dot((1, v[1]), v[0], v) {} }\nrule dot(vector2 at, float r, vector2 size = (0, 1)) { CIRCLE [x at s size r] }";
        let (d, _) = doc(src);
        let at = |needle: &str| d.text().find(needle).expect("needle in the text") as u32;
        let h = d.signature_help(at("v[0], v)") + 1).expect("in the call");
        assert_eq!(h.label, "dot(vector2 at, float r, vector2 size = (0, 1))");
        assert_eq!(h.active, 1);
        assert_eq!(d.signature_help(at("v) {}")).expect("third").active, 2);
        assert_eq!(d.signature_help(at("v[1])")).expect("first").active, 0);
    }
}
