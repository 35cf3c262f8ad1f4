//! What raylab prints: the program's output (`say!`) and its messages (`note!`), both made
//! safe for a terminal and neither able to fail the program.
//!
//! Messages quote what files say (a shape's name, a shard's header, a path), and a file may
//! hold control characters: an escape sequence would clear the screen or retitle the window,
//! a NUL or a carriage return would hide what came before. Every control character but the
//! newline and the tab, and the Unicode characters that reorder text (bidirectional
//! overrides), is written as its escape (`\u{1b}`) instead.

use std::borrow::Cow;
use std::fmt::Write as _;

/// `text` with every character a terminal would act on written as its escape.
pub fn safe(text: &str) -> Cow<'_, str> {
    let acts = |c: char| {
        (c.is_control() && c != '\n' && c != '\t')
            || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
    };
    if !text.chars().any(acts) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if acts(c) {
            let _ = write!(out, "\\u{{{:x}}}", c as u32);
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// Writes the program's output to standard output (see the `say!` macro), ignoring a
/// failure: a reader that went away (`raylab integrators | head`) or a terminal gone after
/// SIGHUP must neither panic the program (as `println!` would) nor stop an image from being
/// written.
pub fn print_out(args: std::fmt::Arguments) {
    use std::io::Write;
    let text = args.to_string();
    let mut out = std::io::stdout().lock();
    let _ = out
        .write_all(safe(&text).as_bytes())
        .and_then(|()| out.flush());
}

/// Prints a line on stderr (see the `note!` macro), ignoring a failure: after SIGHUP the
/// terminal may be gone, and a message that cannot be shown must not stop the image from
/// being written.
pub fn note(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{}", safe(line));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_escaped_and_text_is_kept() {
        assert!(matches!(safe("plain text\n\tand a tab"), Cow::Borrowed(_)));
        assert_eq!(
            safe("shape \u{1b}]0;owned\u{7}\u{1b}[2J name\0\r"),
            "shape \\u{1b}]0;owned\\u{7}\\u{1b}[2J name\\u{0}\\u{d}"
        );
        assert_eq!(safe("a\u{202e}b\u{9b}c"), "a\\u{202e}b\\u{9b}c");
        assert_eq!(safe("é ü 日本"), "é ü 日本");
    }
}
