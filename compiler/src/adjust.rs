//! The adjustment vocabulary: what each adjustment name means ([`AdjKind`]) and
//! the renamable colour and weight components ([`Components`]). Shared by the
//! parser (which groups adjustment words), the checker and lowering.

/// What an adjustment is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdjKind {
    /// `x X [Y [Z]]`, `y`, `z`.
    Translate(u8),
    /// `r`/`rotate X [Y [Z]]` (axis 3), `rx` (0), `ry` (1), `rz` (2).
    Rotate(u8),
    /// `up`/`down`/`left`/`right`/`rollleft`/`rollright`: axis and sign.
    Turn(u8, i8),
    Scale,
    /// `f X Y Z` (3) or `fx`/`fy`/`fz`.
    Flip(u8),
    Fps,
    Color(u8),
    Weight(u8),
    /// `hue` (0), `sat`/`saturation` (1), `b`/`brightness` (2): Context Free's HSB.
    Hsb(u8),
    /// A colour value, `#ff8800` or `#tomato` (the adjustment's name is its text):
    /// sets the colour absolutely.
    Paint,
    /// `skew X Y`: Context Free's skew, two angles (x += tan X · y, y += tan Y · x).
    Skew,
    /// `seed N` (on a rule call only): the call's whole sub-derivation draws from the
    /// random stream of (run seed, N); not part of the transform.
    Seed,
}

impl AdjKind {
    /// (min, max) argument count.
    pub fn arity(self) -> (usize, usize) {
        match self {
            AdjKind::Translate(0) | AdjKind::Rotate(3) | AdjKind::Scale => (1, 3),
            AdjKind::Turn(..) => (0, 1),
            AdjKind::Flip(3) => (3, 3),
            AdjKind::Flip(_) | AdjKind::Paint => (0, 0),
            AdjKind::Skew => (2, 2),
            _ => (1, 1),
        }
    }

    /// Whether arguments are angles (may carry unit suffixes).
    pub fn is_angle(self) -> bool {
        matches!(self, AdjKind::Rotate(_) | AdjKind::Turn(..) | AdjKind::Skew)
    }
}

/// The names of colour and weight components (renamable with `color`/`weight`).
#[derive(Clone, Debug)]
pub struct Components {
    pub color: [String; 4],
    pub weight: [String; 4],
}

impl Default for Components {
    fn default() -> Self {
        Components { color: ["R", "G", "B", "A"].map(String::from), weight: ["u", "v", "w", "q"].map(String::from) }
    }
}

impl Components {
    /// Classifies an adjustment name.
    pub fn adj_kind(&self, name: &str) -> Option<AdjKind> {
        Some(match name {
            "x" => AdjKind::Translate(0),
            "y" => AdjKind::Translate(1),
            "z" => AdjKind::Translate(2),
            "r" | "rotate" => AdjKind::Rotate(3),
            "rx" | "pitch" => AdjKind::Rotate(0),
            "ry" | "yaw" => AdjKind::Rotate(1),
            "rz" | "roll" => AdjKind::Rotate(2),
            "up" => AdjKind::Turn(0, 1),
            "down" => AdjKind::Turn(0, -1),
            "right" => AdjKind::Turn(1, 1),
            "left" => AdjKind::Turn(1, -1),
            "rollright" => AdjKind::Turn(2, 1),
            "rollleft" => AdjKind::Turn(2, -1),
            "s" => AdjKind::Scale,
            "f" => AdjKind::Flip(3),
            "fx" => AdjKind::Flip(0),
            "fy" => AdjKind::Flip(1),
            "fz" => AdjKind::Flip(2),
            "fps" => AdjKind::Fps,
            "skew" => AdjKind::Skew,
            "seed" => AdjKind::Seed,
            _ if name.starts_with('#') => AdjKind::Paint,
            _ => {
                if let Some(i) = self.color.iter().position(|c| c == name) {
                    AdjKind::Color(i as u8)
                } else if let Some(i) = self.weight.iter().position(|c| c == name) {
                    AdjKind::Weight(i as u8)
                } else {
                    // After the components, so a file that renames a colour `b` keeps it.
                    match name {
                        "hue" => AdjKind::Hsb(0),
                        "sat" | "saturation" => AdjKind::Hsb(1),
                        "b" | "brightness" => AdjKind::Hsb(2),
                        _ => return None,
                    }
                }
            }
        })
    }

    /// Every adjustment name, for "did you mean".
    pub fn all_names(&self) -> Vec<&str> {
        let mut v = vec![
            "x",
            "y",
            "z",
            "r",
            "rotate",
            "rx",
            "ry",
            "rz",
            "pitch",
            "yaw",
            "roll",
            "up",
            "down",
            "left",
            "right",
            "rollleft",
            "rollright",
            "s",
            "f",
            "fx",
            "fy",
            "fz",
            "fps",
            "skew",
            "seed",
            "hue",
            "sat",
            "saturation",
            "b",
            "brightness",
        ];
        v.extend(self.color.iter().map(|s| s.as_str()));
        v.extend(self.weight.iter().map(|s| s.as_str()));
        v
    }
}
