//! The XML side: elements with their line and column, `$name` substitution from `<default>`s
//! and `-D` overrides, and typed property values.

use glam::{Affine3A, DAffine3, DMat3, DVec3, Vec3A};
use roxmltree::{Document, Node};
use std::collections::HashMap;

/// An error at a place in the file: (line, column, message).
pub type Located = (u32, u32, String);

/// Where `node` starts, as (line, column) from 1.
/// The most attributes one element may have (Mitsuba's have at most four or five; the XML
/// parser checks each new one against those before it, so 100,000 would take half a minute).
pub const MAX_ATTRIBUTES: usize = 256;

/// Refuses, before the XML parser sees it, text with an element of more than
/// [`MAX_ATTRIBUTES`] attributes: its line and column. (A scan of the tags alone: comments,
/// CDATA sections, processing instructions and declarations are skipped, quoted values are
/// not counted.)
pub fn check_attributes(text: &str) -> Result<(), Located> {
    let bytes = text.as_bytes();
    let skip_to = |from: usize, end: &[u8]| -> usize {
        bytes[from..]
            .windows(end.len())
            .position(|w| w == end)
            .map_or(bytes.len(), |p| from + p + end.len())
    };
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] != b'<' {
            i += 1;
            continue;
        }
        let rest = &bytes[i..];
        if rest.starts_with(b"<!--") {
            i = skip_to(i + 4, b"-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i = skip_to(i + 9, b"]]>");
        } else if rest.starts_with(b"<?") {
            i = skip_to(i + 2, b"?>");
        } else if rest.starts_with(b"<!") {
            i = skip_to(i + 2, b">");
        } else {
            let start = i;
            let (mut count, mut quote) = (0usize, None);
            i += 1;
            while i < bytes.len() {
                let b = bytes[i];
                match quote {
                    Some(q) if b == q => quote = None,
                    Some(_) => {}
                    None if b == b'"' || b == b'\'' => quote = Some(b),
                    None if b == b'=' => count += 1,
                    None if b == b'>' => break,
                    None => {}
                }
                i += 1;
            }
            if count > MAX_ATTRIBUTES {
                let before = &text[..start];
                let line = before.matches('\n').count() as u32 + 1;
                let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) as u32 + 1;
                return Err((
                    line,
                    col,
                    format!("an element with {count} attributes, more than the {MAX_ATTRIBUTES} raylab reads"),
                ));
            }
        }
    }
    Ok(())
}

pub fn position(doc: &Document, node: Node) -> (u32, u32) {
    let p = doc.text_pos_at(node.range().start);
    (p.row, p.col)
}

/// The substitutions in force: `<default>` values, overridden by `-D` ones.
pub struct Params {
    values: HashMap<String, String>,
    overridden: HashMap<String, String>,
    /// The scene is Mitsuba 0.x's: property names are read through Mitsuba 3's upgrade
    /// (camelCase to snake_case, `<lookAt>`, diffuse's `diffuse_reflectance`, `uscale`...).
    pub legacy: bool,
}

impl Params {
    pub fn new(overrides: &[(String, String)]) -> Params {
        Params {
            values: HashMap::new(),
            overridden: overrides.iter().cloned().collect(),
            legacy: false,
        }
    }

    /// Records a `<default name value>` (a `-D` of the same name wins).
    pub fn default(&mut self, name: &str, value: &str) {
        self.values.insert(name.to_string(), value.to_string());
    }

    /// `text` with every `$name` replaced by its value; an unknown name is an error.
    pub fn substitute(&self, text: &str) -> Result<String, String> {
        let mut out = String::with_capacity(text.len());
        let mut rest = text;
        while let Some(at) = rest.find('$') {
            out.push_str(&rest[..at]);
            let after = &rest[at + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..len];
            if name.is_empty() {
                return Err(format!("`$` without a parameter name in {text:?}"));
            }
            let value = self
                .overridden
                .get(name)
                .or_else(|| self.values.get(name))
                .ok_or_else(|| {
                    format!(
                        "parameter `${name}` has no value: give it a <default> or -D {name}=..."
                    )
                })?;
            out.push_str(value);
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// One attribute of `node`, substituted; `None` when absent.
pub fn attr(
    params: &Params,
    doc: &Document,
    node: Node,
    name: &str,
) -> Result<Option<String>, Located> {
    node.attribute(name)
        .map(|v| params.substitute(v).map_err(|e| at(doc, node, e)))
        .transpose()
}

/// The major version of a `<scene version="X.Y.Z">` (Mitsuba's file versions); `None` when
/// the attribute is absent.
pub fn major_version(doc: &Document, scene: Node) -> Result<Option<u32>, Located> {
    let Some(v) = scene.attribute("version") else {
        return Ok(None);
    };
    let parts: Option<Vec<u32>> = v.split('.').map(|p| p.trim().parse().ok()).collect();
    match parts.as_deref() {
        Some([major, ..]) if v.split('.').count() <= 3 => Ok(Some(*major)),
        _ => Err(at(
            doc,
            scene,
            format!("could not read the version number {v:?} (as \"3.0.0\")"),
        )),
    }
}

/// Mitsuba 3's upgrade of a 0.x property name: each lower-case letter followed by capitals
/// gets an underscore and the capitals become lower case (`maxDepth` is `max_depth`,
/// `intIOR` is `int_ior`).
pub fn snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        out.push(chars[i]);
        if chars[i].is_ascii_lowercase() && chars.get(i + 1).is_some_and(char::is_ascii_uppercase) {
            out.push('_');
            i += 1;
            while let Some(c) = chars.get(i).filter(|c| c.is_ascii_uppercase()) {
                out.push(c.to_ascii_lowercase());
                i += 1;
            }
            continue;
        }
        i += 1;
    }
    out
}

/// An error at `node`.
pub fn at(doc: &Document, node: Node, message: impl Into<String>) -> Located {
    let (line, col) = position(doc, node);
    (line, col, message.into())
}

/// Numbers separated by commas and/or whitespace.
pub fn numbers(text: &str) -> Result<Vec<f32>, String> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("`{s}` is not a finite number"))
        })
        .collect()
}

/// A typed property value.
#[derive(Clone, Debug)]
pub enum Value {
    Float(f32),
    Integer(i64),
    Boolean(bool),
    String(String),
    /// `rgb`, `point` or `vector`.
    Vector([f32; 3]),
    /// A uniform `spectrum` (one number).
    Uniform(f32),
    /// A `spectrum` as `wavelength:value` pairs (nm).
    Spectrum(Vec<(f64, f64)>),
    /// A `spectrum` read from a file (`filename`), as the converter reads it (it has the
    /// scene's files).
    SpectrumFile(String),
    Transform(Affine3A),
}

/// A vector from `x`, `y`, `z` attributes (missing ones 0) or a `value` of one or three
/// numbers.
fn xyz(params: &Params, doc: &Document, node: Node, default: f32) -> Result<[f32; 3], Located> {
    if let Some(v) = attr(params, doc, node, "value")? {
        let n = numbers(&v).map_err(|e| at(doc, node, e))?;
        return match n.len() {
            1 => Ok([n[0]; 3]),
            3 => Ok([n[0], n[1], n[2]]),
            k => Err(at(doc, node, format!("expected 1 or 3 numbers, got {k}"))),
        };
    }
    let mut out = [default; 3];
    for (i, name) in ["x", "y", "z"].iter().enumerate() {
        if let Some(v) = attr(params, doc, node, name)? {
            out[i] = numbers(&v)
                .ok()
                .and_then(|n| (n.len() == 1).then(|| n[0]))
                .ok_or_else(|| at(doc, node, format!("`{name}`: `{v}` is not a number")))?;
        }
    }
    Ok(out)
}

/// The value of a property element (`<float name="..." value="..."/>`, ...).
pub fn value(params: &Params, doc: &Document, node: Node) -> Result<Value, Located> {
    let tag = node.tag_name().name();
    let text = |name: &str| -> Result<String, Located> {
        attr(params, doc, node, name)?
            .ok_or_else(|| at(doc, node, format!("<{tag}> needs `{name}`")))
    };
    Ok(match tag {
        "float" => {
            let v = text("value")?;
            let n = numbers(&v).map_err(|e| at(doc, node, e))?;
            match n[..] {
                [x] => Value::Float(x),
                _ => {
                    return Err(at(
                        doc,
                        node,
                        format!("<float> takes one number, got `{v}`"),
                    ))
                }
            }
        }
        "integer" => {
            let v = text("value")?;
            Value::Integer(
                v.trim()
                    .parse()
                    .map_err(|_| at(doc, node, format!("`{v}` is not an integer")))?,
            )
        }
        "boolean" => {
            let v = text("value")?;
            Value::Boolean(match v.trim() {
                "true" => true,
                "false" => false,
                _ => return Err(at(doc, node, format!("`{v}` is not `true` or `false`"))),
            })
        }
        "string" => Value::String(text("value")?),
        "rgb" => {
            let v = text("value")?;
            let n = numbers(&v).map_err(|e| at(doc, node, e))?;
            match n[..] {
                [x] => Value::Vector([x; 3]),
                [r, g, b] => Value::Vector([r, g, b]),
                _ => {
                    return Err(at(
                        doc,
                        node,
                        format!("<rgb> takes 1 or 3 numbers, got `{v}`"),
                    ))
                }
            }
        }
        "spectrum" => {
            if node.attribute("filename").is_some() {
                if node.attribute("value").is_some() {
                    return Err(at(
                        doc,
                        node,
                        "<spectrum>: give `value` or `filename`, not both",
                    ));
                }
                return Ok(Value::SpectrumFile(text("filename")?));
            }
            let v = text("value")?;
            if !v.contains(':') {
                match numbers(&v).ok().as_deref() {
                    Some([x]) => Value::Uniform(*x),
                    _ => {
                        return Err(at(
                            doc,
                            node,
                            format!(
                                "<spectrum value=\"{v}\">: one number, or wavelength:value pairs"
                            ),
                        ))
                    }
                }
            } else {
                let mut pairs = Vec::new();
                for entry in v
                    .split(|c: char| c == ',' || c.is_whitespace())
                    .filter(|e| !e.is_empty())
                {
                    let pair = entry.split_once(':').and_then(|(w, x)| {
                        Some((w.trim().parse::<f64>().ok()?, x.trim().parse::<f64>().ok()?))
                    });
                    match pair {
                        Some(p) if p.0.is_finite() && p.1.is_finite() => pairs.push(p),
                        _ => {
                            return Err(at(
                                doc,
                                node,
                                format!("<spectrum>: `{entry}` is not a wavelength:value pair"),
                            ))
                        }
                    }
                }
                Value::Spectrum(pairs)
            }
        }
        "point" | "vector" => Value::Vector(xyz(params, doc, node, 0.0)?),
        "transform" => Value::Transform(transform(params, doc, node)?),
        _ => return Err(at(doc, node, format!("unknown property type <{tag}>"))),
    })
}

/// A `<transform>`: its operations applied in order (each after the ones before), composed in
/// double precision as Mitsuba does, so that a rotation by 90 degrees leaves exact zeros.
pub fn transform(params: &Params, doc: &Document, node: Node) -> Result<Affine3A, Located> {
    let d = |v: [f32; 3]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
    let one = |op: Node, name: &str| -> Result<f64, Located> {
        let v = attr(params, doc, op, name)?.ok_or_else(|| {
            at(
                doc,
                op,
                format!("<{}> needs `{name}`", op.tag_name().name()),
            )
        })?;
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| at(doc, op, format!("`{name}`: `{v}` is not a finite number")))
    };
    let mut m = DAffine3::IDENTITY;
    for op in node.children().filter(Node::is_element) {
        let step = match op.tag_name().name() {
            "translate" => DAffine3::from_translation(d(xyz(params, doc, op, 0.0)?)),
            "scale" => DAffine3::from_scale(d(xyz(params, doc, op, 1.0)?)),
            "rotate" => {
                let axis = d(xyz(params, doc, op, 0.0)?);
                let angle = one(op, "angle")?;
                if axis.length_squared() == 0.0 {
                    return Err(at(doc, op, "<rotate> needs a non-zero axis"));
                }
                DAffine3::from_axis_angle(axis.normalize(), angle.to_radians())
            }
            "matrix" => {
                let v = attr(params, doc, op, "value")?
                    .ok_or_else(|| at(doc, op, "<matrix> needs `value`"))?;
                let n = numbers(&v).map_err(|e| at(doc, op, e))?;
                let n: Vec<f64> = n.into_iter().map(f64::from).collect();
                let cols = match n.len() {
                    16 if n[12..] == [0.0, 0.0, 0.0, 1.0] => 4,
                    16 => {
                        return Err(at(
                            doc,
                            op,
                            "<matrix>: a projective last row is not supported",
                        ))
                    }
                    9 => 3,
                    k => {
                        return Err(at(
                            doc,
                            op,
                            format!("<matrix> takes 16 (or 9) numbers, got {k}"),
                        ))
                    }
                };
                let e = |r: usize, c: usize| if c < cols { n[cols * r + c] } else { 0.0 };
                let col = |c: usize| DVec3::new(e(0, c), e(1, c), e(2, c));
                DAffine3::from_cols(col(0), col(1), col(2), col(3))
            }
            "lookat" | "lookAt" if op.tag_name().name() == "lookat" || params.legacy => {
                let get = |name: &str| -> Result<DVec3, Located> {
                    let v = attr(params, doc, op, name)?
                        .ok_or_else(|| at(doc, op, format!("<lookat> needs `{name}`")))?;
                    match numbers(&v).map_err(|e| at(doc, op, e))?[..] {
                        [x, y, z] => Ok(d([x, y, z])),
                        _ => Err(at(doc, op, format!("`{name}` takes 3 numbers, got `{v}`"))),
                    }
                };
                let origin = get("origin")?;
                let target = get("target")?;
                let up = match attr(params, doc, op, "up")? {
                    Some(_) => get("up")?,
                    None => DVec3::Y,
                };
                // Mitsuba's look_at: z towards the target, x = up x z (to the left), y = z x x.
                let dir = (target - origin).normalize_or_zero();
                let left = up.normalize_or_zero().cross(dir).normalize_or_zero();
                if dir == DVec3::ZERO || left == DVec3::ZERO {
                    return Err(at(
                        doc,
                        op,
                        "<lookat>: the target is the origin, or up is along the view",
                    ));
                }
                let new_up = dir.cross(left);
                DAffine3::from_mat3_translation(DMat3::from_cols(left, new_up, dir), origin)
            }
            other => {
                return Err(at(
                    doc,
                    op,
                    format!("unknown transform operation <{other}>"),
                ))
            }
        };
        m = step * m;
    }
    // In single precision, with what double precision left of exact zeros made zero.
    let f = |v: DVec3| {
        let snap = |x: f64| if x.abs() < 1e-12 { 0.0 } else { x as f32 };
        Vec3A::new(snap(v.x), snap(v.y), snap(v.z))
    };
    Ok(Affine3A::from_cols(
        f(m.matrix3.x_axis),
        f(m.matrix3.y_axis),
        f(m.matrix3.z_axis),
        f(m.translation),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(doc: &str, f: impl FnOnce(&Document, Node)) {
        let d = Document::parse(doc).unwrap();
        f(&d, d.root_element());
    }

    #[test]
    fn parameters_are_substituted_and_overridden() {
        let mut p = Params::new(&[("spp".into(), "64".into())]);
        p.default("spp", "4");
        p.default("res", "128");
        assert_eq!(p.substitute("$spp x $res$res").unwrap(), "64 x 128128");
        assert_eq!(p.substitute("no dollars").unwrap(), "no dollars");
        assert!(p
            .substitute("$missing")
            .unwrap_err()
            .contains("`$missing` has no value"));
        assert!(p
            .substitute("a $ b")
            .unwrap_err()
            .contains("without a parameter name"));
    }

    #[test]
    fn transform_operations_apply_in_order() {
        with(
            r#"<transform name="to_world"><scale value="2"/><rotate y="1" angle="90"/><translate x="1" y="2" z="3"/></transform>"#,
            |d, n| {
                let m = transform(&Params::new(&[]), d, n).unwrap();
                // (1, 0, 0) -> scaled (2, 0, 0) -> about y by 90 degrees (0, 0, -2) -> (1, 2, 1).
                let p = m.transform_point3a(Vec3A::X);
                assert!((p - Vec3A::new(1.0, 2.0, 1.0)).length() < 1e-6, "{p}");
                // Exact zeros where double precision leaves 6e-17.
                assert_eq!(m.matrix3.x_axis.x, 0.0);
            },
        );
        with(
            r#"<transform name="t"><matrix value="1 0 0 5  0 2 0 6  0 0 3 7  0 0 0 1"/><translate x="1"/></transform>"#,
            |d, n| {
                let m = transform(&Params::new(&[]), d, n).unwrap();
                assert_eq!(m.transform_point3a(Vec3A::ONE), Vec3A::new(7.0, 8.0, 10.0));
            },
        );
    }

    #[test]
    fn lookat_is_mitsubas_frame() {
        // z towards the target, x = up x z (the image's left), y the up made orthogonal.
        with(
            r#"<transform name="t"><lookat origin="1, 2, 3" target="1, 2, 0" up="0, 1, 0"/></transform>"#,
            |d, n| {
                let m = transform(&Params::new(&[]), d, n).unwrap();
                assert_eq!(m.translation, Vec3A::new(1.0, 2.0, 3.0));
                assert_eq!(m.matrix3.z_axis, -Vec3A::Z);
                assert_eq!(m.matrix3.x_axis, -Vec3A::X);
                assert_eq!(m.matrix3.y_axis, Vec3A::Y);
            },
        );
    }

    #[test]
    fn bad_values_are_located() {
        with(r#"<scene><float name="x" value="1 2"/></scene>"#, |d, n| {
            let e = value(&Params::new(&[]), d, n.first_element_child().unwrap()).unwrap_err();
            assert_eq!((e.0, e.1), (1, 8));
            assert!(e.2.contains("takes one number"), "{e:?}");
        });
        with(
            r#"<scene><spectrum name="x" value="400:1, 700:nan"/></scene>"#,
            |d, n| {
                let e = value(&Params::new(&[]), d, n.first_element_child().unwrap()).unwrap_err();
                assert!(e.2.contains("is not a wavelength:value pair"), "{e:?}");
            },
        );
        with(
            r#"<scene><spectrum name="x" value="400:1, 700:2"/></scene>"#,
            |d, n| {
                let v = value(&Params::new(&[]), d, n.first_element_child().unwrap()).unwrap();
                assert!(matches!(v, Value::Spectrum(p) if p == [(400.0, 1.0), (700.0, 2.0)]));
            },
        );
        with(r#"<t><rotate angle="30"/></t>"#, |d, n| {
            let e = transform(&Params::new(&[]), d, n).unwrap_err();
            assert!(e.2.contains("non-zero axis"), "{e:?}");
        });
        assert!(numbers("1, 2 3,4").unwrap() == vec![1.0, 2.0, 3.0, 4.0]);
        assert!(numbers("1 inf").is_err() && numbers("1 x").is_err());
    }
}
