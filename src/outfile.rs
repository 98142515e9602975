//! Files the program writes: the one atomic writer every output and cache file goes through, and
//! the checks a command runs on its output paths before any work, so that a typo or an
//! unwritable directory does not cost a render.
//!
//! * [`write_with`] / [`write`]: a uniquely named temporary file in the destination directory is
//!   written, flushed to disk and renamed over the destination, so readers (other processes,
//!   parallel tests) see the old file or the complete new one, never a partial write, and a
//!   failed write leaves no temporary file behind. A new file gets the mode a plain
//!   `File::create` gives, `0666 & !umask`; a file that is replaced keeps its mode. A symbolic
//!   link at the destination is followed ([`target`]): the file it points to is replaced, in
//!   its own directory, and the link stays a link. The directory must exist. A file the
//!   command has read as an input ([`crate::infile`]) is never replaced.
//! * [`prepare`]: refuses two outputs that are the same file (through links too), and an
//!   output that is a file the command has read (the scene, an include, a mesh, an MTL
//!   library, a measured table, an image, a part), creates missing parent directories, and
//!   proves each directory writable by creating and removing a temporary file.
//! * [`write_each`]: writes every output it can and reports all that failed together.

use std::fs::File;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// A file-system step of an atomic write or an output check that failed. The message names the
/// file, the step and the operating system's reason.
#[derive(Debug, thiserror::Error)]
#[error("{}: {what}: {source}", crate::errors::shown_path(.path))]
pub struct WriteError {
    pub path: PathBuf,
    pub what: &'static str,
    pub source: std::io::Error,
}

/// `path`'s directory: its parent, or `.` for a bare file name.
pub fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Creates the temporary file an atomic write of `path` uses, in `dir`, named after `path`, and
/// registers it for removal on a signal. Each candidate name is registered before the file is
/// created (and unregistered if that name is taken), so there is no moment when the file exists
/// and a signal would leave it behind.
fn temp_file(
    path: &Path,
    dir: &Path,
) -> std::io::Result<(tempfile::NamedTempFile, on_signal::Live)> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let prefix = format!(".{}.", shorten(&name));
    let mut b = tempfile::Builder::new();
    b.prefix(&prefix).suffix(".tmp");
    let mut live = None;
    let tmp = b.make_in(dir, |candidate| {
        let registered = on_signal::Live::new(candidate);
        let mut open = std::fs::OpenOptions::new();
        open.read(true).write(true).create_new(true);
        // Temporary files are usually private (0600), and that mode would survive the rename.
        // Ask for 0666 instead: open(2) removes the umask's bits, as for any newly created file.
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            open.mode(0o666);
        }
        let file = open.open(candidate)?;
        live = Some(registered);
        Ok(file)
    })?;
    let live = live.expect("make_in returns a file only after the closure made one");
    Ok((tmp, live))
}

/// The destination's name shortened for the temporary file's suffix (names are limited to 255
/// bytes, and the prefix and random part take some).
fn shorten(name: &str) -> String {
    name.chars().take(64).collect()
}

/// Writes a file atomically (see the module documentation): `fill` writes the content into the
/// temporary file. The directory of `path` must exist.
pub fn write_with<E: From<WriteError>>(
    path: &Path,
    fill: impl FnOnce(&mut File) -> Result<(), E>,
) -> Result<(), E> {
    let err = |what: &'static str| {
        move |source: std::io::Error| WriteError {
            path: path.to_path_buf(),
            what,
            source,
        }
    };
    if let Some(what) = crate::infile::input_named(path) {
        return Err(err("is not replaced")(input_error(what)).into());
    }
    // Through a link to the file it names, which is replaced in its own directory.
    let dest = target(path);
    let dir = parent_dir(&dest);
    let (mut tmp, _live) =
        temp_file(&dest, dir).map_err(err("cannot create a temporary file in its directory"))?;
    if let Ok(meta) = std::fs::metadata(&dest) {
        if meta.is_file() {
            tmp.as_file()
                .set_permissions(meta.permissions())
                .map_err(err("cannot copy the permissions of the existing file"))?;
        }
    }
    // On any failure below, dropping `tmp` removes the temporary file.
    fill(tmp.as_file_mut())?;
    tmp.as_file_mut()
        .sync_all()
        .map_err(err("cannot flush the temporary file"))?;
    tmp.persist(&dest)
        .map_err(|e| err("cannot rename the temporary file over the destination")(e.error))?;
    Ok(())
}

/// Removes the temporary files of the writes in progress when the process is interrupted
/// (SIGINT, SIGTERM, SIGHUP), then dies of the signal as it would have: an interrupted write
/// keeps the old output and leaves no `.NAME.XXXXXX.tmp` behind. Call once, early in `main`;
/// without it (the library in tests) nothing changes.
pub fn remove_temporaries_on_signal() {
    on_signal::install();
}

#[cfg(unix)]
mod on_signal {
    use std::ffi::CString;
    use std::path::Path;
    use std::sync::atomic::{AtomicBool, AtomicPtr, Ordering};

    /// The temporary files being written (a C string each, or null): the handler may only read
    /// them, without locks or allocation.
    const SLOTS: usize = 64;
    static LIVE: [AtomicPtr<libc::c_char>; SLOTS] =
        [const { AtomicPtr::new(std::ptr::null_mut()) }; SLOTS];
    static INSTALLED: AtomicBool = AtomicBool::new(false);

    pub(super) fn install() {
        let handler: extern "C" fn(libc::c_int) = handler;
        for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            // SAFETY: the handler only calls async-signal-safe functions (unlink, signal, raise).
            unsafe {
                libc::signal(sig, handler as libc::sighandler_t);
            }
        }
        INSTALLED.store(true, Ordering::SeqCst);
    }

    extern "C" fn handler(sig: libc::c_int) {
        for slot in &LIVE {
            let p = slot.load(Ordering::SeqCst);
            if !p.is_null() {
                // SAFETY: a registered path is a valid C string that is never freed.
                unsafe {
                    libc::unlink(p);
                }
            }
        }
        // SAFETY: restores the default action and delivers the signal again.
        unsafe {
            libc::signal(sig, libc::SIG_DFL);
            libc::raise(sig);
        }
    }

    /// A temporary file registered for removal on a signal while it lives.
    pub(super) struct Live(Option<usize>);

    impl Live {
        pub(super) fn new(path: &Path) -> Live {
            use std::os::unix::ffi::OsStrExt;
            if !INSTALLED.load(Ordering::SeqCst) {
                return Live(None);
            }
            let Ok(c) = CString::new(path.as_os_str().as_bytes()) else {
                return Live(None);
            };
            let p = c.into_raw();
            for (i, slot) in LIVE.iter().enumerate() {
                if slot
                    .compare_exchange(std::ptr::null_mut(), p, Ordering::SeqCst, Ordering::SeqCst)
                    .is_ok()
                {
                    return Live(Some(i));
                }
            }
            // SAFETY: p came from into_raw above and was not stored.
            drop(unsafe { CString::from_raw(p) });
            Live(None)
        }
    }

    impl Drop for Live {
        fn drop(&mut self) {
            // The string is left allocated (a few bytes per write): a handler running on
            // another thread may be reading it.
            if let Some(i) = self.0 {
                LIVE[i].store(std::ptr::null_mut(), Ordering::SeqCst);
            }
        }
    }
}

#[cfg(not(unix))]
mod on_signal {
    pub(super) fn install() {}
    pub(super) struct Live;
    impl Live {
        pub(super) fn new(_: &std::path::Path) -> Live {
            Live
        }
    }
}

/// Writes `bytes` to `path` atomically (see [`write_with`]).
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_with(path, |f| {
        f.write_all(bytes).map_err(|source| WriteError {
            path: path.to_path_buf(),
            what: "cannot write the data",
            source,
        })
    })
}

/// An output of a command: the option that named it (for messages) and its path.
#[derive(Clone, Debug)]
pub struct Output<'a> {
    pub option: &'a str,
    pub path: &'a Path,
}

pub use crate::paths::{resolve, target};

/// Why a file the command has read is not written over.
fn input_error(what: &str) -> std::io::Error {
    std::io::Error::other(format!(
        "it is also an input of this command (read as the {what}): writing it would replace \
         the input; give the output another path"
    ))
}

/// Checks a command's outputs before it does any work (see the module documentation). Errors
/// name the option and the path.
pub fn prepare(outputs: &[Output]) -> anyhow::Result<()> {
    for o in outputs {
        if let Some(what) = crate::infile::input_named(o.path) {
            anyhow::bail!(
                "{} {}: {}",
                o.option,
                crate::errors::shown_path(o.path),
                input_error(what)
            );
        }
    }
    let resolved: Vec<PathBuf> = outputs.iter().map(|o| target(o.path)).collect();
    for i in 0..outputs.len() {
        for j in 0..i {
            if resolved[i] == resolved[j] {
                let (a, b) = (&outputs[j], &outputs[i]);
                anyhow::bail!(
                    "{} {} and {} {} are the same file ({}): one would overwrite the other; \
                     give each output its own path",
                    a.option,
                    crate::errors::shown_path(a.path),
                    b.option,
                    crate::errors::shown_path(b.path),
                    crate::errors::shown_path(&resolved[i])
                );
            }
        }
    }
    for o in outputs {
        check_one(o)?;
    }
    Ok(())
}

/// Refuses an output that is one of the command's inputs (`(what, path)`, e.g. the scene
/// file): the write would replace the input (`brdf eval --dirs x.csv --out x.csv`, a scene
/// named `.exr` given as its own `--out`). Paths are compared by their [`target`]s. (Every
/// file read through [`crate::infile`] is refused by [`prepare`] as well; this names inputs
/// before they are read.)
pub fn refuse_inputs(outputs: &[Output], inputs: &[(&str, &Path)]) -> anyhow::Result<()> {
    for o in outputs {
        for (what, input) in inputs {
            if target(o.path) == target(input) {
                anyhow::bail!(
                    "{} {} is also the {what}: writing it would replace the input; give the output another path",
                    o.option,
                    crate::errors::shown_path(o.path)
                );
            }
        }
    }
    Ok(())
}

/// The longest file name (one path component) the common file systems accept (ext4, XFS,
/// btrfs, tmpfs: `NAME_MAX`).
const MAX_NAME_BYTES: usize = 255;

fn check_one(o: &Output) -> anyhow::Result<()> {
    let shown = crate::errors::shown_path(o.path);
    if o.path.file_name().is_none() {
        anyhow::bail!("{} {shown}: names a directory, not a file", o.option);
    }
    if o.path.is_dir() {
        anyhow::bail!("{} {shown}: is a directory; give a file name", o.option);
    }
    // The probe below uses a shortened name, so it cannot see a name the file system refuses:
    // a 300-character output name passed and failed after the render.
    let name_len = o.path.file_name().map_or(0, |n| n.len());
    if name_len > MAX_NAME_BYTES {
        anyhow::bail!(
            "{} {shown}: the file name is {name_len} bytes long, over the {MAX_NAME_BYTES} bytes a file name may have",
            o.option
        );
    }
    // The file written is the link's target, in the target's directory.
    let dest = target(o.path);
    let dir = parent_dir(&dest);
    if !dir.is_dir() {
        std::fs::create_dir_all(dir).map_err(|e| {
            anyhow::anyhow!(
                "{} {shown}: cannot create the directory {}: {e}",
                o.option,
                crate::errors::shown_path(dir)
            )
        })?;
    }
    // Creating a file is the only reliable test (permissions, read-only or special file
    // systems, ACLs, root on /sys): make the temporary file the real write would make, and drop
    // it, which removes it.
    let _probe = temp_file(&dest, dir).map_err(|e| {
        anyhow::anyhow!(
            "{} {shown}: cannot write to the directory {}: {e}",
            o.option,
            crate::errors::shown_path(dir)
        )
    })?;
    Ok(())
}

/// Writes each output with `write` even when an earlier one fails; returns the paths written,
/// or an error listing every output that failed (and the ones that were written).
pub fn write_each<'p>(
    paths: &[&'p Path],
    mut write: impl FnMut(usize, &Path) -> anyhow::Result<()>,
) -> anyhow::Result<Vec<&'p Path>> {
    let mut written = Vec::new();
    let mut failed = Vec::new();
    for (i, p) in paths.iter().enumerate() {
        match write(i, p) {
            Ok(()) => written.push(*p),
            Err(e) => failed.push(format!("  {}", crate::errors::chain(&e))),
        }
    }
    if failed.is_empty() {
        return Ok(written);
    }
    let done = if written.is_empty() {
        String::from("none was written")
    } else {
        format!(
            "written: {}",
            written
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    anyhow::bail!(
        "{} of {} outputs could not be written ({done}):\n{}",
        failed.len(),
        paths.len(),
        failed.join("\n")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.bin");
        write(&p, b"one").unwrap();
        write(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn failed_fill_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("keep.txt");
        write(&p, b"old").unwrap();
        let r: anyhow::Result<()> = write_with(&p, |f| {
            f.write_all(b"partial")?;
            anyhow::bail!("encoder failed")
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn resolve_sees_through_dot_dot_and_links() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().canonicalize().unwrap();
        std::fs::create_dir(d.join("real")).unwrap();
        let a = resolve(&d.join("real").join("a.png"));
        assert_eq!(a, d.join("real/a.png"));
        assert_eq!(resolve(&d.join("real/./x/../a.png")), a);
        assert_eq!(resolve(&d.join("new/../real/a.png")), a);
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("real"), d.join("link")).unwrap();
            assert_eq!(resolve(&d.join("link/a.png")), a);
        }
        // Not yet existing directories resolve lexically.
        assert_eq!(resolve(&d.join("n1/n2/b.exr")), d.join("n1/n2/b.exr"));
    }

    #[test]
    fn write_each_writes_the_rest_after_a_failure() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, c) = (
            dir.path().join("a.txt"),
            dir.path().join("b.txt"),
            dir.path().join("c.txt"),
        );
        let paths = [a.as_path(), b.as_path(), c.as_path()];
        let err = write_each(&paths, |i, p| {
            if i == 1 {
                anyhow::bail!("{}: simulated failure", p.display());
            }
            write(p, b"x")?;
            Ok(())
        })
        .unwrap_err()
        .to_string();
        assert!(a.exists() && c.exists() && !b.exists());
        assert!(err.starts_with("1 of 3 outputs"), "{err}");
        assert!(err.contains("b.txt: simulated failure"), "{err}");
        assert!(err.contains("written: ") && err.contains("c.txt"), "{err}");
    }
    /// A link at the destination is written through: the file it names gets the content, the
    /// link stays; and a link to another output is the same output.
    #[cfg(unix)]
    #[test]
    fn links_are_written_through_and_compared_by_target() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("elsewhere")).unwrap();
        let file = d.join("elsewhere/t.pfm");
        std::fs::write(&file, b"old").unwrap();
        let link = d.join("link.pfm");
        std::os::unix::fs::symlink("elsewhere/t.pfm", &link).unwrap();
        write(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&file).unwrap(), b"new");
        // No temporary file is left in either directory.
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 2);
        assert_eq!(std::fs::read_dir(d.join("elsewhere")).unwrap().count(), 1);
        let out = |option, path| Output { option, path };
        let e = prepare(&[out("--out", &file), out("--out", &link)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("are the same file"), "{e}");
        let dangling = d.join("dangling.pfm");
        std::os::unix::fs::symlink("elsewhere/new.pfm", &dangling).unwrap();
        write(&dangling, b"made").unwrap();
        assert_eq!(std::fs::read(d.join("elsewhere/new.pfm")).unwrap(), b"made");
        assert!(std::fs::symlink_metadata(&dangling)
            .unwrap()
            .file_type()
            .is_symlink());
    }
}
