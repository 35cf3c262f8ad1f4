//! pbrt-v4 parameter lists: `"type name" value` or `"type name" [ values ]`, each read at
//! most once by the directive that takes it; a parameter nobody read is an error.

use super::tokens::Pos;

/// An error at a place: (position, message).
pub type Located = (Pos, String);

#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    Nums(Vec<f64>),
    Strs(Vec<String>),
    Bools(Vec<bool>),
}

#[derive(Clone, Debug)]
pub struct Param {
    pub ty: String,
    pub name: String,
    pub values: Values,
    pub pos: Pos,
}

/// A colour-valued parameter as written.
#[derive(Clone, Debug, PartialEq)]
pub enum Colour {
    Rgb([f64; 3]),
    /// A named spectrum (`metal-Cu-eta`, `glass-BK7`, `stdillum-D65`) or a file.
    Named(String),
    /// `wavelength value` pairs.
    Sampled(Vec<(f64, f64)>),
    Blackbody(f64),
    /// A texture's name.
    Texture(String),
}

/// The types pbrt-v4 knows, with the kind of value each takes.
const NUMERIC: [&str; 13] = [
    "integer",
    "float",
    "point2",
    "vector2",
    "point3",
    "vector3",
    "normal3",
    "normal",
    "point",
    "vector",
    "color",
    "rgb",
    "blackbody",
];

/// A directive's parameters.
#[derive(Debug)]
pub struct ParamList {
    /// Where the directive is, for errors about a missing parameter.
    pub at: Pos,
    /// What the directive is (`Shape "sphere"`), for messages.
    pub what: String,
    params: Vec<(Param, bool)>,
}

impl ParamList {
    pub fn new(at: Pos, what: String, params: Vec<Param>) -> Result<ParamList, Located> {
        let mut seen = std::collections::HashSet::new();
        for p in &params {
            if !seen.insert(p.name.as_str()) {
                return Err((p.pos, format!("{what}: `{}` is given twice", p.name)));
            }
            let ok = match (&p.values, p.ty.as_str()) {
                (Values::Nums(_), t) => NUMERIC.contains(&t) || t == "spectrum",
                (Values::Strs(_), t) => matches!(t, "string" | "texture" | "spectrum"),
                (Values::Bools(_), t) => t == "bool",
            };
            if !ok {
                return Err((
                    p.pos,
                    format!(
                        "{what}: `{} {}` has values of the wrong kind (or `{}` is not a pbrt-v4 type)",
                        p.ty, p.name, p.ty
                    ),
                ));
            }
        }
        Ok(ParamList {
            at,
            what,
            params: params.into_iter().map(|p| (p, false)).collect(),
        })
    }

    /// The parameter `name`, marked as read.
    fn take(&mut self, name: &str) -> Option<Param> {
        let (p, used) = self.params.iter_mut().find(|(p, _)| p.name == name)?;
        *used = true;
        Some(p.clone())
    }

    fn wrong(&self, p: &Param, expected: &str) -> Located {
        (
            p.pos,
            format!(
                "{}: `{}` must be {expected}, not a `{}`",
                self.what, p.name, p.ty
            ),
        )
    }

    /// The numbers of `name` if its type is one of `types`.
    pub fn numbers(
        &mut self,
        name: &str,
        types: &[&str],
    ) -> Result<Option<(Vec<f64>, Pos)>, Located> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        match &p.values {
            Values::Nums(v) if types.contains(&p.ty.as_str()) => Ok(Some((v.clone(), p.pos))),
            _ => Err(self.wrong(&p, &format!("a `{}`", types.join("` or `")))),
        }
    }

    /// One number of type `ty` (`float` or `integer`).
    fn one(&mut self, name: &str, ty: &str) -> Result<Option<f64>, Located> {
        match self.numbers(name, &[ty])? {
            None => Ok(None),
            Some((v, _)) if v.len() == 1 => Ok(Some(v[0])),
            Some((v, pos)) => Err((
                pos,
                format!("{}: `{name}` takes one value, not {}", self.what, v.len()),
            )),
        }
    }

    pub fn float(&mut self, name: &str) -> Result<Option<f64>, Located> {
        self.one(name, "float")
    }

    pub fn integer(&mut self, name: &str) -> Result<Option<i64>, Located> {
        let pos = self
            .params
            .iter()
            .find(|(p, _)| p.name == name)
            .map(|(p, _)| p.pos);
        match self.one(name, "integer")? {
            None => Ok(None),
            Some(v) if v.fract() == 0.0 && v.abs() < 1e15 => Ok(Some(v as i64)),
            Some(v) => Err((
                pos.unwrap_or(self.at),
                format!("{}: `{name}` must be an integer, not {v}", self.what),
            )),
        }
    }

    pub fn boolean(&mut self, name: &str) -> Result<Option<bool>, Located> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        match &p.values {
            Values::Bools(v) if v.len() == 1 => Ok(Some(v[0])),
            _ => Err(self.wrong(&p, "one `bool`")),
        }
    }

    pub fn string(&mut self, name: &str) -> Result<Option<String>, Located> {
        Ok(self.string_at(name)?.map(|(s, _)| s))
    }

    /// A string with its place.
    pub fn string_at(&mut self, name: &str) -> Result<Option<(String, Pos)>, Located> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        match &p.values {
            Values::Strs(v) if v.len() == 1 && p.ty == "string" => Ok(Some((v[0].clone(), p.pos))),
            _ => Err(self.wrong(&p, "one `string`")),
        }
    }

    /// A point or vector (`point3`, `vector3`, `normal`, ...).
    pub fn point(&mut self, name: &str) -> Result<Option<[f64; 3]>, Located> {
        match self.numbers(
            name,
            &["point3", "point", "vector3", "vector", "normal3", "normal"],
        )? {
            None => Ok(None),
            Some((v, _)) if v.len() == 3 => Ok(Some([v[0], v[1], v[2]])),
            Some((v, pos)) => Err((
                pos,
                format!(
                    "{}: `{name}` takes three numbers, not {}",
                    self.what,
                    v.len()
                ),
            )),
        }
    }

    /// A colour: `rgb`, `spectrum`, `blackbody`, `texture`, or a `float` (grey).
    pub fn colour(&mut self, name: &str) -> Result<Option<(Colour, Pos)>, Located> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        let bad = |what: &str| (p.pos, format!("{}: `{}` {what}", self.what, p.name));
        let c = match (&p.values, p.ty.as_str()) {
            (Values::Nums(v), "rgb" | "color") if v.len() == 3 => Colour::Rgb([v[0], v[1], v[2]]),
            (Values::Nums(v), "float") if v.len() == 1 => Colour::Rgb([v[0]; 3]),
            (Values::Nums(v), "blackbody") if v.len() == 1 => Colour::Blackbody(v[0]),
            (Values::Nums(v), "spectrum") if v.len() >= 2 && v.len() % 2 == 0 => {
                Colour::Sampled(v.chunks(2).map(|c| (c[0], c[1])).collect())
            }
            (Values::Strs(v), "spectrum") if v.len() == 1 => Colour::Named(v[0].clone()),
            (Values::Strs(v), "texture") if v.len() == 1 => Colour::Texture(v[0].clone()),
            (_, "rgb" | "color") => return Err(bad("takes three numbers")),
            (_, "spectrum") => return Err(bad("takes a name, or pairs of wavelength and value")),
            (_, "float" | "blackbody") => return Err(bad("takes one number")),
            _ => return Err(self.wrong(&p, "a colour (`rgb`, `spectrum`, `blackbody`, `texture`)")),
        };
        Ok(Some((c, p.pos)))
    }

    /// A float or a float texture's name.
    pub fn float_or_texture(&mut self, name: &str) -> Result<Option<(Colour, Pos)>, Located> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        match (&p.values, p.ty.as_str()) {
            (Values::Nums(v), "float") if v.len() == 1 => Ok(Some((Colour::Rgb([v[0]; 3]), p.pos))),
            (Values::Strs(v), "texture") if v.len() == 1 => {
                Ok(Some((Colour::Texture(v[0].clone()), p.pos)))
            }
            _ => Err(self.wrong(&p, "one `float` or a `texture`")),
        }
    }

    /// Where parameter `name` is, if given (without reading it).
    pub fn present(&self, name: &str) -> Option<Pos> {
        self.params
            .iter()
            .find(|(p, _)| p.name == name)
            .map(|(p, _)| p.pos)
    }

    /// Marks `names` read: parameters that change nothing raylab computes.
    pub fn ignore(&mut self, names: &[&str]) {
        for name in names {
            self.take(name);
        }
    }

    /// The first parameter nobody read, as an error.
    pub fn finish(&self) -> Result<(), Located> {
        match self.params.iter().find(|(_, used)| !used) {
            None => Ok(()),
            Some((p, _)) => Err((
                p.pos,
                format!(
                    "{}: parameter `{} {}` is not supported",
                    self.what, p.ty, p.name
                ),
            )),
        }
    }
}
