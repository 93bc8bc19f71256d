//! `mdg-view --script FILE`: input read from a file instead of the mouse and
//! keyboard (tests, demonstrations). Each line is one command; the input commands
//! become the same [`Input`]s winit's events become, so they go through the
//! window's own handlers.
//!
//! ```text
//! # a comment
//! wait 200              pause for 200 ms
//! idle                  wait until the newest search is on screen
//! move 400 300          the cursor to pixel (400, 300)
//! move-by 120 -40 12    the cursor by (120, −40) pixels in 12 moves, 16 ms apart
//! point 2 4             the cursor onto guide 2's control point 4 (both from 1)
//! press left            a button down: left, right or middle
//! release left          a button up
//! key s                 a key: one character, or escape, tab, delete, backspace,
//!                       home, left, right, up, down, pageup, pagedown, space;
//!                       with ctrl+ or shift+ (e.g. ctrl+z)
//! screenshot out.png    write the window's frame now
//! quit                  close the window
//! ```

use crate::input::{Button, Input, Key, Modifiers};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The time between the moves of a `move-by`.
pub const MOVE_INTERVAL: Duration = Duration::from_millis(16);
/// The longest `wait`, and the most moves in a `move-by`.
const MAX_WAIT_MS: u64 = 600_000;
const MAX_STEPS: u32 = 10_000;

/// One line of a script.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    Wait(Duration),
    Idle,
    Move(f64, f64),
    MoveBy {
        dx: f64,
        dy: f64,
        steps: u32,
    },
    /// Guide and control point, from 0.
    Point {
        guide: usize,
        point: usize,
    },
    Button {
        button: Button,
        pressed: bool,
    },
    Key {
        key: Key,
        modifiers: Option<Modifiers>,
    },
    Screenshot(PathBuf),
    Quit,
}

/// A script line that is not a command.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScriptError {
    /// The line's number, from 1.
    pub line: usize,
    /// The line as written (without its comment).
    pub text: String,
    /// What was expected there.
    pub why: String,
}

impl std::fmt::Display for ScriptError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: `{}`: {}", self.line, self.text, self.why)
    }
}

impl std::error::Error for ScriptError {}

/// Parses a script; the error names the line.
pub fn parse(text: &str) -> Result<Vec<(usize, Command)>, ScriptError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        let bad = |why: &str| ScriptError { line: n, text: line.to_string(), why: why.to_string() };
        let num = |w: &str| w.parse::<f64>().ok().filter(|v| v.is_finite() && v.abs() <= 1e6);
        let index = |w: &str| w.parse::<usize>().ok().filter(|v| *v >= 1).map(|v| v - 1);
        let button = |w: &str| match w {
            "left" => Some(Button::Left),
            "right" => Some(Button::Right),
            "middle" => Some(Button::Middle),
            _ => None,
        };
        let cmd = match words.as_slice() {
            ["wait", ms] => {
                let ms = ms
                    .parse::<u64>()
                    .ok()
                    .filter(|m| *m <= MAX_WAIT_MS)
                    .ok_or_else(|| bad(&format!("expected milliseconds, 0 to {MAX_WAIT_MS}")))?;
                Command::Wait(Duration::from_millis(ms))
            }
            ["idle"] => Command::Idle,
            ["quit"] => Command::Quit,
            ["move", x, y] => match (num(x), num(y)) {
                (Some(x), Some(y)) => Command::Move(x, y),
                _ => return Err(bad("expected two numbers (pixels)")),
            },
            ["move-by", dx, dy, rest @ ..] if rest.len() <= 1 => {
                let steps = match rest.first() {
                    None => 1,
                    Some(s) => s
                        .parse::<u32>()
                        .ok()
                        .filter(|s| (1..=MAX_STEPS).contains(s))
                        .ok_or_else(|| bad(&format!("expected a number of moves, 1 to {MAX_STEPS}")))?,
                };
                match (num(dx), num(dy)) {
                    (Some(dx), Some(dy)) => Command::MoveBy { dx, dy, steps },
                    _ => return Err(bad("expected two numbers (pixels)")),
                }
            }
            ["point", g, p] => match (index(g), index(p)) {
                (Some(guide), Some(point)) => Command::Point { guide, point },
                _ => return Err(bad("expected a guide and a control point, counted from 1")),
            },
            ["press", b] | ["release", b] => Command::Button {
                button: button(b).ok_or_else(|| bad("expected left, right or middle"))?,
                pressed: words[0] == "press",
            },
            ["key", k] => {
                let mut modifiers = Modifiers::default();
                let mut name = *k;
                loop {
                    if let Some(r) = name.strip_prefix("ctrl+").filter(|r| !r.is_empty()) {
                        modifiers.ctrl = true;
                        name = r;
                    } else if let Some(r) = name.strip_prefix("shift+").filter(|r| !r.is_empty()) {
                        modifiers.shift = true;
                        name = r;
                    } else {
                        break;
                    }
                }
                let key = Key::from_name(name).ok_or_else(|| bad("unknown key"))?;
                Command::Key { key, modifiers: (modifiers != Modifiers::default()).then_some(modifiers) }
            }
            ["screenshot", file] => Command::Screenshot(PathBuf::from(file)),
            _ => return Err(bad("unknown command (see mdg-view --help)")),
        };
        out.push((n, cmd));
    }
    Ok(out)
}

/// What the window does next for the script.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Handle this input.
    Input(Input),
    /// Move the cursor onto this control point (the window knows where it is drawn)
    /// and tell the runner with [`Runner::cursor_at`].
    Point {
        guide: usize,
        point: usize,
    },
    Screenshot(PathBuf),
    Quit,
    /// Nothing yet: call again at this time (or on the next event when `None`).
    Wait(Option<Instant>),
    /// The script is over.
    Done,
}

/// Runs a parsed script.
#[derive(Clone, Debug)]
pub struct Runner {
    commands: Vec<(usize, Command)>,
    next: usize,
    resume_at: Option<Instant>,
    cursor: (f64, f64),
    /// Moves left of a `move-by`, and their size.
    moves_left: u32,
    step: (f64, f64),
    /// Inputs queued by the current command (a key with its modifiers).
    queued: Vec<Input>,
}

impl Runner {
    pub fn new(commands: Vec<(usize, Command)>) -> Runner {
        Runner {
            commands,
            next: 0,
            resume_at: None,
            cursor: (0.0, 0.0),
            moves_left: 0,
            step: (0.0, 0.0),
            queued: Vec::new(),
        }
    }

    /// The line of the command being run (for messages).
    pub fn line(&self) -> usize {
        self.commands.get(self.next.saturating_sub(1)).map_or(0, |c| c.0)
    }

    /// Where the cursor is now (after a [`Step::Point`]).
    pub fn cursor_at(&mut self, x: f64, y: f64) {
        self.cursor = (x, y);
    }

    /// The next step at time `now`; `idle` says whether no search is in flight and
    /// the newest one's model is on screen. `modifiers` are those held (a key with
    /// its own modifiers restores them after it).
    pub fn next(&mut self, now: Instant, idle: bool, modifiers: Modifiers) -> Step {
        if !self.queued.is_empty() {
            return Step::Input(self.queued.remove(0));
        }
        if let Some(t) = self.resume_at {
            if now < t {
                return Step::Wait(Some(t));
            }
            self.resume_at = None;
        }
        if self.moves_left > 0 {
            self.moves_left -= 1;
            self.cursor = (self.cursor.0 + self.step.0, self.cursor.1 + self.step.1);
            if self.moves_left > 0 {
                self.resume_at = Some(now + MOVE_INTERVAL);
            }
            return Step::Input(Input::CursorMoved(self.cursor.0, self.cursor.1));
        }
        let Some((_, cmd)) = self.commands.get(self.next).cloned() else { return Step::Done };
        if cmd == Command::Idle && !idle {
            return Step::Wait(None);
        }
        self.next += 1;
        match cmd {
            Command::Idle => self.next(now, idle, modifiers),
            Command::Wait(d) => {
                self.resume_at = Some(now + d);
                Step::Wait(self.resume_at)
            }
            Command::Move(x, y) => {
                self.cursor = (x, y);
                Step::Input(Input::CursorMoved(x, y))
            }
            Command::MoveBy { dx, dy, steps } => {
                self.step = (dx / steps as f64, dy / steps as f64);
                self.moves_left = steps;
                self.next(now, idle, modifiers)
            }
            Command::Point { guide, point } => Step::Point { guide, point },
            Command::Button { button, pressed } => Step::Input(Input::Button { button, pressed }),
            Command::Key { key, modifiers: None } => Step::Input(Input::Key(key)),
            Command::Key { key, modifiers: Some(m) } => {
                self.queued = vec![Input::Key(key), Input::Modifiers(modifiers)];
                Step::Input(Input::Modifiers(m))
            }
            Command::Screenshot(p) => Step::Screenshot(p),
            Command::Quit => Step::Quit,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripts_parse_and_bad_lines_are_named() {
        let s = parse("# drag\nidle\npoint 1 4\npress left\nmove-by 30 -10 3\nrelease left\nkey ctrl+z\nkey s\nwait 5\nscreenshot a.png\nquit\n")
            .expect("parses");
        assert_eq!(s[1], (3, Command::Point { guide: 0, point: 3 }));
        assert_eq!(s[3], (5, Command::MoveBy { dx: 30.0, dy: -10.0, steps: 3 }));
        assert_eq!(
            s[5],
            (7, Command::Key { key: Key::Char("z".into()), modifiers: Some(Modifiers { ctrl: true, shift: false }) })
        );
        for (bad, why) in [
            ("jump 1 2", "line 1: `jump 1 2`: unknown command"),
            ("move 1", "unknown command"),
            ("move a b", "expected two numbers"),
            ("point 0 1", "counted from 1"),
            ("press thumb", "left, right or middle"),
            ("key nosuch", "unknown key"),
            ("wait -3", "milliseconds"),
            ("move-by 1 1 0", "number of moves"),
        ] {
            let e = parse(bad).expect_err(bad);
            assert_eq!((e.line, e.text.as_str()), (1, bad));
            assert!(e.to_string().contains(why), "{bad}: {e}");
        }
        assert_eq!(parse("idle\n\n  move 1 # two numbers").expect_err("one").line, 3);
    }

    #[test]
    fn the_runner_spaces_moves_waits_for_idle_and_wraps_keys_in_their_modifiers() {
        let cmds = parse("move 10 10\nmove-by 30 0 3\nidle\nkey ctrl+z\nquit").expect("parses");
        let mut r = Runner::new(cmds);
        let t0 = Instant::now();
        let none = Modifiers::default();
        assert_eq!(r.next(t0, false, none), Step::Input(Input::CursorMoved(10.0, 10.0)));
        assert_eq!(r.next(t0, false, none), Step::Input(Input::CursorMoved(20.0, 10.0)));
        // The next move waits its interval.
        assert_eq!(r.next(t0, false, none), Step::Wait(Some(t0 + MOVE_INTERVAL)));
        let t1 = t0 + MOVE_INTERVAL;
        assert_eq!(r.next(t1, false, none), Step::Input(Input::CursorMoved(30.0, 10.0)));
        let t2 = t1 + MOVE_INTERVAL;
        assert_eq!(r.next(t2, false, none), Step::Input(Input::CursorMoved(40.0, 10.0)));
        // `idle` holds until the search is done.
        assert_eq!(r.next(t2, false, none), Step::Wait(None));
        let ctrl = Modifiers { ctrl: true, shift: false };
        assert_eq!(r.next(t2, true, none), Step::Input(Input::Modifiers(ctrl)));
        assert_eq!(r.next(t2, true, ctrl), Step::Input(Input::Key(Key::Char("z".into()))));
        assert_eq!(r.next(t2, true, ctrl), Step::Input(Input::Modifiers(none)));
        assert_eq!(r.next(t2, true, none), Step::Quit);
        assert_eq!(r.next(t2, true, none), Step::Done);
    }
}
