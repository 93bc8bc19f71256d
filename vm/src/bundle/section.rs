//! Extension sections: the tables of the SPEC §11 extensions (guided search,
//! creatures, grid grammars) as the bundle carries them — opaque to the VM, typed by
//! their [`SectionKind`], decoded and verified by the crate that owns each table
//! through [`Section`].
//!
//! The VM neither knows the tables' types nor depends on their crates: a section is
//! its kind and its encoded text (JSON, the tables are small and nested and serde
//! gives them a checked, deterministic encoding). On the wire the sections are one
//! JSON object keyed by kind, in kind order (the layout of format version 8), so a
//! bundle's bytes do not depend on which crates read it.

use super::Bundle;

/// Which extension a section holds. The order is the sections' order on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SectionKind {
    /// `search`/`guide` sections: the guided search's table (`mdg_guided`).
    Guided,
    /// `creature` sections: the creature grammar's table (`mdg_creature`).
    Creatures,
    /// `grid` sections: the grid grammar (`mdg_grid`).
    Grid,
}

impl SectionKind {
    /// Every kind, in wire order.
    pub const ALL: [SectionKind; 3] = [SectionKind::Guided, SectionKind::Creatures, SectionKind::Grid];

    /// The section's key on the wire.
    pub fn key(self) -> &'static str {
        match self {
            SectionKind::Guided => "guided",
            SectionKind::Creatures => "creatures",
            SectionKind::Grid => "grid",
        }
    }

    /// What the section is, for messages.
    pub fn what(self) -> &'static str {
        match self {
            SectionKind::Guided => "guided search",
            SectionKind::Creatures => "creatures",
            SectionKind::Grid => "grid grammar",
        }
    }

    fn from_key(key: &str) -> Option<SectionKind> {
        SectionKind::ALL.into_iter().find(|k| k.key() == key)
    }
}

/// The extension sections of a bundle: at most one of each kind, each its encoded
/// table.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Extensions {
    sections: std::collections::BTreeMap<SectionKind, String>,
}

impl Extensions {
    pub fn is_empty(&self) -> bool {
        self.sections.is_empty()
    }

    /// Whether the bundle has a section of `kind` (without decoding it).
    pub fn has(&self, kind: SectionKind) -> bool {
        self.sections.contains_key(&kind)
    }

    /// The encoded text of the section of `kind`.
    pub fn get(&self, kind: SectionKind) -> Option<&str> {
        self.sections.get(&kind).map(String::as_str)
    }

    /// Sets the section of `kind` to `text` (an encoded table).
    pub fn set(&mut self, kind: SectionKind, text: String) {
        self.sections.insert(kind, text);
    }

    /// Removes the section of `kind`.
    pub fn remove(&mut self, kind: SectionKind) {
        self.sections.remove(&kind);
    }

    /// The sections as stored in the bundle: empty when there are none, else one JSON
    /// object keyed by kind, in kind order.
    pub(super) fn encode(&self) -> String {
        if self.sections.is_empty() {
            return String::new();
        }
        let mut out = String::from("{");
        for (i, (kind, text)) in self.sections.iter().enumerate() {
            if i > 0 {
                out.push(',');
            }
            out.push('"');
            out.push_str(kind.key());
            out.push_str("\":");
            out.push_str(text);
        }
        out.push('}');
        out
    }

    /// The sections stored as `text` (see [`Extensions::encode`]): checks that it is
    /// JSON, an object, with known kinds each at most once; the tables themselves are
    /// decoded by their crates.
    pub(super) fn decode(text: &str) -> Result<Extensions, String> {
        let mut ext = Extensions::default();
        if text.is_empty() {
            return Ok(ext);
        }
        serde_json::from_str::<serde::de::IgnoredAny>(text).map_err(|e| format!("malformed extension tables ({e})"))?;
        for (key, value) in split_object(text).ok_or("the extension tables are not a JSON object")? {
            let kind = SectionKind::from_key(&key).ok_or_else(|| format!("unknown extension section `{key}`"))?;
            if ext.sections.insert(kind, value.to_string()).is_some() {
                return Err(format!("the extension section `{key}` appears twice"));
            }
        }
        Ok(ext)
    }
}

/// The members of the JSON object `text` (already checked to be valid JSON) as
/// (key, the member's value as written); `None` when `text` is not an object.
fn split_object(text: &str) -> Option<Vec<(String, &str)>> {
    let bytes = text.as_bytes();
    let skip_ws = |mut i: usize| {
        while bytes.get(i).is_some_and(|b| b.is_ascii_whitespace()) {
            i += 1;
        }
        i
    };
    // The end (one past the closing quote) of the string starting at `i`.
    let string_end = |mut i: usize| {
        i += 1;
        while let Some(&b) = bytes.get(i) {
            match b {
                b'\\' => i += 2,
                b'"' => return i + 1,
                _ => i += 1,
            }
        }
        i
    };
    let mut i = skip_ws(0);
    if bytes.get(i) != Some(&b'{') {
        return None;
    }
    let mut out = Vec::new();
    i = skip_ws(i + 1);
    if bytes.get(i) == Some(&b'}') {
        return Some(out);
    }
    loop {
        let key_end = string_end(i);
        let key: String = serde_json::from_str(text.get(i..key_end)?).ok()?;
        i = skip_ws(key_end);
        i = skip_ws(i + 1); // (the `:`)
        let start = i;
        let mut depth = 0usize;
        while let Some(&b) = bytes.get(i) {
            match b {
                b'"' => {
                    i = string_end(i);
                    continue;
                }
                b'{' | b'[' => depth += 1,
                b'}' | b']' if depth > 0 => depth -= 1,
                b',' | b'}' if depth == 0 => break,
                _ => {}
            }
            i += 1;
        }
        out.push((key, text.get(start..i)?.trim_end()));
        match bytes.get(i) {
            Some(b',') => i = skip_ws(i + 1),
            _ => return Some(out),
        }
    }
}

/// Why an extension section could not be read: its table does not decode, or does
/// not verify against the bundle.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SectionError {
    pub kind: SectionKind,
    pub message: String,
}

impl std::fmt::Display for SectionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "invalid bundle: {}: {}", self.kind.what(), self.message)
    }
}

impl std::error::Error for SectionError {}

/// A table that a crate on top of the VM keeps in a bundle section: the crate says
/// its kind and how a decoded table is checked against the bundle, and reads it only
/// through [`Section::from_bundle`], which decodes and verifies.
pub trait Section: Sized + serde::Serialize + serde::de::DeserializeOwned {
    /// The section the table lives in.
    const KIND: SectionKind;

    /// Checks every index and number of the decoded table against `bundle`.
    fn check(&self, bundle: &Bundle) -> Result<(), String>;

    /// The table of `bundle`, decoded and verified; `None` when the bundle has no such
    /// section.
    fn from_bundle(bundle: &Bundle) -> Result<Option<Self>, SectionError> {
        let Some(text) = bundle.extensions.get(Self::KIND) else { return Ok(None) };
        let err = |message: String| SectionError { kind: Self::KIND, message };
        let table: Self = serde_json::from_str(text).map_err(|e| err(format!("malformed table ({e})")))?;
        table.check(bundle).map_err(err)?;
        Ok(Some(table))
    }

    /// Stores the table in `ext` (replacing a section of its kind).
    fn store(&self, ext: &mut Extensions) {
        ext.set(Self::KIND, serde_json::to_string(self).unwrap_or_default());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_round_trip_in_kind_order_and_reject_unknown_or_repeated_kinds() {
        let mut ext = Extensions::default();
        ext.set(SectionKind::Grid, r#"{"a":[1,{"b":"}\"]"}]}"#.into());
        ext.set(SectionKind::Guided, "[]".into());
        let text = ext.encode();
        assert_eq!(text, r#"{"guided":[],"grid":{"a":[1,{"b":"}\"]"}]}}"#);
        assert_eq!(Extensions::decode(&text), Ok(ext));
        assert_eq!(Extensions::decode(""), Ok(Extensions::default()));
        let spaced = Extensions::decode(" { \"grid\" : 3 , \"creatures\" : \"x\" } ").expect("spaced");
        assert_eq!((spaced.get(SectionKind::Grid), spaced.get(SectionKind::Creatures)), (Some("3"), Some("\"x\"")));
        assert!(Extensions::decode(r#"{"grid":1,"grid":2}"#).is_err_and(|e| e.contains("twice")));
        assert!(Extensions::decode(r#"{"sound":1}"#).is_err_and(|e| e.contains("unknown extension section `sound`")));
        assert!(Extensions::decode("[1]").is_err_and(|e| e.contains("not a JSON object")));
        assert!(Extensions::decode(r#"{"grid":"#).is_err_and(|e| e.contains("malformed")));
    }
}
