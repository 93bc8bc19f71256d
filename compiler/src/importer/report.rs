//! The importer's report: every construct of the source program that the MDG
//! grammar does not say exactly as written, with its source line, and the MDG
//! names given to source names that MDG reserves.

use serde::Serialize;

/// What happened to a construct.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Action {
    /// Written as MDG that draws something close but not the same.
    Approximated,
    /// Left out of the MDG grammar.
    Dropped,
}

/// One reported construct.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Note {
    /// 1-based line in the source file (0 for the file as a whole).
    pub line: u32,
    /// The construct, as the source spells it (`skew`, `path`, `set maxobjects`).
    pub construct: String,
    pub action: Action,
    /// What the MDG grammar does instead, and why.
    pub detail: String,
}

/// The notes of one import, in source order.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Report {
    /// The source file's name as given.
    pub file: String,
    /// `context-free` or `structure-synth`.
    pub dialect: String,
    pub notes: Vec<Note>,
}

impl Report {
    pub(crate) fn new(file: &str, dialect: &str) -> Report {
        Report { file: file.to_string(), dialect: dialect.to_string(), notes: Vec::new() }
    }

    pub(crate) fn approx(&mut self, line: u32, construct: &str, detail: impl Into<String>) {
        self.push(line, construct, Action::Approximated, detail.into());
    }

    pub(crate) fn drop(&mut self, line: u32, construct: &str, detail: impl Into<String>) {
        self.push(line, construct, Action::Dropped, detail.into());
    }

    fn push(&mut self, line: u32, construct: &str, action: Action, detail: String) {
        let note = Note { line, construct: construct.to_string(), action, detail };
        // One note per line and construct: a list with two skews says it once.
        if !self.notes.iter().any(|n| n.line == note.line && n.construct == note.construct && n.action == note.action) {
            self.notes.push(note);
        }
    }

    /// The notes sorted by line (stable: the order of discovery within a line).
    pub(crate) fn finish(&mut self) {
        self.notes.sort_by_key(|n| n.line);
    }

    /// The distinct constructs reported, in first-seen order (for a summary).
    pub fn constructs(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for n in &self.notes {
            if !out.contains(&n.construct) {
                out.push(n.construct.clone());
            }
        }
        out
    }

    /// One line per note: `FILE:LINE: approximated|dropped CONSTRUCT: DETAIL`.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for n in &self.notes {
            let what = match n.action {
                Action::Approximated => "approximated",
                Action::Dropped => "dropped",
            };
            s.push_str(&format!("{}:{}: {what} `{}`: {}\n", self.file, n.line, n.construct, n.detail));
        }
        s
    }

    /// The report as JSON (`mdgc import --report FILE`).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }
}
