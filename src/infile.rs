//! Files the program reads because a user named them, directly or through another file: scene
//! files and their includes, meshes, MTL libraries, measured tables, images, partial films,
//! direction tables. Every reader of such a file goes through here, so that one file from the
//! internet cannot take the machine down and no output replaces an input:
//!
//! * **Regular files only.** The file is opened without blocking (`O_NONBLOCK`, so that a FIFO
//!   does not wait for a writer) and refused unless it is a regular file: `/dev/zero`,
//!   `/dev/urandom`, a FIFO, a socket or a directory is named as what it is.
//! * **Bounded.** Each kind of file has a size limit ([`Kind`]); a larger file is refused
//!   before any of it is read, and a read stops one byte past the limit, so that a file that
//!   grows while it is read cannot go past it either.
//! * **Recorded.** Once [`record_inputs`] is called (the command line does, first thing), the
//!   file each read resolved to is remembered, and [`crate::outfile`] refuses to write over any
//!   of them ([`input_named`]): an output that is an include, a mesh, an MTL library or a
//!   measured table of the scene is refused, not written.

use std::fs::File;
use std::io::{self, Read as _};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// What a file is read as: its name in messages, and the most bytes it may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kind {
    pub what: &'static str,
    pub limit: u64,
}

const MIB: u64 = 1 << 20;
const GIB: u64 = 1 << 30;

/// A TOML or XML scene file (inline triangles included).
pub const SCENE: Kind = Kind {
    what: "scene file",
    limit: 256 * MIB,
};
/// A file a Mitsuba XML scene includes.
pub const INCLUDE: Kind = Kind {
    what: "included scene file",
    limit: 256 * MIB,
};
/// An OBJ mesh.
pub const OBJ: Kind = Kind {
    what: "OBJ mesh",
    limit: 8 * GIB,
};
/// A PLY mesh.
pub const PLY: Kind = Kind {
    what: "PLY mesh",
    limit: 8 * GIB,
};
/// An OBJ file's MTL library.
pub const MTL: Kind = Kind {
    what: "MTL library",
    limit: 64 * MIB,
};
/// A measured table (a MERL `.binary` file is 34,992,012 bytes).
pub const MEASURED: Kind = Kind {
    what: "measured table",
    limit: 64 * MIB,
};
/// An image (EXR, PNG, PFM): a 16384² RGB float image with its variance layer is 6 GiB.
pub const IMAGE: Kind = Kind {
    what: "image",
    limit: 16 * GIB,
};
/// A partial film (`.bwfilm`): f64 sums per pixel and block.
pub const FILM: Kind = Kind {
    what: "partial film",
    limit: 64 * GIB,
};
/// A Vulkan driver manifest (JSON), read to say what is wrong with one.
pub const MANIFEST: Kind = Kind {
    what: "driver manifest",
    limit: MIB,
};
/// A list of failed cases to run again (`stress --replay`, JSON lines).
pub const REPLAY: Kind = Kind {
    what: "replay file",
    limit: GIB,
};
/// A CSV table of directions (`brdf eval --dirs`).
pub const CSV: Kind = Kind {
    what: "CSV table",
    limit: GIB,
};

/// A byte count for messages: `512 bytes`, `3.5 MiB`, `8 GiB`.
pub fn fmt_bytes(n: u64) -> String {
    if n < 1024 {
        return format!("{n} bytes");
    }
    let (v, unit) = [(GIB, "GiB"), (MIB, "MiB"), (1024, "KiB")]
        .into_iter()
        .find(|(u, _)| n >= *u)
        .map(|(u, name)| (n as f64 / u as f64, name))
        .unwrap_or((n as f64, "bytes"));
    let s = format!("{v:.1}");
    format!("{} {unit}", s.trim_end_matches(".0"))
}

/// "a" or "an" before `what`.
pub fn article(what: &str) -> &'static str {
    let vowel = what.starts_with(['a', 'e', 'i', 'o', 'u', 'A', 'E', 'I', 'O', 'U']);
    // Letters said with a vowel first: an MTL library.
    if vowel || what.starts_with("MTL") {
        "an"
    } else {
        "a"
    }
}

fn refused(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

/// What a non-regular file is, for the message that refuses it.
fn file_type_name(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

/// Opens `path` for reading as a `kind` file: refused (with the reason) unless it is a regular
/// file of at most `kind.limit` bytes; recorded as an input ([`record_inputs`]). Returns the
/// file and its length.
pub fn open(path: &Path, kind: Kind) -> io::Result<(File, u64)> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // A FIFO opened for reading would wait for a writer; without blocking it opens at once
        // and is refused below. Reads of a regular file ignore the flag.
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        let t = file_type_name(meta.file_type());
        return Err(refused(format!(
            "is {t}, not a regular file: {} {} must be a regular file",
            article(kind.what),
            kind.what
        )));
    }
    if meta.len() > kind.limit {
        return Err(refused(format!(
            "is {}, over the {} {} {} may have",
            fmt_bytes(meta.len()),
            fmt_bytes(kind.limit),
            article(kind.what),
            kind.what
        )));
    }
    record(path, kind);
    Ok((file, meta.len()))
}

/// Reads the whole `kind` file at `path` ([`open`]'s checks), never more than `kind.limit`
/// bytes.
pub fn read(path: &Path, kind: Kind) -> io::Result<Vec<u8>> {
    let (file, len) = open(path, kind)?;
    read_opened(file, len, kind)
}

/// The bytes of a `file` [`open`] gave (of length `len`), never more than `kind.limit`.
pub fn read_opened(file: File, len: u64, kind: Kind) -> io::Result<Vec<u8>> {
    let mut bytes = Vec::with_capacity(len.min(kind.limit) as usize);
    file.take(kind.limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > kind.limit {
        return Err(refused(format!(
            "grew past the {} {} {} may have while it was read",
            fmt_bytes(kind.limit),
            article(kind.what),
            kind.what
        )));
    }
    Ok(bytes)
}

/// [`read`] as UTF-8 text, or an error that says where the file stops being text
/// ([`crate::errors::utf8_of`]).
pub fn read_text(path: &Path, kind: Kind) -> io::Result<String> {
    let bytes = read(path, kind)?;
    match String::from_utf8(bytes) {
        Ok(s) => Ok(s),
        // The text keeps the buffer read (a copy of a 38 MB OBJ file cost 10-20 ms of set-up).
        Err(e) => Err(crate::errors::utf8_of(e.as_bytes())
            .err()
            .unwrap_or_else(|| io::Error::other("not UTF-8 text"))),
    }
}

static RECORDING: AtomicBool = AtomicBool::new(false);
/// (the file read, as [`crate::outfile::target`] resolves it; what it was read as).
static INPUTS: Mutex<Vec<(PathBuf, &'static str)>> = Mutex::new(Vec::new());

/// From now on, remember every file read through this module, so that
/// [`crate::outfile`] refuses to write over one. The command line calls it first thing; a
/// library caller may.
pub fn record_inputs() {
    RECORDING.store(true, Ordering::SeqCst);
}

fn record(path: &Path, kind: Kind) {
    if !RECORDING.load(Ordering::SeqCst) {
        return;
    }
    let target = crate::outfile::target(path);
    let mut inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    if !inputs.iter().any(|(p, _)| *p == target) {
        inputs.push((target, kind.what));
    }
}

/// What the file `path` resolves to was read as, if it was read ([`record_inputs`]).
pub fn input_named(path: &Path) -> Option<&'static str> {
    if !RECORDING.load(Ordering::SeqCst) {
        return None;
    }
    let target = crate::outfile::target(path);
    let inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    inputs.iter().find(|(p, _)| *p == target).map(|(_, w)| *w)
}

/// Forgets that `path` was read: for a file the program itself keeps and may replace (a cache
/// entry found stale).
pub fn forget(path: &Path) {
    let target = crate::outfile::target(path);
    let mut inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    inputs.retain(|(p, _)| *p != target);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_read_like_people_write_them() {
        assert_eq!(fmt_bytes(0), "0 bytes");
        assert_eq!(fmt_bytes(1023), "1023 bytes");
        assert_eq!(fmt_bytes(1024), "1 KiB");
        assert_eq!(fmt_bytes(3 * MIB + MIB / 2), "3.5 MiB");
        assert_eq!(fmt_bytes(8 * GIB), "8 GiB");
    }

    /// Devices, FIFOs and directories are refused by what they are, at once (a FIFO with no
    /// writer does not block), and a file over the limit before it is read.
    #[test]
    fn only_bounded_regular_files_are_read() {
        let small = Kind {
            what: "test file",
            limit: 10,
        };
        for (dev, kind) in [
            ("/dev/zero", "character device"),
            ("/dev/urandom", "character device"),
            ("/", "directory"),
        ] {
            if Path::new(dev).exists() {
                let e = read(Path::new(dev), small).unwrap_err().to_string();
                assert!(e.contains(kind) && e.contains("regular file"), "{dev}: {e}");
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo reads the C string it is given.
        if unsafe { libc::mkfifo(c.as_ptr(), 0o600) } == 0 {
            let e = read(&fifo, small).unwrap_err().to_string();
            assert!(e.contains("FIFO"), "{e}");
        }
        let f = dir.path().join("f");
        std::fs::write(&f, b"0123456789").unwrap();
        assert_eq!(read(&f, small).unwrap(), b"0123456789");
        std::fs::write(&f, b"0123456789a").unwrap();
        let e = read(&f, small).unwrap_err().to_string();
        assert!(e.contains("11 bytes, over the 10 bytes a test file"), "{e}");
        std::fs::write(&f, b"ok \xff").unwrap();
        let e = read_text(&f, small).unwrap_err().to_string();
        assert!(e.contains("line 1, column 4"), "{e}");
    }
}
