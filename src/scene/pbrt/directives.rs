//! pbrt-v4's directives from its tokens: the name, its positional arguments (how many and
//! of what kind each directive takes) and its parameter list.

use super::params::{Located, Param, Values};
use super::tokens::{Pos, Tok};

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

/// A cursor over one file's tokens.
pub struct Parser {
    toks: Vec<(Tok, Pos)>,
    at: usize,
    /// Where the text ends, for "ran out" errors.
    end: Pos,
}

impl Parser {
    pub fn new(toks: Vec<(Tok, Pos)>, end: Pos) -> Parser {
        Parser { toks, at: 0, end }
    }

    fn peek(&self) -> Option<&(Tok, Pos)> {
        self.toks.get(self.at)
    }

    fn here(&self) -> Pos {
        self.peek().map_or(self.end, |t| t.1)
    }

    fn next(&mut self) -> Option<(Tok, Pos)> {
        let t = self.toks.get(self.at).cloned();
        self.at += 1;
        t
    }

    /// The next directive, or `None` at the end of the file.
    pub fn directive(&mut self) -> Result<Option<Directive>, Located> {
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
            let mut raw: Vec<(Tok, Pos)> = Vec::new();
            match self.next() {
                Some((Tok::Open, _)) => loop {
                    match self.next() {
                        Some((Tok::Close, _)) => break,
                        Some((t @ (Tok::Word(_) | Tok::Str(_)), p)) => raw.push((t, p)),
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
                Some((t @ (Tok::Word(_) | Tok::Str(_)), p)) => raw.push((t, p)),
                _ => return Err((pos, format!("{directive}: `{name}` has no value"))),
            }
            let values = if ty == "bool" {
                let mut v = Vec::new();
                for (t, p) in &raw {
                    match t {
                        Tok::Word(w) | Tok::Str(w) if w == "true" => v.push(true),
                        Tok::Word(w) | Tok::Str(w) if w == "false" => v.push(false),
                        _ => {
                            return Err((
                                *p,
                                format!("{directive}: `{name}` must be true or false"),
                            ))
                        }
                    }
                }
                Values::Bools(v)
            } else if raw.iter().all(|(t, _)| matches!(t, Tok::Str(_))) {
                Values::Strs(
                    raw.into_iter()
                        .map(|(t, _)| match t {
                            Tok::Str(s) => s,
                            _ => String::new(),
                        })
                        .collect(),
                )
            } else {
                let mut v = Vec::with_capacity(raw.len());
                for (t, p) in &raw {
                    match t {
                        Tok::Word(w) => match w.parse::<f64>() {
                            Ok(x) if x.is_finite() => v.push(x),
                            _ => {
                                return Err((
                                    *p,
                                    format!("{directive}: `{name}`: `{w}` is not a finite number"),
                                ))
                            }
                        },
                        _ => {
                            return Err((
                                *p,
                                format!("{directive}: `{name}` mixes strings and numbers"),
                            ))
                        }
                    }
                }
                Values::Nums(v)
            };
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
