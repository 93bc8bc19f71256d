//! Reading input files without trusting them: only regular files, opened without
//! blocking (a named pipe no writer holds would block `open` for ever), at most a
//! given number of bytes (a device such as `/dev/zero` reports no length and never
//! ends). Every tool reads sources, bundles, guide and voxel files through
//! [`read_bounded`].

use std::io::Read;
use std::path::Path;

/// The most bytes read from a bundle, guide or other data file: 256 MiB.
pub const MAX_DATA_BYTES: u64 = 256 << 20;

/// Why a file was not read.
#[derive(Debug)]
pub enum ReadError {
    /// Opening or reading failed.
    Io(std::io::Error),
    /// The path is a directory, device, pipe or socket; the text names which.
    NotRegular(&'static str),
    /// The file has more than the limit; the size read (or reported) so far.
    TooLarge { len: u64, max: u64 },
    /// The file was read as text ([`read_text_bounded`]) and is not UTF-8.
    NotUtf8,
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::Io(e) => write!(f, "{e}"),
            ReadError::NotRegular(what) => write!(f, "not a regular file ({what}); only regular files are read"),
            ReadError::TooLarge { len, max } => write!(f, "file too large: {len} bytes (at most {max})"),
            ReadError::NotUtf8 => write!(f, "stream did not contain valid UTF-8"),
        }
    }
}

/// What a path that is not a regular file is, for messages ("a named pipe", "a device", …).
pub fn kind(m: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = m.file_type();
        if t.is_fifo() {
            return "a named pipe";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if m.is_dir() {
        "a directory"
    } else {
        "not a plain file"
    }
}

/// Reads the regular file at `path` (symlinks followed), at most `max` bytes.
/// Opened with `O_NONBLOCK` on Unix so a named pipe is refused instead of waited on;
/// the type is checked on the open file (no race with a rename in between).
pub fn read_bounded(path: &Path, max: u64) -> Result<Vec<u8>, ReadError> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NONBLOCK);
    }
    let f = o.open(path).map_err(ReadError::Io)?;
    let m = f.metadata().map_err(ReadError::Io)?;
    if !m.is_file() {
        return Err(ReadError::NotRegular(kind(&m)));
    }
    if m.len() > max {
        return Err(ReadError::TooLarge { len: m.len(), max });
    }
    // The file may grow while it is read: never more than max + 1 bytes.
    let mut bytes = Vec::with_capacity(m.len() as usize);
    f.take(max + 1).read_to_end(&mut bytes).map_err(ReadError::Io)?;
    if bytes.len() as u64 > max {
        return Err(ReadError::TooLarge { len: bytes.len() as u64, max });
    }
    Ok(bytes)
}

/// [`read_bounded`] as UTF-8 text ([`ReadError::NotUtf8`] when it is not).
pub fn read_text_bounded(path: &Path, max: u64) -> Result<String, ReadError> {
    let bytes = read_bounded(path, max)?;
    String::from_utf8(bytes).map_err(|_| ReadError::NotUtf8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_directories_and_large_files_are_refused() {
        #[cfg(unix)]
        {
            let e = read_bounded(Path::new("/dev/zero"), 1 << 20).expect_err("refused");
            assert!(matches!(e, ReadError::NotRegular("a device")), "{e}");
        }
        let e = read_bounded(Path::new("."), 1 << 20).expect_err("refused");
        assert!(matches!(e, ReadError::NotRegular(_)), "{e}");
        let me = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/input.rs");
        assert!(matches!(read_bounded(&me, 10).expect_err("refused"), ReadError::TooLarge { max: 10, .. }));
        assert!(read_text_bounded(&me, 1 << 20).expect("ok").contains("read_bounded"));
    }

    /// A file whose reported size is below the limit but whose content is not (a
    /// `/proc` file reports 0, as a file that grows after the check would) is read
    /// only to the limit and refused: `take(max + 1)`, not the metadata, stops it.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_file_longer_than_its_reported_size_is_read_only_to_the_limit() {
        let p = Path::new("/proc/self/status");
        assert_eq!(std::fs::metadata(p).expect("meta").len(), 0, "/proc reports no size");
        let whole = read_bounded(p, 1 << 20).expect("within the limit");
        assert!(whole.len() > 100, "{} bytes", whole.len());
        let e = read_bounded(p, 100).expect_err("longer than 100 bytes");
        assert!(matches!(e, ReadError::TooLarge { len: 101, max: 100 }), "{e:?}");
        assert_eq!(e.to_string(), "file too large: 101 bytes (at most 100)");
    }
}
