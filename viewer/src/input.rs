//! The window's input, whatever produced it: winit's events and the lines of a
//! `--script` ([`crate::script`]) both become [`Input`]s, handled by one function of
//! the window, so a scripted drag takes the same path as a drag with the mouse.

/// A mouse button.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Button {
    Left,
    Right,
    Middle,
}

/// A key, as the window's handlers tell keys apart.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Key {
    /// A key that types text: the text as typed (`s`, `S`, `[`, `{`, `1`, ` `).
    Char(String),
    Escape,
    Tab,
    Delete,
    Backspace,
    Home,
    ArrowLeft,
    ArrowRight,
    ArrowUp,
    ArrowDown,
    PageUp,
    PageDown,
}

impl Key {
    /// A key by its name in scripts: one character, or `escape`, `tab`, `delete`,
    /// `backspace`, `home`, `left`, `right`, `up`, `down`, `pageup`, `pagedown`,
    /// `space`.
    pub fn from_name(name: &str) -> Option<Key> {
        Some(match name.to_ascii_lowercase().as_str() {
            "escape" | "esc" => Key::Escape,
            "tab" => Key::Tab,
            "delete" | "del" => Key::Delete,
            "backspace" => Key::Backspace,
            "home" => Key::Home,
            "left" => Key::ArrowLeft,
            "right" => Key::ArrowRight,
            "up" => Key::ArrowUp,
            "down" => Key::ArrowDown,
            "pageup" => Key::PageUp,
            "pagedown" => Key::PageDown,
            "space" => Key::Char(" ".into()),
            _ if name.chars().count() == 1 => Key::Char(name.to_string()),
            _ => return None,
        })
    }
}

/// Which modifier keys are held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Modifiers {
    pub shift: bool,
    pub ctrl: bool,
}

/// One input event.
#[derive(Clone, Debug, PartialEq)]
pub enum Input {
    /// The cursor is at (x, y) pixels from the window's top-left corner.
    CursorMoved(f64, f64),
    /// A mouse button went down (`pressed`) or up.
    Button { button: Button, pressed: bool },
    /// The wheel turned by this many lines (positive: away from the user).
    Wheel(f32),
    /// A key went down.
    Key(Key),
    /// The modifier keys now held.
    Modifiers(Modifiers),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_by_name() {
        assert_eq!(Key::from_name("s"), Some(Key::Char("s".into())));
        assert_eq!(Key::from_name("Delete"), Some(Key::Delete));
        assert_eq!(Key::from_name("space"), Some(Key::Char(" ".into())));
        assert_eq!(Key::from_name("pagedown"), Some(Key::PageDown));
        assert_eq!(Key::from_name("nosuchkey"), None);
    }
}
