//! pbrt-v4's tokens: bare words (directives, numbers, `true`/`false`), quoted strings,
//! brackets; `#` starts a comment to the end of the line. Each token keeps its file, line and
//! column for messages.

/// Where a token starts: file index (into the importer's file list), line and column from 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pos {
    pub file: usize,
    pub line: u32,
    pub col: u32,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Tok {
    /// A bare word: a directive name, a number, `true`, `false`.
    Word(String),
    /// A quoted string, escapes resolved.
    Str(String),
    Open,
    Close,
}

/// The tokens of one file's `text`, or the first malformed one: (position, message).
pub fn tokenize(text: &str, file: usize) -> Result<Vec<(Tok, Pos)>, (Pos, String)> {
    let mut out = Vec::new();
    let (mut line, mut col) = (1u32, 1u32);
    let mut chars = text.chars().peekable();
    while let Some(&c) = chars.peek() {
        let pos = Pos { file, line, col };
        let advance = |c: char, line: &mut u32, col: &mut u32| {
            if c == '\n' {
                *line += 1;
                *col = 1;
            } else {
                *col += 1;
            }
        };
        match c {
            c if c.is_whitespace() => {
                chars.next();
                advance(c, &mut line, &mut col);
            }
            '#' => {
                while let Some(&c) = chars.peek() {
                    if c == '\n' {
                        break;
                    }
                    chars.next();
                    advance(c, &mut line, &mut col);
                }
            }
            '[' | ']' => {
                chars.next();
                advance(c, &mut line, &mut col);
                out.push((if c == '[' { Tok::Open } else { Tok::Close }, pos));
            }
            '"' => {
                chars.next();
                advance(c, &mut line, &mut col);
                let mut s = String::new();
                loop {
                    let Some(c) = chars.next() else {
                        return Err((pos, "a string is not closed (no ending `\"`)".into()));
                    };
                    advance(c, &mut line, &mut col);
                    match c {
                        '"' => break,
                        '\n' => return Err((pos, "a string runs past the end of its line".into())),
                        '\\' => {
                            let escape = Pos {
                                file,
                                line,
                                col: col - 1,
                            };
                            let Some(e) = chars.next() else {
                                return Err((
                                    pos,
                                    "a string is not closed (no ending `\"`)".into(),
                                ));
                            };
                            advance(e, &mut line, &mut col);
                            s.push(match e {
                                'n' => '\n',
                                't' => '\t',
                                'b' => '\u{8}',
                                'f' => '\u{c}',
                                'r' => '\r',
                                '\\' | '\'' | '"' => e,
                                _ => {
                                    return Err((
                                        escape,
                                        format!("unknown escape `\\{e}` in a string"),
                                    ))
                                }
                            });
                        }
                        c => s.push(c),
                    }
                }
                out.push((Tok::Str(s), pos));
            }
            _ => {
                let mut w = String::new();
                while let Some(&c) = chars.peek() {
                    if c.is_whitespace() || matches!(c, '"' | '[' | ']' | '#') {
                        break;
                    }
                    w.push(c);
                    chars.next();
                    advance(c, &mut line, &mut col);
                }
                out.push((Tok::Word(w), pos));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_strings_brackets_and_comments_with_their_places() {
        let toks = tokenize(
            "Shape \"sphere\" # a ball\n  \"float radius\" [ 2.5 ]\n\"a\\\"b\"",
            3,
        )
        .unwrap();
        let kinds: Vec<_> = toks.iter().map(|(t, _)| t.clone()).collect();
        assert_eq!(
            kinds,
            vec![
                Tok::Word("Shape".into()),
                Tok::Str("sphere".into()),
                Tok::Str("float radius".into()),
                Tok::Open,
                Tok::Word("2.5".into()),
                Tok::Close,
                Tok::Str("a\"b".into()),
            ]
        );
        assert_eq!(
            toks[2].1,
            Pos {
                file: 3,
                line: 2,
                col: 3
            }
        );
        assert_eq!(
            toks[4].1,
            Pos {
                file: 3,
                line: 2,
                col: 20
            }
        );
    }

    #[test]
    fn unclosed_strings_and_bad_escapes_are_located() {
        let (pos, msg) = tokenize("Shape \"sph", 0).unwrap_err();
        assert_eq!((pos.line, pos.col), (1, 7));
        assert!(msg.contains("not closed"), "{msg}");
        let (pos, msg) = tokenize("\n \"a\\q\"", 0).unwrap_err();
        assert_eq!((pos.line, pos.col), (2, 4));
        assert!(msg.contains("`\\q`"), "{msg}");
    }
}
