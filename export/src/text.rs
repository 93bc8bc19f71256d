//! One buffered formatter for the writers that make text or many small records
//! (OBJ, PLY): numbers go straight into a byte buffer — floats in their shortest
//! round-trip form (`zmij`), integers by `itoa` — and the buffer goes to the output
//! in 64 KiB blocks, so no line costs a `format!` or a call through the writer.

use std::io::Write;

use crate::ExportError;

/// Bytes gathered before they are handed to the output.
const BLOCK: usize = 1 << 16;

/// A buffered writer of numbers and bytes (see the module docs).
pub(crate) struct Formatter<'w> {
    buf: Vec<u8>,
    w: &'w mut dyn Write,
    floats: zmij::Buffer,
    ints: itoa::Buffer,
}

impl<'w> Formatter<'w> {
    pub(crate) fn new(w: &'w mut dyn Write) -> Formatter<'w> {
        Formatter { buf: Vec::with_capacity(BLOCK + 256), w, floats: zmij::Buffer::new(), ints: itoa::Buffer::new() }
    }

    /// Appends bytes.
    #[inline]
    pub(crate) fn bytes(&mut self, b: &[u8]) -> Result<(), ExportError> {
        self.buf.extend_from_slice(b);
        if self.buf.len() >= BLOCK {
            self.flush()?;
        }
        Ok(())
    }

    /// Appends `x` in its shortest form that reads back as the same f32, as Rust's
    /// `{}` writes it for ordinary values (`1`, `-0.5`, `0.1`), with an exponent for
    /// very large or small ones (`1e-7`); non-finite values are written as 0 (no
    /// format here stores them).
    #[inline]
    pub(crate) fn f32(&mut self, x: f32) -> Result<(), ExportError> {
        let x = if x.is_finite() { x } else { 0.0 };
        let s = self.floats.format_finite(x).as_bytes();
        let s = s.strip_suffix(b".0").unwrap_or(s);
        self.buf.extend_from_slice(s);
        Ok(())
    }

    /// Appends `xs` separated by single spaces.
    #[inline]
    pub(crate) fn f32s(&mut self, xs: &[f32]) -> Result<(), ExportError> {
        for (k, x) in xs.iter().enumerate() {
            if k > 0 {
                self.buf.push(b' ');
            }
            self.f32(*x)?;
        }
        Ok(())
    }

    /// Appends an unsigned integer.
    #[inline]
    pub(crate) fn u64(&mut self, n: u64) -> Result<(), ExportError> {
        let s = self.ints.format(n).as_bytes();
        self.buf.extend_from_slice(s);
        Ok(())
    }

    /// Hands what is buffered to the output.
    pub(crate) fn flush(&mut self) -> Result<(), ExportError> {
        self.w.write_all(&self.buf).map_err(ExportError::Io)?;
        self.buf.clear();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_read_back_and_look_like_rust_s() {
        let mut out = Vec::new();
        let xs = [0.0f32, -0.0, 1.0, -1.0, 0.5, 0.1, 2.0 / 3.0, 1e-7, 3.4e38, -123456.79, 16777216.0, f32::NAN];
        {
            let mut f = Formatter::new(&mut out);
            for x in xs {
                f.f32(x).expect("f32");
                f.bytes(b" ").expect("bytes");
            }
            f.u64(18_446_744_073_709_551_615).expect("u64");
            f.flush().expect("flush");
        }
        let text = String::from_utf8(out).expect("utf8");
        let words: Vec<&str> = text.split(' ').collect();
        assert_eq!(&words[..6], &["0", "-0", "1", "-1", "0.5", "0.1"]);
        for (w, x) in words.iter().zip(xs) {
            let want = if x.is_finite() { x } else { 0.0 };
            assert_eq!(w.parse::<f32>().expect("a float").to_bits(), want.to_bits(), "{w}");
            if x.is_finite() && x.abs() < 1e7 && x.abs() > 1e-4 {
                assert_eq!(*w, format!("{x}"), "as {{}} writes it");
            }
        }
        assert_eq!(words.last(), Some(&"18446744073709551615"));
    }
}
