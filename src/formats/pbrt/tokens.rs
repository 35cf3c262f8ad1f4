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
#[cfg(test)]
pub fn tokenize(text: &str, file: usize) -> Result<Vec<(Tok, Pos)>, (Pos, String)> {
    Tokens::new(text, file).collect()
}

/// The tokens of one file's text, one at a time (a scene's number lists run to millions of
/// tokens: none is held longer than the parser needs it).
pub struct Tokens<'a> {
    chars: std::iter::Peekable<std::str::Chars<'a>>,
    file: usize,
    line: u32,
    col: u32,
    /// Whether an error was given: nothing follows it.
    failed: bool,
}

impl<'a> Tokens<'a> {
    pub fn new(text: &'a str, file: usize) -> Tokens<'a> {
        Tokens {
            chars: text.chars().peekable(),
            file,
            line: 1,
            col: 1,
            failed: false,
        }
    }

    fn advance(&mut self, c: char) {
        if c == '\n' {
            self.line += 1;
            self.col = 1;
        } else {
            self.col += 1;
        }
    }

    /// The next token, `None` at the end, or the malformed one's place and what is wrong.
    fn token(&mut self) -> Option<Result<(Tok, Pos), (Pos, String)>> {
        loop {
            let &c = self.chars.peek()?;
            let pos = Pos {
                file: self.file,
                line: self.line,
                col: self.col,
            };
            match c {
                c if c.is_whitespace() => {
                    self.chars.next();
                    self.advance(c);
                }
                '#' => {
                    while let Some(&c) = self.chars.peek() {
                        if c == '\n' {
                            break;
                        }
                        self.chars.next();
                        self.advance(c);
                    }
                }
                '[' | ']' => {
                    self.chars.next();
                    self.advance(c);
                    return Some(Ok((if c == '[' { Tok::Open } else { Tok::Close }, pos)));
                }
                '"' => {
                    self.chars.next();
                    self.advance(c);
                    return Some(self.string(pos).map(|s| (Tok::Str(s), pos)));
                }
                _ => {
                    let mut w = String::new();
                    while let Some(&c) = self.chars.peek() {
                        if c.is_whitespace() || matches!(c, '"' | '[' | ']' | '#') {
                            break;
                        }
                        w.push(c);
                        self.chars.next();
                        self.advance(c);
                    }
                    return Some(Ok((Tok::Word(w), pos)));
                }
            }
        }
    }

    /// The rest of a quoted string that started at `pos`, escapes resolved.
    fn string(&mut self, pos: Pos) -> Result<String, (Pos, String)> {
        let mut s = String::new();
        loop {
            let Some(c) = self.chars.next() else {
                return Err((pos, "a string is not closed (no ending `\"`)".into()));
            };
            self.advance(c);
            match c {
                '"' => return Ok(s),
                '\n' => return Err((pos, "a string runs past the end of its line".into())),
                '\\' => {
                    let escape = Pos {
                        file: self.file,
                        line: self.line,
                        col: self.col - 1,
                    };
                    let Some(e) = self.chars.next() else {
                        return Err((pos, "a string is not closed (no ending `\"`)".into()));
                    };
                    self.advance(e);
                    s.push(match e {
                        'n' => '\n',
                        't' => '\t',
                        'b' => '\u{8}',
                        'f' => '\u{c}',
                        'r' => '\r',
                        '\\' | '\'' | '"' => e,
                        _ => return Err((escape, format!("unknown escape `\\{e}` in a string"))),
                    });
                }
                c => s.push(c),
            }
        }
    }
}

impl Iterator for Tokens<'_> {
    type Item = Result<(Tok, Pos), (Pos, String)>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        let t = self.token();
        self.failed = matches!(t, Some(Err(_)));
        t
    }
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
