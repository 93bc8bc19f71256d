//! Diagnostics as data: one type for errors and warnings, rendered in one place.
//!
//! Low-level code builds a [`Diagnostic`] with a code, a message and a primary span;
//! callers add secondary labels, notes and suggested edits. Rendering (terminal text
//! with codespan-reporting, or JSON) happens only here.

use crate::source::Sources;
use crate::span::Span;
use codespan_reporting::diagnostic as cs;
use codespan_reporting::files::{Error as FilesError, Files};
use codespan_reporting::term;
use serde::Serialize;

pub use crate::codes::Severity;

/// A labelled secondary span.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Label {
    pub span: Span,
    pub message: String,
}

/// A suggested edit: replace `span` with `replacement`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Suggestion {
    pub message: String,
    pub span: Span,
    pub replacement: String,
}

/// One diagnostic.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Diagnostic {
    pub severity: Severity,
    /// `E0301`, `W0001`, … (see `docs/diagnostics.md`).
    pub code: &'static str,
    pub message: String,
    pub span: Span,
    /// What the primary span shows (may be empty).
    pub label: String,
    pub secondary: Vec<Label>,
    pub notes: Vec<String>,
    pub suggestion: Option<Suggestion>,
}

impl Diagnostic {
    /// An error with a code, message and primary span. The code must be an error
    /// in the registry ([`crate::codes`]; checked in debug builds).
    pub fn error(code: &'static str, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Error, code, span, message.into())
    }

    /// A warning with a code, message and primary span. The code must be a warning
    /// in the registry ([`crate::codes`]; checked in debug builds).
    pub fn warning(code: &'static str, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Warning, code, span, message.into())
    }

    /// A note (information about the other diagnostics) with a code registered as a
    /// note.
    pub fn note(code: &'static str, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Note, code, span, message.into())
    }

    fn new(severity: Severity, code: &'static str, span: Span, message: String) -> Diagnostic {
        debug_assert!(
            crate::codes::lookup(code).is_some_and(|c| c.code == code && c.severity == severity),
            "diagnostic code {code} is not registered as a {severity:?} in compiler/src/codes.rs"
        );
        Diagnostic {
            severity,
            code,
            message,
            span,
            label: String::new(),
            secondary: vec![],
            notes: vec![],
            suggestion: None,
        }
    }

    /// Sets the primary label.
    pub fn with_label(mut self, label: impl Into<String>) -> Diagnostic {
        self.label = label.into();
        self
    }

    /// Adds a secondary label.
    pub fn with_secondary(mut self, span: Span, message: impl Into<String>) -> Diagnostic {
        self.secondary.push(Label { span, message: message.into() });
        self
    }

    /// Adds a note.
    pub fn with_note(mut self, note: impl Into<String>) -> Diagnostic {
        self.notes.push(note.into());
        self
    }

    /// Adds a suggested edit.
    pub fn with_suggestion(
        mut self,
        message: impl Into<String>,
        span: Span,
        replacement: impl Into<String>,
    ) -> Diagnostic {
        self.suggestion = Some(Suggestion { message: message.into(), span, replacement: replacement.into() });
        self
    }

    /// Whether this is an error.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

/// Most errors an analysis reports (see [`limit_report`]); also the most
/// diagnostics the lexer, the parser and the preprocessor keep for one file or
/// expansion ([`Capped`]), so junk input costs bounded memory.
pub const MAX_ERRORS: usize = 100;
/// Most warnings an analysis reports.
pub const MAX_WARNINGS: usize = 100;

/// Diagnostics left out by a [`Capped`] list: how many, and the earliest place of one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Suppressed {
    pub count: usize,
    pub first: Option<Span>,
}

impl Suppressed {
    /// Counts one left out at `span`.
    pub fn add(&mut self, span: Span) {
        *self += Suppressed { count: 1, first: Some(span) };
    }
}

impl std::ops::AddAssign for Suppressed {
    fn add_assign(&mut self, o: Suppressed) {
        self.count += o.count;
        self.first = match (self.first, o.first) {
            (Some(a), Some(b)) => Some(if (b.file, b.start) < (a.file, a.start) { b } else { a }),
            (a, b) => a.or(b),
        };
    }
}

impl std::ops::Add for Suppressed {
    type Output = Suppressed;
    fn add(mut self, o: Suppressed) -> Suppressed {
        self += o;
        self
    }
}

/// A list of diagnostics that keeps the first [`MAX_ERRORS`] and counts the rest.
#[derive(Debug, Default)]
pub struct Capped {
    pub list: Vec<Diagnostic>,
    /// Diagnostics not kept.
    pub suppressed: Suppressed,
}

impl Capped {
    /// Keeps `d` if there is room, else counts it.
    pub fn push(&mut self, d: Diagnostic) {
        if self.list.len() < MAX_ERRORS {
            self.list.push(d);
        } else {
            self.suppressed.add(d.span);
        }
    }

    /// Whether another diagnostic would be kept.
    pub fn has_room(&self) -> bool {
        self.list.len() < MAX_ERRORS
    }
}

/// Limits a list of diagnostics to its first [`MAX_ERRORS`] errors and
/// [`MAX_WARNINGS`] warnings, and returns the note (N0001) to show last, saying how
/// many more there were: those dropped here and `suppressed` (dropped earlier, by
/// a [`Capped`] list). The order of `diags` decides which are kept.
pub fn limit_report(diags: &mut Vec<Diagnostic>, suppressed: Suppressed) -> Option<Diagnostic> {
    let (mut errors, mut warnings) = (0usize, 0usize);
    let (mut more_errors, mut more_warnings) = (suppressed.count, 0usize);
    let mut first_dropped: Option<Span> = None;
    let mut last_kept = None;
    diags.retain(|d| {
        let keep = match d.severity {
            Severity::Error => {
                errors += 1;
                errors <= MAX_ERRORS || {
                    more_errors += 1;
                    false
                }
            }
            Severity::Warning => {
                warnings += 1;
                warnings <= MAX_WARNINGS || {
                    more_warnings += 1;
                    false
                }
            }
            Severity::Note => true,
        };
        if keep {
            last_kept = Some(d.span);
        } else if first_dropped.is_none_or(|f| (d.span.file, d.span.start) < (f.file, f.start)) {
            first_dropped = Some(d.span);
        }
        keep
    });
    if more_errors + more_warnings == 0 {
        return None;
    }
    let plural = |n: usize, what: &str| format!("{n} more {what}{}", if n == 1 { "" } else { "s" });
    let what = match (more_errors, more_warnings) {
        (e, 0) => plural(e, "error"),
        (0, w) => plural(w, "warning"),
        (e, w) => format!("{} and {}", plural(e, "error"), plural(w, "warning")),
    };
    let first_dropped = (Suppressed { count: 0, first: first_dropped } + suppressed).first;
    let span = first_dropped.or(last_kept).unwrap_or_default();
    Some(
        Diagnostic::note("N0001", span, format!("{what} not shown"))
            .with_label(if first_dropped.is_some() { "the first one not shown is here" } else { "" })
            .with_note(format!(
                "at most {MAX_ERRORS} errors and {MAX_WARNINGS} warnings are reported; fix the first ones and \
                 check again (later errors are often their consequences)"
            )),
    )
}

use crate::text::push_escaped;
pub use crate::text::{escape_text, needs_escape};

fn to_codespan(d: &Diagnostic, sources: &Sources) -> cs::Diagnostic<u32> {
    let clamp = |s: Span| {
        let len = sources.files.get(s.file.0 as usize).map(|f| f.text.len()).unwrap_or(0);
        let start = (s.start as usize).min(len);
        let end = (s.end as usize).clamp(start, len);
        (s.file.0, start..end)
    };
    let sev = match d.severity {
        Severity::Error => cs::Severity::Error,
        Severity::Warning => cs::Severity::Warning,
        Severity::Note => cs::Severity::Note,
    };
    let esc = |t: &str| escape_text(t).into_owned();
    let (f, r) = clamp(d.span);
    let mut labels = vec![cs::Label::primary(f, r).with_message(esc(&d.label))];
    for l in &d.secondary {
        let (f, r) = clamp(l.span);
        labels.push(cs::Label::secondary(f, r).with_message(esc(&l.message)));
    }
    let mut notes: Vec<String> = d.notes.iter().map(|n| esc(n)).collect();
    if let Some(s) = &d.suggestion {
        notes.push(format!("help: {}", esc(&s.message)));
    }
    cs::Diagnostic::new(sev).with_code(d.code).with_message(esc(&d.message)).with_labels(labels).with_notes(notes)
}

/// The longest source line a rendered diagnostic shows whole (in bytes); a longer
/// line is cut to a window of about this size around the labels, marked with `…`.
pub const MAX_SHOWN_LINE: usize = 240;

/// Renders diagnostics as plain text (no colour), the form used in snapshots and logs.
/// Source lines, file names and messages are shown with control characters escaped
/// ([`escape_text`]): a downloaded grammar cannot retitle, clear or recolour the
/// terminal of whoever checks it.
pub fn render_plain(diags: &[Diagnostic], sources: &Sources) -> String {
    let config = term::Config::default();
    let mut out = String::new();
    for d in diags {
        let cd = to_codespan(d, sources);
        let (shown, cd) = Shown::of(&cd, sources);
        // Rendering fails only if a span points outside its file, which `to_codespan` prevents.
        let _ = term::emit_to_string(&mut out, &config, &shown, &cd);
    }
    out
}

/// What one diagnostic shows of its files: the lines around its labels (the only
/// ones codespan-reporting prints), each with its control characters escaped and,
/// if longer than [`MAX_SHOWN_LINE`], cut to a window around its labels (other long
/// lines keep their start). Lines keep their numbers and the header its real line
/// and column; lines far from every label are left out of the text (they are never
/// printed), so a diagnostic costs its shown lines, not its file.
struct Shown<'s> {
    sources: &'s Sources,
    /// By file id (`None`: no label in it).
    files: Vec<Option<ShownFile>>,
}

struct ShownFile {
    /// The file name, escaped.
    name: String,
    /// The shown lines, each ending in `\n`.
    text: String,
    /// The shown lines in order: (line index, where it starts in `text`).
    starts: Vec<(usize, usize)>,
    /// Per shown line (as in `starts`): how it maps to the original.
    windows: Vec<ShownLine>,
}

/// One shown line: its window `ws..we` in the original text, where the window's
/// first byte went in the shown text, and per escaped character its original
/// offset, its length and the bytes its escape adds.
struct ShownLine {
    ws: usize,
    we: usize,
    at: usize,
    escapes: Vec<(usize, usize, usize)>,
}

impl ShownLine {
    /// Where an original offset of this line went (clamped to the window).
    fn to_shown(&self, o: usize) -> usize {
        let o = o.clamp(self.ws, self.we);
        let added: usize = self.escapes.iter().take_while(|(e, _, _)| *e < o).map(|(_, _, n)| n).sum();
        self.at + o - self.ws + added
    }

    /// The original offset a shown offset came from (inside an escape: its character).
    fn to_original(&self, s: usize) -> usize {
        let mut o = self.ws;
        let mut pos = self.at;
        if s <= pos {
            return o;
        }
        for &(e, len, n) in &self.escapes {
            // Plain bytes up to the escaped character.
            if s < pos + (e - o) {
                return o + (s - pos);
            }
            pos += e - o;
            // The escaped character: its escape is `n` bytes longer than it.
            if s < pos + len + n {
                return e;
            }
            pos += len + n;
            o = e + len;
        }
        (o + (s - pos)).min(self.we)
    }
}

/// Lines shown around a label that starts on line `a` and ends on line `b`: more
/// than codespan-reporting prints by default (3 lines after the start and 1 before
/// the end of a multi-line label).
fn shown_lines(a: usize, b: usize, n_lines: usize, out: &mut std::collections::BTreeSet<usize>) {
    let last = n_lines.saturating_sub(1);
    out.extend(a.saturating_sub(2)..=(a + 5).min(b).min(last));
    out.extend(b.saturating_sub(3).max(a)..=(b + 2).min(last));
}

impl<'s> Shown<'s> {
    /// The shown files of `d`, and `d` with its labels moved into them.
    fn of(d: &cs::Diagnostic<u32>, sources: &'s Sources) -> (Shown<'s>, cs::Diagnostic<u32>) {
        let mut files: Vec<Option<ShownFile>> = (0..sources.files.len()).map(|_| None).collect();
        let mut d = d.clone();
        let ids: std::collections::BTreeSet<u32> = d.labels.iter().map(|l| l.file_id).collect();
        for id in ids {
            let Some(f) = sources.files.get(id as usize) else { continue };
            let offsets: Vec<usize> =
                d.labels.iter().filter(|l| l.file_id == id).flat_map(|l| [l.range.start, l.range.end]).collect();
            let mut lines = std::collections::BTreeSet::new();
            for l in d.labels.iter().filter(|l| l.file_id == id) {
                let a = f.line_col(l.range.start as u32).0 as usize;
                let b = f.line_col(l.range.end as u32).0 as usize;
                shown_lines(a, b, f.n_lines(), &mut lines);
            }
            let mut text = String::new();
            let mut starts = Vec::with_capacity(lines.len());
            let mut windows = Vec::with_capacity(lines.len());
            for line in lines {
                let start = f.line_start(line as u32) as usize;
                let end = f.line_end(line as u32) as usize;
                let body = f.text[start..end].trim_end_matches(['\n', '\r']);
                let on: Vec<usize> =
                    offsets.iter().copied().filter(|&o| o >= start && o <= start + body.len()).collect();
                starts.push((line, text.len()));
                let (ws, we) = if body.len() <= MAX_SHOWN_LINE {
                    (start, start + body.len())
                } else if on.is_empty() {
                    (start, start + MAX_SHOWN_LINE)
                } else {
                    let lo = on.iter().min().copied().unwrap_or(start);
                    let ws = lo.saturating_sub(MAX_SHOWN_LINE / 4).max(start);
                    (ws, (ws + MAX_SHOWN_LINE).min(start + body.len()))
                };
                let (ws, we) = (floor_char(&f.text, ws), floor_char(&f.text, we));
                if ws > start {
                    text.push('…');
                }
                let at = text.len();
                let mut escapes = Vec::new();
                for (i, c) in f.text[ws..we].char_indices() {
                    let added = push_escaped(&mut text, c);
                    if added != c.len_utf8() {
                        escapes.push((ws + i, c.len_utf8(), added - c.len_utf8()));
                    }
                }
                windows.push(ShownLine { ws, we, at, escapes });
                if we < start + body.len() {
                    text.push('…');
                }
                text.push('\n');
            }
            let file = ShownFile { name: escape_text(&f.name).into_owned(), text, starts, windows };
            for l in d.labels.iter_mut().filter(|l| l.file_id == id) {
                l.range = file.to_shown(f, l.range.start)..file.to_shown(f, l.range.end);
            }
            files[id as usize] = Some(file);
        }
        (Shown { sources, files }, d)
    }

    fn file(&self, id: u32) -> Result<&ShownFile, FilesError> {
        self.files.get(id as usize).and_then(Option::as_ref).ok_or(FilesError::FileMissing)
    }
}

impl ShownFile {
    /// Where an original offset went (its line is always shown: it is a label's).
    fn to_shown(&self, f: &crate::source::SourceFile, o: usize) -> usize {
        let line = f.line_col(o as u32).0 as usize;
        match self.starts.binary_search_by_key(&line, |(l, _)| *l) {
            Ok(i) => self.windows[i].to_shown(o),
            Err(_) => self.text.len(),
        }
    }

    /// The index in `starts` of the shown line holding shown offset `s`.
    fn shown_line(&self, s: usize) -> usize {
        match self.starts.binary_search_by_key(&s, |(_, at)| *at) {
            Ok(i) => i,
            Err(i) => i.saturating_sub(1),
        }
    }
}

/// `i`, moved back to the start of the character it falls in.
fn floor_char(text: &str, mut i: usize) -> usize {
    while i > 0 && !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

impl<'a> Files<'a> for Shown<'_> {
    type FileId = u32;
    type Name = &'a str;
    type Source = &'a str;

    fn name(&'a self, id: u32) -> Result<&'a str, FilesError> {
        Ok(self.file(id)?.name.as_str())
    }
    fn source(&'a self, id: u32) -> Result<&'a str, FilesError> {
        Ok(self.file(id)?.text.as_str())
    }
    fn line_index(&'a self, id: u32, byte_index: usize) -> Result<usize, FilesError> {
        let f = self.file(id)?;
        Ok(f.starts.get(f.shown_line(byte_index)).map_or(0, |(l, _)| *l))
    }
    /// The position in the original file (the header shows where the label really is).
    fn location(&'a self, id: u32, byte_index: usize) -> Result<codespan_reporting::files::Location, FilesError> {
        let f = self.file(id)?;
        let i = f.shown_line(byte_index);
        let (line, _) = *f.starts.get(i).ok_or(FilesError::FileMissing)?;
        let original = f.windows[i].to_original(byte_index);
        let orig = self.sources.files.get(id as usize).ok_or(FilesError::FileMissing)?;
        let line_start = orig.line_start(line as u32) as usize;
        let column = orig.text.get(line_start..original).map_or(0, |t| t.chars().count()) + 1;
        Ok(codespan_reporting::files::Location { line_number: line + 1, column_number: column })
    }
    /// A shown line's range; a line left out is empty (it is never printed).
    fn line_range(&'a self, id: u32, line_index: usize) -> Result<std::ops::Range<usize>, FilesError> {
        let f = self.file(id)?;
        let n = self.sources.files.get(id as usize).map_or(0, |s| s.n_lines());
        if line_index >= n {
            return Err(FilesError::LineTooLarge { given: line_index, max: n.saturating_sub(1) });
        }
        Ok(match f.starts.binary_search_by_key(&line_index, |(l, _)| *l) {
            Ok(i) => f.starts[i].1..f.starts.get(i + 1).map_or(f.text.len(), |(_, at)| *at),
            Err(i) => {
                let at = f.starts.get(i).map_or(f.text.len(), |(_, at)| *at);
                at..at
            }
        })
    }
}

/// A diagnostic with resolved file names and line/column positions, for JSON output.
#[derive(Serialize)]
pub struct JsonDiagnostic<'a> {
    pub severity: Severity,
    pub code: &'a str,
    pub message: &'a str,
    pub file: &'a str,
    /// 1-based line and column (in bytes) of the primary span's start and end.
    pub line: u32,
    pub column: u32,
    pub end_line: u32,
    pub end_column: u32,
    pub span: Span,
    pub label: &'a str,
    pub secondary: &'a [Label],
    pub notes: &'a [String],
    pub suggestion: &'a Option<Suggestion>,
}

/// Renders diagnostics as one JSON object per line; no raw control character is
/// written (strings hold them as `\u` escapes).
pub fn render_json(diags: &[Diagnostic], sources: &Sources) -> String {
    let mut out = String::new();
    for d in diags {
        let (name, (l0, c0), (l1, c1)) = match sources.files.get(d.span.file.0 as usize) {
            Some(f) => (f.name.as_str(), f.line_col(d.span.start), f.line_col(d.span.end)),
            None => ("", (0, 0), (0, 0)),
        };
        let j = JsonDiagnostic {
            severity: d.severity,
            code: d.code,
            message: &d.message,
            file: name,
            line: l0 + 1,
            column: c0 + 1,
            end_line: l1 + 1,
            end_column: c1 + 1,
            span: d.span,
            label: &d.label,
            secondary: &d.secondary,
            notes: &d.notes,
            suggestion: &d.suggestion,
        };
        // JSON escapes C0 controls itself; C1 controls and text-flow characters are
        // written as `\u` escapes too (the same string, safe on a terminal).
        for c in serde_json::to_string(&j).unwrap_or_default().chars() {
            if needs_escape(c) {
                out.push_str(&format!("\\u{:04x}", c as u32));
            } else {
                out.push(c);
            }
        }
        out.push('\n');
    }
    out
}

/// The closest candidate to `name` by edit distance, if it is close enough to be a
/// plausible typo ("did you mean").
pub fn did_you_mean<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    // One- and two-letter names only match when they differ in case.
    let limit = if name.chars().count() <= 2 { 0 } else { (name.len() / 3).max(1) };
    let lower = name.to_lowercase();
    candidates
        .into_iter()
        .filter(|c| *c != name)
        // The distance is at least the difference in length (ASCII lowercases to the
        // same length): skip candidates out of reach before computing it. Thousands of
        // unknown names against thousands of rules made this the cost of a whole check.
        .filter(|c| !(c.is_ascii() && name.is_ascii()) || c.len().abs_diff(name.len()) <= limit)
        .map(|c| (edit_distance(&lower, &c.to_lowercase()), c))
        .filter(|(d, _)| *d <= limit)
        .min_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(b.1)))
        .map(|(_, c)| c)
}

/// Levenshtein distance over chars.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for (i, ca) in a.chars().enumerate() {
        cur[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cost = usize::from(ca != *cb);
            cur[j + 1] = (prev[j] + cost).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}
