//! Panic isolation: analysis and feature code run under `catch_unwind`, so a bug
//! in one request becomes an error response and a log line, and the server keeps
//! serving.

use std::panic::{catch_unwind, AssertUnwindSafe};

/// Runs `f`, turning a panic into `Err(message)`.
pub fn guard<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    // The analysis values are immutable once built and the document store is
    // updated only after a successful run, so nothing is left half-changed.
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        if let Some(s) = payload.downcast_ref::<&str>() {
            (*s).to_string()
        } else if let Some(s) = payload.downcast_ref::<String>() {
            s.clone()
        } else {
            "a panic with no message".to_string()
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panics_become_errors() {
        assert_eq!(guard(|| 2 + 2), Ok(4));
        assert_eq!(guard(|| -> i32 { panic!("boom") }), Err("boom".to_string()));
        let n = 3;
        assert_eq!(guard(|| -> i32 { panic!("boom {n}") }), Err("boom 3".to_string()));
    }
}
