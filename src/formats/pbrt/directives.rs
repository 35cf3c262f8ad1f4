//! pbrt-v4's directives from its tokens: the name, its positional arguments (how many and
//! of what kind each directive takes) and its parameter list.

use super::params::{Located, Param, Values};
use super::tokens::{Pos, Tok, Tokens};

/// One directive as written.
#[derive(Debug)]
pub struct Directive {
    pub name: String,
    pub pos: Pos,
    /// Quoted positional arguments (`Shape "sphere"`: `["sphere"]`).
    pub strings: Vec<String>,
    /// Numeric positional arguments (`Translate 1 2 3`), with brackets or without.
    pub numbers: Vec<f64>,
    pub params: Vec<Param>,
}

/// What a directive takes after its name.
enum Takes {
    Nothing,
    /// `n` numbers, bracketed or not.
    Numbers(usize),
    /// `n` strings, then a parameter list if `params`.
    Strings(usize, bool),
    /// One or two strings (`MediumInterface`).
    OneOrTwoStrings,
    /// A bare word (`ActiveTransform All`).
    Word,
}

fn takes(name: &str) -> Option<Takes> {
    use Takes::*;
    Some(match name {
        "AttributeBegin" | "AttributeEnd" | "TransformBegin" | "TransformEnd" | "WorldBegin"
        | "WorldEnd" | "ReverseOrientation" | "ObjectEnd" | "Identity" => Nothing,
        "Translate" | "Scale" => Numbers(3),
        "Rotate" => Numbers(4),
        "LookAt" => Numbers(9),
        "Transform" | "ConcatTransform" => Numbers(16),
        "TransformTimes" => Numbers(2),
        "Shape" | "Material" | "Camera" | "Film" | "Sampler" | "PixelFilter" | "Integrator"
        | "Accelerator" | "LightSource" | "AreaLightSource" | "MakeNamedMaterial"
        | "MakeNamedMedium" | "Attribute" | "ColorSpace" => Strings(1, true),
        "NamedMaterial" | "ObjectBegin" | "ObjectInstance" | "Include" | "Import"
        | "CoordinateSystem" | "CoordSysTransform" => Strings(1, false),
        "Texture" => Strings(3, true),
        // `Option "bool name" value`: one parameter and nothing before it.
        "Option" => Strings(0, true),
        "MediumInterface" => OneOrTwoStrings,
        "ActiveTransform" => Word,
        _ => return None,
    })
}

/// A cursor over one file's tokens, read as they are needed with one token of lookahead.
pub struct Parser<'a> {
    tokens: Tokens<'a>,
    /// The next token, once looked at.
    ahead: Option<(Tok, Pos)>,
    /// A malformed token met: the text ends there for the parser, and the error is the
    /// directive's.
    malformed: Option<(Pos, String)>,
    /// Where the text ends, for "ran out" errors.
    end: Pos,
}

impl<'a> Parser<'a> {
    pub fn new(tokens: Tokens<'a>, end: Pos) -> Parser<'a> {
        Parser {
            tokens,
            ahead: None,
            malformed: None,
            end,
        }
    }

    fn fill(&mut self) {
        if self.ahead.is_none() && self.malformed.is_none() {
            match self.tokens.next() {
                Some(Ok(t)) => self.ahead = Some(t),
                Some(Err(e)) => self.malformed = Some(e),
                None => {}
            }
        }
    }

    fn peek(&mut self) -> Option<&(Tok, Pos)> {
        self.fill();
        self.ahead.as_ref()
    }

    fn here(&mut self) -> Pos {
        let end = self.end;
        self.peek().map_or(end, |t| t.1)
    }

    fn next(&mut self) -> Option<(Tok, Pos)> {
        self.fill();
        self.ahead.take()
    }

    /// The next directive, or `None` at the end of the file; a malformed token on the way is
    /// the error, wherever the directive's own reading stopped.
    pub fn directive(&mut self) -> Result<Option<Directive>, Located> {
        let d = self.read_directive();
        match self.malformed.take() {
            Some(e) => Err(e),
            None => d,
        }
    }

    fn read_directive(&mut self) -> Result<Option<Directive>, Located> {
        let Some((tok, pos)) = self.next() else {
            return Ok(None);
        };
        let name = match tok {
            Tok::Word(w) => w,
            Tok::Str(s) => {
                return Err((pos, format!("expected a directive, found the string \"{s}\" (a parameter outside a directive's list?)")))
            }
            Tok::Open | Tok::Close => {
                return Err((pos, "expected a directive, found a bracket".into()))
            }
        };
        let Some(takes) = takes(&name) else {
            let hint = if name.parse::<f64>().is_ok() {
                " (a number outside a directive's arguments?)"
            } else {
                ""
            };
            return Err((pos, format!("unknown directive `{name}`{hint}")));
        };
        let mut d = Directive {
            name,
            pos,
            strings: Vec::new(),
            numbers: Vec::new(),
            params: Vec::new(),
        };
        match takes {
            Takes::Nothing => {}
            Takes::Numbers(n) => {
                let bracketed = matches!(self.peek(), Some((Tok::Open, _)));
                if bracketed {
                    self.next();
                }
                while d.numbers.len() < n || bracketed {
                    match self.peek() {
                        Some((Tok::Close, _)) if bracketed => {
                            self.next();
                            break;
                        }
                        Some((Tok::Word(w), p)) => match w.parse::<f64>() {
                            Ok(v) if v.is_finite() => {
                                d.numbers.push(v);
                                self.next();
                            }
                            Err(_) if !bracketed => break,
                            _ => {
                                return Err((
                                    *p,
                                    format!("{}: `{w}` is not a finite number", d.name),
                                ))
                            }
                        },
                        _ if bracketed => {
                            return Err((
                                self.here(),
                                format!("{}: the `[` is not closed by `]`", d.name),
                            ))
                        }
                        _ => break,
                    }
                }
                if d.numbers.len() != n {
                    return Err((
                        pos,
                        format!("{} takes {n} numbers, got {}", d.name, d.numbers.len()),
                    ));
                }
            }
            Takes::Strings(n, params) => {
                for _ in 0..n {
                    match self.next() {
                        Some((Tok::Str(s), _)) => d.strings.push(s),
                        _ => {
                            return Err((
                                pos,
                                format!(
                                    "{} takes {n} quoted string{} first",
                                    d.name,
                                    if n == 1 { "" } else { "s" }
                                ),
                            ))
                        }
                    }
                }
                if params {
                    d.params = self.params(&d.name)?;
                }
                if d.name == "Option" && d.params.len() != 1 {
                    return Err((pos, "Option takes one `\"type name\" value`".into()));
                }
            }
            Takes::OneOrTwoStrings => {
                while d.strings.len() < 2 {
                    match self.peek() {
                        Some((Tok::Str(s), _)) => {
                            d.strings.push(s.clone());
                            self.next();
                        }
                        _ => break,
                    }
                }
                if d.strings.is_empty() {
                    return Err((pos, format!("{} takes one or two quoted names", d.name)));
                }
            }
            Takes::Word => match self.next() {
                Some((Tok::Word(w), _)) => d.strings.push(w),
                _ => return Err((pos, format!("{} takes StartTime, EndTime or All", d.name))),
            },
        }
        Ok(Some(d))
    }

    /// `"type name" value-or-[values]` pairs up to the next directive.
    fn params(&mut self, directive: &str) -> Result<Vec<Param>, Located> {
        let mut out = Vec::new();
        while let Some((Tok::Str(decl), pos)) = self.peek().cloned() {
            self.next();
            let mut words = decl.split_whitespace();
            let (Some(ty), Some(name), None) = (words.next(), words.next(), words.next()) else {
                return Err((
                    pos,
                    format!("{directive}: \"{decl}\" is not a parameter's \"type name\""),
                ));
            };
            // The values as they come (a list may hold millions of numbers: each is read
            // into its f64 at once, not held as a token).
            let mut list = ValueList::new(directive, name, ty == "bool");
            match self.next() {
                Some((Tok::Open, _)) => loop {
                    match self.next() {
                        Some((Tok::Close, _)) => break,
                        Some((t @ (Tok::Word(_) | Tok::Str(_)), p)) => list.push(t, p)?,
                        Some((Tok::Open, p)) => {
                            return Err((p, format!("{directive}: `{name}`: a `[` inside a list")))
                        }
                        None => {
                            return Err((
                                pos,
                                format!("{directive}: `{name}`: the `[` is not closed by `]`"),
                            ))
                        }
                    }
                },
                Some((t @ (Tok::Word(_) | Tok::Str(_)), p)) => list.push(t, p)?,
                _ => return Err((pos, format!("{directive}: `{name}` has no value"))),
            }
            let values = list.values();
            if matches!(&values, Values::Nums(v) if v.is_empty()) {
                return Err((pos, format!("{directive}: `{name}` has no value")));
            }
            out.push(Param {
                ty: ty.to_string(),
                name: name.to_string(),
                values,
                pos,
            });
        }
        Ok(out)
    }
}

/// A parameter's values as they are read: booleans for a `bool`, else all strings or all
/// numbers.
struct ValueList<'d> {
    directive: &'d str,
    name: &'d str,
    boolean: bool,
    bools: Vec<bool>,
    strs: Vec<String>,
    nums: Vec<f64>,
}

impl<'d> ValueList<'d> {
    fn new(directive: &'d str, name: &'d str, boolean: bool) -> Self {
        ValueList {
            directive,
            name,
            boolean,
            bools: Vec::new(),
            strs: Vec::new(),
            nums: Vec::new(),
        }
    }

    fn push(&mut self, t: Tok, p: Pos) -> Result<(), Located> {
        let (directive, name) = (self.directive, self.name);
        if self.boolean {
            match t {
                Tok::Word(w) | Tok::Str(w) if w == "true" => self.bools.push(true),
                Tok::Word(w) | Tok::Str(w) if w == "false" => self.bools.push(false),
                _ => return Err((p, format!("{directive}: `{name}` must be true or false"))),
            }
            return Ok(());
        }
        let mixes = || {
            (
                p,
                format!("{directive}: `{name}` mixes strings and numbers"),
            )
        };
        match t {
            Tok::Str(s) if self.nums.is_empty() => self.strs.push(s),
            Tok::Word(w) if self.strs.is_empty() => match w.parse::<f64>() {
                Ok(x) if x.is_finite() => self.nums.push(x),
                _ => {
                    return Err((
                        p,
                        format!("{directive}: `{name}`: `{w}` is not a finite number"),
                    ))
                }
            },
            _ => return Err(mixes()),
        }
        Ok(())
    }

    fn values(self) -> Values {
        if self.boolean {
            Values::Bools(self.bools)
        } else if !self.strs.is_empty() {
            Values::Strs(self.strs)
        } else {
            Values::Nums(self.nums)
        }
    }
}
