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
}
