//! How errors read on the command line.

/// An error and its causes on one line, `outer: cause: root cause`, as anyhow's `{:#}` prints
/// them, but without repeats: many errors (OS, image decoder, TOML) already include their cause
/// in their own message, and printing the chain then repeats it two or three times. A cause
/// whose text is already part of what has been printed is left out.
pub fn chain(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if text.is_empty() || out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

/// A text file's contents, or an error that says where the file stops being UTF-8 text:
/// `line L, column C (byte offset B): byte 0xNN is not UTF-8`. `std::fs::read_to_string`
/// reports only "stream did not contain valid UTF-8", which leaves the user searching.
pub fn read_utf8(path: &std::path::Path) -> std::io::Result<String> {
    let bytes = std::fs::read(path)?;
    // The text keeps the buffer read (a copy of a 38 MB OBJ file cost 10-20 ms of set-up).
    String::from_utf8(bytes).map_err(|e| not_utf8_error(e.as_bytes(), e.utf8_error()))
}

/// `bytes` as text, or the error of [`read_utf8`] that locates the first invalid byte.
pub fn utf8_of(bytes: &[u8]) -> std::io::Result<&str> {
    std::str::from_utf8(bytes).map_err(|e| not_utf8_error(bytes, e))
}

/// The error of [`read_utf8`] and [`utf8_of`] for `bytes`, invalid UTF-8 as `e` says.
fn not_utf8_error(bytes: &[u8], e: std::str::Utf8Error) -> std::io::Error {
    let message = not_utf8_at(bytes, e.valid_up_to());
    std::io::Error::new(std::io::ErrorKind::InvalidData, message)
}

/// Where the invalid UTF-8 at byte offset `at` of `bytes` is, as a 1-based line and a column
/// counted in characters of the valid text before it.
fn not_utf8_at(bytes: &[u8], at: usize) -> String {
    // The prefix up to `at` is valid UTF-8 by construction of `valid_up_to`.
    let valid = std::str::from_utf8(&bytes[..at]).unwrap_or("");
    let line = valid.matches('\n').count() + 1;
    let line_start = valid.rfind('\n').map_or(0, |i| i + 1);
    let column = valid[line_start..].chars().count() + 1;
    format!(
        "not UTF-8 text: line {line}, column {column} (byte offset {at}): byte 0x{:02x} is not \
         UTF-8 (save the file as UTF-8)",
        bytes[at]
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context as _;

    #[test]
    fn causes_already_in_the_message_are_not_repeated() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let inner = crate::outfile::WriteError {
            path: "a/b.png".into(),
            what: "cannot create a temporary file in its directory",
            source: io,
        };
        let e = anyhow::Error::new(inner).context("writing a/b.png");
        let s = chain(&e);
        assert_eq!(s.matches("No such file").count(), 1, "{s}");
        assert_eq!(
            s,
            "writing a/b.png: a/b.png: cannot create a temporary file in its directory: No such file"
        );
        // Distinct causes are all kept.
        let e = Err::<(), _>(anyhow::anyhow!("root"))
            .context("middle")
            .context("top")
            .unwrap_err();
        assert_eq!(chain(&e), "top: middle: root");
    }

    #[test]
    fn invalid_utf8_is_located_by_line_and_column() {
        let bytes = "a = 1\nb = \"é"
            .as_bytes()
            .iter()
            .copied()
            .chain([0xff, b'"'])
            .collect::<Vec<u8>>();
        let at = std::str::from_utf8(&bytes).unwrap_err().valid_up_to();
        let m = not_utf8_at(&bytes, at);
        assert!(m.contains("line 2, column 7") && m.contains("0xff"), "{m}");
        let dir = std::env::temp_dir().join(format!("bw-utf8-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("x.txt");
        std::fs::write(&f, &bytes).unwrap();
        let e = read_utf8(&f).unwrap_err();
        assert_eq!(e.to_string(), m);
        std::fs::write(&f, "fine\n").unwrap();
        assert_eq!(read_utf8(&f).unwrap(), "fine\n");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
