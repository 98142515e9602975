//! How the program tells whether two paths name the same file: [`resolve`] (the path made
//! absolute, `.`/`..` and the links of its directories resolved) and [`target`] (the same, and
//! a symbolic link in the last component followed to the file it points to). Outputs are
//! compared with each other and with the inputs by their targets ([`crate::outfile`],
//! [`crate::infile`]), and written to their targets (a link at an output stays a link).

use std::path::{Component, Path, PathBuf};

/// How many symbolic links [`target`] follows (Linux's `MAXSYMLINKS`); a longer chain or a
/// loop leaves the path at the last link reached.
const MAX_LINKS: usize = 40;

/// Removes `.` and resolves `..` lexically (for the part of a path that does not exist yet).
fn normalize(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            other => out.push(other),
        }
    }
    out
}

/// The file `path` names, made absolute with symbolic links in its directories resolved (the
/// longest existing ancestor is canonicalised, the rest normalised), so that `out/a.png`,
/// `./out/a.png` and `out/../out/a.png` compare equal. The last component is kept as it is
/// (see [`target`] to follow a link there).
pub fn resolve(path: &Path) -> PathBuf {
    let abs = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .unwrap_or_else(|_| PathBuf::from("."))
            .join(path)
    };
    let abs = normalize(&abs);
    let (Some(dir), Some(name)) = (abs.parent(), abs.file_name()) else {
        return abs;
    };
    let mut existing = dir.to_path_buf();
    let mut rest = Vec::new();
    loop {
        if let Ok(c) = existing.canonicalize() {
            let mut r = c;
            for part in rest.iter().rev() {
                r.push(part);
            }
            return normalize(&r.join(name));
        }
        match (
            existing.file_name().map(|n| n.to_os_string()),
            existing.parent(),
        ) {
            (Some(n), Some(p)) => {
                rest.push(n);
                existing = p.to_path_buf();
            }
            _ => return abs,
        }
    }
}

/// The file `path` names once a symbolic link in its last component is followed, link after
/// link (a relative link is relative to the link's directory), then [`resolve`]d: `out/a.png`
/// and a link to it have the same target, and a write through the link replaces that file.
/// A dangling link's target is the file it would create.
pub fn target(path: &Path) -> PathBuf {
    let mut p = resolve(path);
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {}
            _ => return p,
        }
        let Ok(link) = std::fs::read_link(&p) else {
            return p;
        };
        let dir = p.parent().map(Path::to_path_buf).unwrap_or_default();
        p = resolve(&dir.join(link));
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_are_followed_to_their_target() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().canonicalize().unwrap();
        let file = d.join("file.pfm");
        std::fs::write(&file, b"x").unwrap();
        std::os::unix::fs::symlink("file.pfm", d.join("rel")).unwrap();
        std::os::unix::fs::symlink(d.join("rel"), d.join("abs")).unwrap();
        std::os::unix::fs::symlink("missing/new.pfm", d.join("dangling")).unwrap();
        std::os::unix::fs::symlink("loop", d.join("loop")).unwrap();
        assert_eq!(target(&file), file);
        assert_eq!(target(&d.join("rel")), file);
        assert_eq!(target(&d.join("abs")), file);
        assert_eq!(target(&d.join("./sub/../abs")), file);
        assert_eq!(target(&d.join("dangling")), d.join("missing/new.pfm"));
        assert_eq!(target(&d.join("loop")), d.join("loop"));
        assert_eq!(resolve(&d.join("rel")), d.join("rel"));
    }
}
