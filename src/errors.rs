//! How errors read on the command line: causes chained once, invalid UTF-8 located, and what a
//! user wrote (file names, values) shown so that it cannot garble the terminal or the message:
//! control characters escaped ([`shown`], [`shown_path`], [`terminal_safe`]) and long values cut
//! ([`excerpt`]).

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

/// `bytes` as text, or an error that says where they stop being UTF-8 text: `line L, column C
/// (byte offset B): byte 0xNN is not UTF-8`. (`std::fs::read_to_string` reports only "stream
/// did not contain valid UTF-8", which leaves the user searching.)
pub fn utf8_of(bytes: &[u8]) -> std::io::Result<&str> {
    std::str::from_utf8(bytes).map_err(|e| not_utf8_error(bytes, e))
}

/// The error of [`utf8_of`] for `bytes`, invalid UTF-8 as `e` says.
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

/// `c` as a visible escape when it is a control character (C0 but tab and newline when
/// `keep_lines`, DEL, C1): `\x1b`, `\u{9b}`; `None` for any other character.
fn escape(c: char, keep_lines: bool) -> Option<String> {
    match c {
        '\t' | '\n' if keep_lines => None,
        '\n' => Some("\\n".to_string()),
        '\t' => Some("\\t".to_string()),
        '\r' => Some("\\r".to_string()),
        c if (c as u32) < 0x20 || c as u32 == 0x7f => Some(format!("\\x{:02x}", c as u32)),
        c if (0x80..0xa0).contains(&(c as u32)) => Some(format!("\\u{{{:x}}}", c as u32)),
        _ => None,
    }
}

/// Text a user wrote (a name, a value), with every control character escaped, newlines too:
/// an escape sequence in a file name must not reach the terminal, nor a newline split a
/// message.
pub fn shown(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match escape(c, false) {
            Some(e) => out.push_str(&e),
            None => out.push(c),
        }
    }
    out
}

/// A path for a message, as [`shown`] shows text (lossy for a name that is not UTF-8).
pub fn shown_path(path: &std::path::Path) -> String {
    shown(&path.to_string_lossy())
}

/// A message on its way to the terminal, with the control characters of whatever it quotes
/// escaped ([`shown`]) except the tabs and newlines that lay it out: the last guard, for
/// every line the command line prints.
pub fn terminal_safe(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(|c| escape(c, true).is_some()) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        match escape(c, true) {
            Some(e) => out.push_str(&e),
            None => out.push(c),
        }
    }
    std::borrow::Cow::Owned(out)
}

/// The most characters of a user's value that a message quotes ([`excerpt`]).
pub const EXCERPT_CHARS: usize = 80;

/// A value a user wrote, for a message: [`shown`], and cut after [`EXCERPT_CHARS`]
/// characters with its full length said (`'aaaa… (2147483648 bytes)'`), so that a message
/// about a huge value is not huge itself.
pub fn excerpt(text: &str) -> String {
    if text.chars().count() <= EXCERPT_CHARS {
        return shown(text);
    }
    let head: String = text.chars().take(EXCERPT_CHARS).collect();
    format!("{}… ({} bytes)", shown(&head), text.len())
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
        assert_eq!(utf8_of(&bytes).unwrap_err().to_string(), m);
        assert_eq!(utf8_of(b"fine\n").unwrap(), "fine\n");
    }
    #[test]
    fn user_text_is_shown_escaped_and_cut() {
        assert_eq!(
            shown("a\x1b[31mb\nc\td\u{9b}"),
            "a\\x1b[31mb\\nc\\td\\u{9b}"
        );
        assert_eq!(shown("é ü ✓"), "é ü ✓");
        assert_eq!(terminal_safe("line 1\n\tline 2"), "line 1\n\tline 2");
        assert_eq!(terminal_safe("x\x07\x1b]0;t\x07"), "x\\x07\\x1b]0;t\\x07");
        let long = "ab".repeat(1000);
        let e = excerpt(&long);
        assert!(
            e.starts_with(&"ab".repeat(40)) && e.ends_with("… (2000 bytes)"),
            "{e}"
        );
        assert_eq!(excerpt("short"), "short");
    }
}
