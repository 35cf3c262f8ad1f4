//! Mitsuba 3's plugins, one by one, as raylab's RON.

use super::xml::{at, attr, major_version, position, snake_case, value, Located, Params, Value};
pub use crate::scene::import::Imported;
use crate::scene::import::{matrix, num, quote, v3, ImportOptions, RonScene};
use crate::scene::spectra::{self, Use};
use glam::Affine3A;
use roxmltree::{Document, Node};
use std::collections::HashMap;
use std::fmt::Write as _;

/// A plugin's properties by name, each taken at most once; what is left is an error.
struct Props<'a, 'input> {
    doc: &'a Document<'input>,
    node: Node<'a, 'input>,
    values: HashMap<String, (Value, Node<'a, 'input>)>,
    /// Nested plugins and references: (name or "", node).
    children: Vec<(String, Node<'a, 'input>)>,
}

impl<'a, 'input> Props<'a, 'input> {
    fn read(
        params: &Params,
        doc: &'a Document<'input>,
        node: Node<'a, 'input>,
    ) -> Result<Self, Located> {
        let (mut values, mut children) = (HashMap::new(), Vec::new());
        for child in node.children().filter(Node::is_element) {
            let tag = child.tag_name().name();
            let mut name = attr(params, doc, child, "name")?.unwrap_or_default();
            if params.legacy {
                name = snake_case(&name);
                if name == "diffuse_reflectance"
                    && node.tag_name().name() == "bsdf"
                    && node.attribute("type") == Some("diffuse")
                {
                    name = "reflectance".into();
                }
            }
            match tag {
                "bsdf" | "emitter" | "texture" | "film" | "sampler" | "rfilter" | "ref"
                | "shape" | "sensor" | "integrator" | "medium" | "phase" | "volume" => {
                    children.push((name, child))
                }
                _ => {
                    if name.is_empty() {
                        return Err(at(doc, child, format!("<{tag}> needs a `name`")));
                    }
                    let v = value(params, doc, child)?;
                    if values.insert(name.clone(), (v, child)).is_some() {
                        return Err(at(doc, child, format!("`{name}` is given twice")));
                    }
                }
            }
        }
        Ok(Props {
            doc,
            node,
            values,
            children,
        })
    }

    fn kind(&self) -> String {
        format!(
            "<{} type=\"{}\">",
            self.node.tag_name().name(),
            self.node.attribute("type").unwrap_or("")
        )
    }

    fn take(&mut self, name: &str) -> Option<(Value, Node<'a, 'input>)> {
        self.values.remove(name)
    }

    /// Property `name` as what `extract` takes from its value (`what` says it in the error).
    fn typed<T>(
        &mut self,
        name: &str,
        what: &str,
        extract: impl FnOnce(Value) -> Option<T>,
    ) -> Result<Option<T>, Located> {
        match self.take(name) {
            None => Ok(None),
            Some((v, n)) => extract(v)
                .map(Some)
                .ok_or_else(|| at(self.doc, n, format!("`{name}` must be {what}"))),
        }
    }

    fn float(&mut self, name: &str) -> Result<Option<f32>, Located> {
        self.typed(name, "a float", |v| match v {
            Value::Float(x) => Some(x),
            Value::Integer(i) => Some(i as f32),
            _ => None,
        })
    }

    fn integer(&mut self, name: &str) -> Result<Option<i64>, Located> {
        self.typed(name, "an integer", |v| match v {
            Value::Integer(i) => Some(i),
            _ => None,
        })
    }

    fn boolean(&mut self, name: &str) -> Result<Option<bool>, Located> {
        self.typed(name, "a boolean", |v| match v {
            Value::Boolean(b) => Some(b),
            _ => None,
        })
    }

    fn string(&mut self, name: &str) -> Result<Option<String>, Located> {
        self.typed(name, "a string", |v| match v {
            Value::String(s) => Some(s),
            _ => None,
        })
    }

    fn vector(&mut self, name: &str) -> Result<Option<[f32; 3]>, Located> {
        self.colour_as(name, Use::Reflectance)
    }

    /// A conductor's `eta` or `k`: RGB or uniform (spectra of optical constants are not
    /// colours, and raylab does not turn them into RGB).
    fn optical_constant(&mut self, name: &str) -> Result<Option<[f32; 3]>, Located> {
        self.typed(
            name,
            "rgb or one number (a spectrum of optical constants is not supported)",
            |v| match v {
                Value::Vector(x) => Some(x),
                Value::Float(x) | Value::Uniform(x) => Some([x; 3]),
                _ => None,
            },
        )
    }

    /// An emitter's colour: a spectrum turned into RGB without D65's weighting, as
    /// Mitsuba's RGB variants turn an emitter's (a uniform one is equal-energy white).
    fn emission(&mut self, name: &str) -> Result<Option<[f32; 3]>, Located> {
        self.colour_as(name, Use::Emission)
    }

    fn colour_as(&mut self, name: &str, what: Use) -> Result<Option<[f32; 3]>, Located> {
        let Some((v, n)) = self.take(name) else {
            return Ok(None);
        };
        let rgb = match v {
            Value::Vector(x) => x,
            Value::Float(x) => [x; 3],
            Value::Uniform(x) if what == Use::Reflectance => [x; 3],
            Value::Uniform(x) => spectra::uniform_emission(x as f64).map(|c| c as f32),
            Value::Spectrum(pairs) => spectra::to_srgb(&pairs, what)
                .map_err(|e| at(self.doc, n, format!("`{name}`: {e}")))?
                .map(|c| c as f32),
            _ => {
                return Err(at(
                    self.doc,
                    n,
                    format!("`{name}` must be a colour or a vector"),
                ))
            }
        };
        Ok(Some(rgb))
    }

    fn transform(&mut self, name: &str) -> Result<Option<Affine3A>, Located> {
        self.typed(name, "a <transform>", |v| match v {
            Value::Transform(m) => Some(m),
            _ => None,
        })
    }

    /// A number, or (for IORs) a name, as RON: `1.5` or `"bk7"`.
    fn ior(&mut self, name: &str) -> Result<Option<String>, Located> {
        match self.take(name) {
            None => Ok(None),
            Some((Value::Float(v), _)) => Ok(Some(num(v))),
            Some((Value::String(s), n)) => {
                raylab_integrators::bsdf::ior::dielectric(&s).map_err(|e| at(self.doc, n, e))?;
                Ok(Some(quote(&s)))
            }
            Some((_, n)) => Err(at(
                self.doc,
                n,
                format!("`{name}` must be a number or a name"),
            )),
        }
    }

    /// Everything given and not used is an error: raylab does not drop what it cannot do.
    fn finish(self, ignorable: &[&str]) -> Result<(), Located> {
        let mut left: Vec<_> = self
            .values
            .iter()
            .filter(|(k, _)| !ignorable.contains(&k.as_str()))
            .collect();
        left.sort_by_key(|(_, (_, n))| n.range().start);
        if let Some((name, (_, n))) = left.first() {
            return Err(at(
                self.doc,
                *n,
                format!("{}: parameter `{name}` is not supported", self.kind()),
            ));
        }
        if let Some((name, n)) = self.children.first() {
            let what = if name.is_empty() {
                format!("<{}>", n.tag_name().name())
            } else {
                format!("`{name}`")
            };
            return Err(at(
                self.doc,
                *n,
                format!("{}: {what} is not supported here", self.kind()),
            ));
        }
        Ok(())
    }
}

/// A shape as the pieces of a RON entity.
struct ShapeParts {
    name: String,
    shape: String,
    to_world: Affine3A,
    material: Option<String>,
    emitter: Option<String>,
    flip: bool,
}

/// The constant albedo of a `Lambert` material's RON, if it is one.
fn lambert_albedo(ron: &str) -> Option<[f32; 3]> {
    let inner = ron.strip_prefix("Lambert(albedo: ")?.strip_suffix(')')?;
    let numbers: Vec<f32> = inner
        .trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(|x| x.trim().parse().ok())
        .collect::<Option<_>>()?;
    match numbers[..] {
        [g] => Some([g; 3]),
        [r, g, b] => Some([r, g, b]),
        _ => None,
    }
}

/// Mitsuba's `orthographic` sensor as raylab's `Orthographic` camera. Its camera space maps
/// `x` in `[-1, 1]` across the film's width and `y` in `[-1/aspect, 1/aspect]` across its
/// height (aspect = width / height), from `+x` (`to_world`'s left) on the image's left; so
/// `to_world`'s scales set the view's size. A crop is the crop's part of that rectangle.
fn orthographic(
    m: &Affine3A,
    (width, height): (i64, i64),
    crop: Option<(i64, i64, i64, i64)>,
) -> String {
    let (w, h) = (width as f32, height as f32);
    let (left, up, dir) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis);
    // Half the view's size in world units, and its unit axes.
    let (half_w, half_h) = (left.length(), up.length() * h / w);
    let (right, up, dir) = (-left.normalize(), up.normalize(), dir.normalize());
    let (x, y, cw, ch) = crop.unwrap_or((0, 0, width, height));
    let (u, v) = (
        (x as f32 + 0.5 * cw as f32) / w,
        (y as f32 + 0.5 * ch as f32) / h,
    );
    let eye = m.translation + right * (half_w * (2.0 * u - 1.0)) + up * (half_h * (1.0 - 2.0 * v));
    format!(
        "Orthographic(eye: {}, look_at: {}, up: {}, width: {}, height: {}, resolution: ({cw}, {ch}))",
        v3(eye.into()),
        v3((eye + dir).into()),
        v3(up.into()),
        num(2.0 * half_w * cw as f32 / w),
        num(2.0 * half_h * ch as f32 / h),
    )
}

/// The conversion's state: the output's parts and the named things seen so far.
struct Converter<'a, 'input> {
    doc: &'a Document<'input>,
    params: Params,
    /// Top-level plugins with an id, for `<ref>`.
    ids: HashMap<String, Node<'a, 'input>>,
    /// Material names already written, by the node that made them.
    materials: Vec<(String, String)>,
    material_of: HashMap<roxmltree::NodeId, String>,
    /// The name given to Mitsuba's default BSDF, once a shape needs it.
    default_material: Option<String>,
    entities: Vec<String>,
    /// `--approximate`, and what it replaced.
    approximate: bool,
    approximated: Vec<String>,
    /// The scene's folder and its `<path>` folders, to find the files it names.
    /// The scene's files, when it has a folder: names are found through them (and recorded).
    files: Option<crate::scene::access::SceneFiles>,
    search: Vec<String>,
    /// Mesh assets of shapegroups: (name, RON shape).
    meshes: Vec<(String, String)>,
    environment: Option<String>,
    camera: Option<String>,
    render: Vec<String>,
    report: Vec<String>,
    /// The BSDFs being converted, outermost first (a nested or referenced one inside).
    bsdfs_open: Vec<roxmltree::NodeId>,
    /// Each BSDF converted so far, by its node.
    bsdf_of: HashMap<roxmltree::NodeId, String>,
    /// The memory the process could allocate when the conversion began.
    room: crate::system::Room,
    /// (an entity, else a material; its name; its line and column in the text converted).
    origins: Vec<(bool, String, (u32, u32))>,
}

impl<'a, 'input> Converter<'a, 'input> {
    /// A file the scene names, as a path from the scene's folder: itself if it is there, else
    /// under the first `<path>` folder that holds it.
    /// Each candidate looked at is one of the scene's inputs (through `files`), missing ones
    /// too: creating one that comes before changes which file the scene reads.
    fn file_name(&self, name: String) -> String {
        let Some(files) = &self.files else {
            return name;
        };
        std::iter::once(name.clone())
            .chain(self.search.iter().map(|dir| format!("{dir}/{name}")))
            .find(|candidate| files.named(candidate).is_ok_and(|f| f.exists()))
            .unwrap_or(name)
    }

    /// An approximation at `node`: an error unless `--approximate`, else noted in the report.
    fn approximate(&mut self, node: Node<'a, 'input>, what: String) -> Result<(), Located> {
        if !self.approximate {
            return Err(at(
                self.doc,
                node,
                format!("{what}; give --approximate to render it so"),
            ));
        }
        let (line, col) = position(self.doc, node);
        let note = format!("{line}:{col}: {what} (approximated)");
        self.report.push(note.clone());
        self.approximated.push(note);
        Ok(())
    }

    fn props(&self, node: Node<'a, 'input>) -> Result<Props<'a, 'input>, Located> {
        Props::read(&self.params, self.doc, node)
    }

    fn kind(&self, node: Node) -> Result<String, Located> {
        attr(&self.params, self.doc, node, "type")?.ok_or_else(|| {
            at(
                self.doc,
                node,
                format!("<{}> needs a `type`", node.tag_name().name()),
            )
        })
    }

    /// `node` itself, or the plugin its `<ref id>` names.
    fn resolve(&self, node: Node<'a, 'input>) -> Result<Node<'a, 'input>, Located> {
        if node.tag_name().name() != "ref" {
            return Ok(node);
        }
        let id = attr(&self.params, self.doc, node, "id")?
            .ok_or_else(|| at(self.doc, node, "<ref> needs an `id`"))?;
        self.ids
            .get(&id)
            .copied()
            .ok_or_else(|| at(self.doc, node, format!("<ref id=\"{id}\">: no plugin has that id (it must be defined before, at the top level)")))
    }

    /// A colour parameter: a constant, or a `bitmap` / `checkerboard` texture given nested
    /// or by reference.
    fn colour(
        &self,
        props: &mut Props<'a, 'input>,
        name: &str,
        default: Option<[f32; 3]>,
    ) -> Result<Option<String>, Located> {
        if let Some(v) = props.vector(name)? {
            return Ok(Some(v3(v)));
        }
        let Some(i) = props.children.iter().position(|(n, _)| n == name) else {
            return Ok(default.map(v3));
        };
        let (_, node) = props.children.remove(i);
        let node = self.resolve(node)?;
        if node.tag_name().name() != "texture" {
            return Err(at(
                self.doc,
                node,
                format!("`{name}` must be a colour or a <texture>"),
            ));
        }
        self.texture(node).map(Some)
    }

    fn texture(&self, node: Node<'a, 'input>) -> Result<String, Located> {
        let kind = self.kind(node)?;
        let mut p = self.props(node)?;
        let legacy_uv = if self.params.legacy {
            let mut get = |name: &str, default: f32| p.float(name).map(|v| v.unwrap_or(default));
            let (u, v) = (get("uoffset", 0.0)?, get("voffset", 0.0)?);
            let (su, sv) = (get("uscale", 1.0)?, get("vscale", 1.0)?);
            ([su, sv], [u, v])
        } else {
            ([1.0, 1.0], [0.0, 0.0])
        };
        let (scale, offset) = match p.transform("to_uv")? {
            // Mitsuba 0.x's `uoffset`... become to_uv = translate(offset) then scale.
            None if self.params.legacy => (
                legacy_uv.0,
                [
                    legacy_uv.0[0] * legacy_uv.1[0],
                    legacy_uv.0[1] * legacy_uv.1[1],
                ],
            ),
            None => ([1.0, 1.0], [0.0, 0.0]),
            Some(m) => {
                let c = m.matrix3;
                if c.x_axis.y != 0.0 || c.y_axis.x != 0.0 {
                    return Err(at(self.doc, node, "`to_uv`: only a scale and a translation of the texture coordinates are supported"));
                }
                ([c.x_axis.x, c.y_axis.y], [m.translation.x, m.translation.y])
            }
        };
        let uv = format!(
            "uv_scale: ({}, {}), uv_offset: ({}, {})",
            num(scale[0]),
            num(scale[1]),
            num(offset[0]),
            num(offset[1])
        );
        let out = match kind.as_str() {
            "bitmap" => {
                let file = self.file_name(p.string("filename")?.ok_or_else(|| {
                    at(self.doc, node, "<texture type=\"bitmap\"> needs `filename`")
                })?);
                let filter = p
                    .string("filter_type")?
                    .unwrap_or_else(|| "bilinear".into());
                let wrap = p.string("wrap_mode")?.unwrap_or_else(|| "repeat".into());
                let raw = p.boolean("raw")?.unwrap_or(false);
                format!(
                    "Image(path: {}, filter: {}, wrap: {}, raw: {raw}, {uv})",
                    quote(&file),
                    quote(&filter),
                    quote(&wrap)
                )
            }
            "checkerboard" => {
                let c0 = p.vector("color0")?.unwrap_or([0.4; 3]);
                let c1 = p.vector("color1")?.unwrap_or([0.2; 3]);
                format!("Checkerboard(color0: {}, color1: {}, {uv})", v3(c0), v3(c1))
            }
            other => {
                return Err(at(
                    self.doc,
                    node,
                    format!("texture type `{other}` is not supported (bitmap, checkerboard are)"),
                ))
            }
        };
        p.finish(&[])?;
        Ok(out)
    }

    /// The RON of a BSDF. A BSDF that holds itself (a `<ref>` to a BSDF it is inside) is a
    /// cycle, refused; so is nesting deeper than [`super::include::MAX_NESTING`] through
    /// references.
    fn bsdf(&mut self, node: Node<'a, 'input>) -> Result<String, Located> {
        // A BSDF referenced from several places is converted once (a chain of BSDFs each
        // referring twice to the one before would otherwise take 2^depth conversions).
        if let Some(done) = self.bsdf_of.get(&node.id()) {
            return Ok(done.clone());
        }
        if self.bsdfs_open.contains(&node.id()) {
            let id = node.attribute("id").unwrap_or_default();
            return Err(at(
                self.doc,
                node,
                format!("<bsdf id=\"{id}\"> holds a <ref> to itself (a cycle of references)"),
            ));
        }
        if self.bsdfs_open.len() >= super::include::MAX_NESTING {
            return Err(at(
                self.doc,
                node,
                format!(
                    "BSDFs nest deeper than {} (through references)",
                    super::include::MAX_NESTING
                ),
            ));
        }
        self.bsdfs_open.push(node.id());
        let out = self.bsdf_plugin(node);
        self.bsdfs_open.pop();
        if let Ok(desc) = &out {
            self.bsdf_of.insert(node.id(), desc.clone());
        }
        out
    }

    fn bsdf_plugin(&mut self, node: Node<'a, 'input>) -> Result<String, Located> {
        let kind = self.kind(node)?;
        let mut p = self.props(node)?;
        let rough = |p: &mut Props<'a, 'input>, out: &mut String| -> Result<(), Located> {
            if let Some((v, n)) = p.take("distribution") {
                match v {
                    Value::String(d) if matches!(d.as_str(), "ggx" | "beckmann") => {
                        let _ = write!(out, ", distribution: {}", quote(&d));
                    }
                    _ => {
                        return Err(at(
                            p.doc,
                            n,
                            "`distribution` must be \"ggx\" or \"beckmann\"",
                        ))
                    }
                }
            }
            for name in ["alpha", "alpha_u", "alpha_v"] {
                if let Some(a) = p.float(name)? {
                    let _ = write!(out, ", {name}: {}", num(a));
                }
            }
            Ok(())
        };
        let iors = |p: &mut Props<'a, 'input>, out: &mut String| -> Result<(), Located> {
            for name in ["int_ior", "ext_ior"] {
                if let Some(v) = p.ior(name)? {
                    let _ = write!(out, ", {name}: {v}");
                }
            }
            Ok(())
        };
        let out = match kind.as_str() {
            "diffuse" => {
                let albedo = self
                    .colour(&mut p, "reflectance", Some([0.5; 3]))?
                    .unwrap_or_default();
                format!("Lambert(albedo: {albedo})")
            }
            "conductor" | "roughconductor" => {
                let mut out = String::from(if kind == "conductor" {
                    "Conductor("
                } else {
                    "RoughConductor("
                });
                let metal = match p.take("material") {
                    None => None,
                    Some((Value::String(m), n)) => {
                        raylab_integrators::bsdf::ior::metal(&m).map_err(|e| at(self.doc, n, e))?;
                        Some(m)
                    }
                    Some((_, n)) => return Err(at(self.doc, n, "`material` must be a string")),
                };
                match (metal, p.optical_constant("eta")?, p.optical_constant("k")?) {
                    (Some(m), None, None) => {
                        let _ = write!(out, "metal: {}", quote(&m));
                    }
                    (None, Some(eta), Some(k)) => {
                        let _ = write!(out, "eta: {}, k: {}", v3(eta), v3(k));
                    }
                    (None, None, None) => out.push_str("metal: \"none\""),
                    _ => {
                        return Err(at(
                            self.doc,
                            node,
                            "a conductor takes `material`, or `eta` and `k`",
                        ))
                    }
                }
                if let Some(c) = self.colour(&mut p, "specular_reflectance", None)? {
                    let _ = write!(out, ", specular_reflectance: {c}");
                }
                if kind == "roughconductor" {
                    rough(&mut p, &mut out)?;
                }
                out + ")"
            }
            "dielectric" | "roughdielectric" | "thindielectric" => {
                let mut out = match kind.as_str() {
                    "dielectric" => "Dielectric(".to_string(),
                    "roughdielectric" => "RoughDielectric(".to_string(),
                    _ => "ThinDielectric(".to_string(),
                };
                let mut fields = String::new();
                iors(&mut p, &mut fields)?;
                for name in ["specular_reflectance", "specular_transmittance"] {
                    if let Some(c) = self.colour(&mut p, name, None)? {
                        let _ = write!(fields, ", {name}: {c}");
                    }
                }
                if kind == "roughdielectric" {
                    rough(&mut p, &mut fields)?;
                }
                out.push_str(fields.trim_start_matches(", "));
                out + ")"
            }
            "plastic" | "roughplastic" => {
                let mut fields = String::new();
                for name in ["diffuse_reflectance", "specular_reflectance"] {
                    if let Some(c) = self.colour(&mut p, name, None)? {
                        let _ = write!(fields, ", {name}: {c}");
                    }
                }
                iors(&mut p, &mut fields)?;
                if let Some(b) = p.boolean("nonlinear")? {
                    let _ = write!(fields, ", nonlinear: {b}");
                }
                if kind == "roughplastic" {
                    rough(&mut p, &mut fields)?;
                }
                let name = if kind == "plastic" {
                    "Plastic"
                } else {
                    "RoughPlastic"
                };
                format!("{name}({})", fields.trim_start_matches(", "))
            }
            "twosided" => {
                let inner: Vec<Node> = p.children.iter().map(|(_, n)| *n).collect();
                p.children.clear();
                let [inner] = inner[..] else {
                    return Err(at(self.doc, node, "<bsdf type=\"twosided\"> with two BSDFs (one per side) is not supported: give one"));
                };
                let inner = self.resolve(inner)?;
                if inner.tag_name().name() == "bsdf" && inner.attribute("type") == Some("twosided")
                {
                    return Err(at(
                        self.doc,
                        inner,
                        "a two-sided BSDF inside another (Mitsuba refuses it too): give the inner one alone",
                    ));
                }
                format!("TwoSided({})", self.bsdf(inner)?)
            }
            "normalmap" | "bumpmap" => {
                // One nested BSDF and one texture (nested or referenced).
                let mut inner = None;
                let mut texture = None;
                for (_, child) in std::mem::take(&mut p.children) {
                    let child = self.resolve(child)?;
                    match child.tag_name().name() {
                        "bsdf" if inner.is_none() => inner = Some(child),
                        "texture" if texture.is_none() => texture = Some(child),
                        tag => return Err(at(self.doc, child, format!("<bsdf type=\"{kind}\"> takes one <bsdf> and one <texture>, not this <{tag}>"))),
                    }
                }
                let (Some(inner), Some(texture)) = (inner, texture) else {
                    return Err(at(
                        self.doc,
                        node,
                        format!("<bsdf type=\"{kind}\"> needs a nested <bsdf> and a <texture>"),
                    ));
                };
                let (material, texture) = (self.bsdf(inner)?, self.texture(texture)?);
                if kind == "normalmap" {
                    format!("NormalMap(texture: {texture}, material: {material})")
                } else {
                    let scale = p.float("scale")?.unwrap_or(1.0);
                    format!(
                        "BumpMap(texture: {texture}, scale: {}, material: {material})",
                        num(scale)
                    )
                }
            }
            "blendbsdf" => {
                // (1 - weight) f_a + weight f_b, which raylab's materials hold when the weight
                // picks one, both are the same, or both are constant diffuse reflectances.
                let weight = self.constant_weight(&mut p, node, "weight")?;
                let inner = self.nested_bsdfs(&mut p, node, 2)?;
                let (a, b) = (self.bsdf(inner[0])?, self.bsdf(inner[1])?);
                let w = weight.unwrap_or(0.5);
                match (weight, lambert_albedo(&a), lambert_albedo(&b)) {
                    (Some(0.0), ..) => a,
                    (Some(1.0), ..) => b,
                    _ if a == b => a,
                    (Some(w), Some(ka), Some(kb)) => format!(
                        "Lambert(albedo: {})",
                        v3(std::array::from_fn(|i| {
                            let w = w as f64;
                            ((1.0 - w) * ka[i] as f64 + w * kb[i] as f64) as f32
                        }))
                    ),
                    _ => {
                        self.approximate(
                            node,
                            format!("<bsdf type=\"blendbsdf\"> of these BSDFs (with this weight) has no raylab material; replaced by the one weighted more ({})", if w > 0.5 { "the second" } else { "the first" }),
                        )?;
                        if w > 0.5 {
                            b
                        } else {
                            a
                        }
                    }
                }
            }
            "mask" => {
                // Mitsuba's cut-out: the BSDF where opaque, nothing where not. raylab has no
                // transparent surfaces, so only a fully opaque mask is exact.
                let opacity = self.constant_weight(&mut p, node, "opacity")?;
                let inner = self.nested_bsdfs(&mut p, node, 1)?;
                let material = self.bsdf(inner[0])?;
                if opacity != Some(1.0) {
                    self.approximate(
                        node,
                        "<bsdf type=\"mask\"> with an opacity below 1: raylab has no see-through surfaces; rendered opaque".to_string(),
                    )?;
                }
                material
            }
            other => {
                let message = format!("BSDF `{other}` is not supported (diffuse, conductor, roughconductor, dielectric, roughdielectric, thindielectric, plastic, roughplastic, twosided, normalmap, bumpmap, blendbsdf and mask where raylab's materials hold them are)");
                self.approximate(
                    node,
                    format!("{message}: replaced by Mitsuba's default, diffuse 0.5"),
                )?;
                return Ok("Lambert(albedo: 0.5)".into());
            }
        };
        if let Some((name, child)) = p.children.first() {
            return Err(at(
                self.doc,
                *child,
                format!("<bsdf type=\"{kind}\">: `{name}` is not supported here"),
            ));
        }
        p.finish(&[])?;
        Ok(out)
    }

    /// A blend weight or opacity in `[0, 1]`: the number, `None` when it is a texture (the
    /// texture is consumed), Mitsuba's 0.5 when absent.
    fn constant_weight(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
        name: &str,
    ) -> Result<Option<f32>, Located> {
        if let Some(i) = p.children.iter().position(|(n, _)| n == name) {
            p.children.remove(i);
            return Ok(None);
        }
        let w = p.float(name)?.unwrap_or(0.5);
        if !(0.0..=1.0).contains(&w) {
            return Err(at(
                self.doc,
                node,
                format!("`{name}` must lie in [0, 1], not {w}"),
            ));
        }
        Ok(Some(w))
    }

    /// Exactly `n` nested (or referenced) BSDFs of `node`.
    fn nested_bsdfs(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
        n: usize,
    ) -> Result<Vec<Node<'a, 'input>>, Located> {
        let mut inner = Vec::new();
        for (_, child) in std::mem::take(&mut p.children) {
            let child = self.resolve(child)?;
            if child.tag_name().name() != "bsdf" {
                return Err(at(
                    self.doc,
                    child,
                    format!("<{}> is not a BSDF", child.tag_name().name()),
                ));
            }
            inner.push(child);
        }
        if inner.len() != n {
            let kind = self.kind(node)?;
            return Err(at(
                self.doc,
                node,
                format!(
                    "<bsdf type=\"{kind}\"> takes {n} nested BSDF(s), not {}",
                    inner.len()
                ),
            ));
        }
        Ok(inner)
    }

    /// The material name for a BSDF node (written once, however many shapes use it).
    fn material(&mut self, node: Node<'a, 'input>, fallback: &str) -> Result<String, Located> {
        let node = self.resolve(node)?;
        if let Some(name) = self.material_of.get(&node.id()) {
            return Ok(name.clone());
        }
        let mut name =
            attr(&self.params, self.doc, node, "id")?.unwrap_or_else(|| fallback.to_string());
        while self.materials.iter().any(|(n, _)| *n == name) {
            name.push('\'');
        }
        let desc = self.bsdf(node)?;
        let kind = self.kind(node)?;
        if matches!(
            kind.as_str(),
            "diffuse" | "conductor" | "roughconductor" | "plastic" | "roughplastic"
        ) {
            self.report.push(format!(
                "{name}: Mitsuba's `{kind}` is one-sided (black from behind); raylab's opaque \
                 materials are two-sided (as inside `twosided`)"
            ));
        }
        self.materials.push((name.clone(), desc));
        self.origins
            .push((false, name.clone(), position(self.doc, node)));
        self.material_of.insert(node.id(), name.clone());
        Ok(name)
    }

    fn shape(&mut self, node: Node<'a, 'input>, index: usize) -> Result<(), Located> {
        let parts = self.shape_parts(node, index)?;
        self.origins
            .push((true, parts.name.clone(), position(self.doc, node)));
        let mut e = format!(
            "(name: {}, transform: {}, shape: {}",
            quote(&parts.name),
            matrix(&parts.to_world),
            parts.shape,
        );
        if let Some(material) = parts.material {
            let _ = write!(e, ", material: {}", quote(&material));
        }
        if parts.flip {
            e.push_str(", flip_normals: true");
        }
        if let Some(em) = parts.emitter {
            let _ = write!(e, ", emitter: {em}");
        }
        e.push_str("),");
        self.entities.push(e);
        crate::scene::import::check_entities_made(self.entities.len(), &self.room)
            .map_err(|e| at(self.doc, node, e))?;
        Ok(())
    }

    /// An `instance` of a `shapegroup`: each shape of the group placed by the instance's
    /// `to_world` after its own, a mesh (`obj`, `ply`, `rectangle`, `cube`) as an instance of
    /// one mesh asset shared by every instance, an analytic shape as an entity of its own.
    fn instance(&mut self, node: Node<'a, 'input>, index: usize) -> Result<(), Located> {
        let name = attr(&self.params, self.doc, node, "id")?
            .unwrap_or_else(|| format!("instance #{index}"));
        let mut p = self.props(node)?;
        let to_world = p.transform("to_world")?.unwrap_or(Affine3A::IDENTITY);
        let refs: Vec<Node> = std::mem::take(&mut p.children)
            .into_iter()
            .map(|(_, n)| n)
            .collect();
        p.finish(&[])?;
        let [group] = refs[..] else {
            return Err(at(
                self.doc,
                node,
                "<shape type=\"instance\"> takes one shapegroup (a <ref> to it)",
            ));
        };
        let group = self.resolve(group)?;
        if group.tag_name().name() != "shape" || self.kind(group)? != "shapegroup" {
            return Err(at(
                self.doc,
                group,
                "an instance places a <shape type=\"shapegroup\">",
            ));
        }
        let gid = attr(&self.params, self.doc, group, "id")?.unwrap_or_else(|| name.clone());
        let shapes: Vec<Node> = group.children().filter(Node::is_element).collect();
        for (i, child) in shapes.into_iter().enumerate() {
            if child.tag_name().name() != "shape" {
                return Err(at(self.doc, child, "a shapegroup holds shapes only"));
            }
            let kind = self.kind(child)?;
            let parts = self.shape_parts(child, i)?;
            if parts.emitter.is_some() {
                return Err(at(
                    self.doc,
                    child,
                    "a shape of a shapegroup cannot emit light (in Mitsuba neither)",
                ));
            }
            let placed = to_world * parts.to_world;
            let shape = if matches!(kind.as_str(), "obj" | "ply" | "rectangle" | "cube") {
                if parts.flip {
                    return Err(at(self.doc, child, "a mesh of a shapegroup turned around (flip_normals, or a mirrored rectangle) is not supported"));
                }
                let mesh = format!("{gid}/{i}");
                if !self.meshes.iter().any(|(n, _)| *n == mesh) {
                    self.meshes.push((mesh.clone(), parts.shape.clone()));
                }
                format!("Instance(mesh: {})", quote(&mesh))
            } else {
                parts.shape.clone()
            };
            let entity = format!("{name} / {}", parts.name);
            self.origins
                .push((true, entity.clone(), position(self.doc, child)));
            let mut e = format!(
                "(name: {}, transform: {}, shape: {shape}",
                quote(&entity),
                matrix(&placed),
            );
            if let Some(material) = parts.material {
                let _ = write!(e, ", material: {}", quote(&material));
            }
            if parts.flip && !shape.starts_with("Instance") {
                e.push_str(", flip_normals: true");
            }
            e.push_str("),");
            self.entities.push(e);
            crate::scene::import::check_entities_made(self.entities.len(), &self.room)
                .map_err(|e| at(self.doc, node, e))?;
        }
        Ok(())
    }

    /// A shape's parts: its RON shape, placement, material, emitter and orientation.
    fn shape_parts(&mut self, node: Node<'a, 'input>, index: usize) -> Result<ShapeParts, Located> {
        let kind = self.kind(node)?;
        let name =
            attr(&self.params, self.doc, node, "id")?.unwrap_or_else(|| format!("{kind} #{index}"));
        let mut p = self.props(node)?;
        let to_world = p.transform("to_world")?.unwrap_or(Affine3A::IDENTITY);
        let file = |p: &mut Props<'a, 'input>| -> Result<String, Located> {
            p.string("filename")?.ok_or_else(|| {
                at(
                    self.doc,
                    node,
                    format!("<shape type=\"{kind}\"> needs `filename`"),
                )
            })
        };
        // Mitsuba shades a mesh with its file's normals, or with normals it computes when the
        // file has none; flat with `face_normals`.
        let normals = |p: &mut Props<'a, 'input>| -> Result<&str, Located> {
            Ok(match p.boolean("face_normals")? {
                Some(true) => "flat",
                _ => "smooth",
            })
        };
        let shape = match kind.as_str() {
            "obj" | "ply" => {
                let path = quote(&self.file_name(file(&mut p)?));
                let normals = normals(&mut p)?;
                let variant = if kind == "obj" { "Obj" } else { "Ply" };
                format!("{variant}(path: {path}, normals: \"{normals}\")")
            }
            "serialized" => {
                let path = quote(&self.file_name(file(&mut p)?));
                let index = p.integer("shape_index")?.unwrap_or(0);
                let index = u32::try_from(index).map_err(|_| {
                    at(self.doc, node, format!("shape_index {index} must be 0 or more"))
                })?;
                let normals = normals(&mut p)?;
                format!("Serialized(path: {path}, shape_index: {index}, normals: \"{normals}\")")
            }
            "rectangle" => "Rectangle".to_string(),
            "cube" => "Box(min: (-1, -1, -1), max: (1, 1, 1))".to_string(),
            "disk" => "Disk".to_string(),
            "sphere" => {
                let c = p.vector("center")?.unwrap_or([0.0; 3]);
                let r = p.float("radius")?.unwrap_or(1.0);
                format!("Sphere(center: {}, radius: {})", v3(c), num(r))
            }
            "cylinder" => {
                let p0 = p.vector("p0")?.unwrap_or([0.0; 3]);
                let p1 = p.vector("p1")?.unwrap_or([0.0, 0.0, 1.0]);
                let r = p.float("radius")?.unwrap_or(1.0);
                format!("Cylinder(p0: {}, p1: {}, radius: {})", v3(p0), v3(p1), num(r))
            }
            other => {
                return Err(at(self.doc, node, format!("shape `{other}` is not supported (obj, ply, serialized, rectangle, cube, disk, sphere, cylinder are)")))
            }
        };
        let mut flip = p.boolean("flip_normals")?.unwrap_or(false);
        // Mitsuba's rectangle faces its inverse transpose's +z; raylab's Rectangle is two
        // triangles facing their winding, which a mirroring to_world turns the other way.
        if kind == "rectangle" && to_world.matrix3.determinant() < 0.0 {
            flip = !flip;
            self.report.push(format!(
                "{name}: a mirroring to_world: its faces turned to face where Mitsuba's do"
            ));
        }
        let (mut material, mut emitter) = (None, None);
        for (_, child) in std::mem::take(&mut p.children) {
            let child = self.resolve(child)?;
            match child.tag_name().name() {
                "bsdf" if material.is_none() => {
                    material = Some(self.material(child, &format!("{name} material"))?)
                }
                "emitter" if emitter.is_none() => {
                    let k = self.kind(child)?;
                    if k != "area" {
                        return Err(at(
                            self.doc,
                            child,
                            format!("a shape's emitter must be `area`, not `{k}`"),
                        ));
                    }
                    let mut e = self.props(child)?;
                    let radiance = e.emission("radiance")?.ok_or_else(|| at(self.doc, child, "<emitter type=\"area\"> needs a constant `radiance` (a texture is not supported)"))?;
                    e.finish(&[])?;
                    emitter = Some(format!("Area(radiance: {})", v3(radiance)));
                }
                tag => {
                    return Err(at(
                        self.doc,
                        child,
                        format!("<{tag}> inside a shape is not supported"),
                    ))
                }
            }
        }
        p.finish(&[])?;
        // Mitsuba gives a shape without a BSDF its default grey diffuse, but an emitter a
        // black one: raylab's pure emitters are black too (no material).
        let material = match (material, &emitter) {
            (Some(m), _) => Some(m),
            (None, Some(_)) => None,
            (None, None) => Some(match &self.default_material {
                Some(name) => name.clone(),
                None => {
                    let mut name = "default".to_string();
                    while self.materials.iter().any(|(n, _)| *n == name) {
                        name.push('\'');
                    }
                    self.materials
                        .push((name.clone(), "Lambert(albedo: 0.5)".into()));
                    self.report.push(format!(
                        "{name}: Mitsuba's default BSDF (diffuse 0.5), for shapes without one; \
                         two-sided in raylab"
                    ));
                    self.default_material = Some(name.clone());
                    name
                }
            }),
        };
        Ok(ShapeParts {
            name,
            shape,
            to_world,
            material,
            emitter,
            flip,
        })
    }

    fn emitter(&mut self, node: Node<'a, 'input>, index: usize) -> Result<(), Located> {
        let kind = self.kind(node)?;
        let name =
            attr(&self.params, self.doc, node, "id")?.unwrap_or_else(|| format!("{kind} #{index}"));
        let mut p = self.props(node)?;
        let to_world = p.transform("to_world")?;
        let placed = |m: Option<Affine3A>| {
            m.map(|m| format!(", transform: {}", matrix(&m)))
                .unwrap_or_default()
        };
        let entity = match kind.as_str() {
            "constant" => {
                let r = p.emission("radiance")?.unwrap_or([1.0; 3]);
                if self.environment.replace(v3(r)).is_some() {
                    return Err(at(self.doc, node, "a second environment emitter: raylab's scene has one"));
                }
                None
            }
            "envmap" => {
                let file = self.file_name(p.string("filename")?.ok_or_else(|| at(self.doc, node, "<emitter type=\"envmap\"> needs `filename`"))?);
                let scale = p.float("scale")?.unwrap_or(1.0);
                Some(format!("emitter: Environment(path: {}, scale: {}){}", quote(&file), num(scale), placed(to_world)))
            }
            "point" => {
                let i = p.emission("intensity")?.unwrap_or([1.0; 3]);
                let m = match p.vector("position")? {
                    Some(pos) => Affine3A::from_translation(pos.into()),
                    None => to_world.unwrap_or(Affine3A::IDENTITY),
                };
                Some(format!("emitter: Point(intensity: {}), transform: {}", v3(i), matrix(&m)))
            }
            "spot" => {
                let i = p.emission("intensity")?.unwrap_or([1.0; 3]);
                let cutoff = p.float("cutoff_angle")?.unwrap_or(20.0);
                let beam = p.float("beam_width")?.unwrap_or(cutoff * 0.75);
                Some(format!("emitter: Spot(intensity: {}, cutoff_angle: {}, beam_width: {}){}", v3(i), num(cutoff), num(beam), placed(to_world)))
            }
            "directional" => {
                let e = p.emission("irradiance")?.unwrap_or([1.0; 3]);
                let d = p.vector("direction")?.unwrap_or([0.0, 0.0, 1.0]);
                Some(format!("emitter: Directional(direction: {}, irradiance: {}){}", v3(d), v3(e), placed(to_world)))
            }
            other => return Err(at(self.doc, node, format!("emitter `{other}` is not supported (area, point, spot, directional, constant, envmap are)"))),
        };
        p.finish(&[])?;
        if let Some(e) = entity {
            self.entities
                .push(format!("(name: {}, {e}),", quote(&name)));
        }
        Ok(())
    }

    fn sensor(&mut self, node: Node<'a, 'input>) -> Result<(), Located> {
        if self.camera.is_some() {
            // Mitsuba 3 renders its first sensor (sensor 0) unless told otherwise.
            let (line, col) = position(self.doc, node);
            self.report.push(format!(
                "{line}:{col}: a second <sensor>: not read (Mitsuba 3 and raylab render the first)"
            ));
            return Ok(());
        }
        let kind = self.kind(node)?;
        if kind != "perspective" && kind != "orthographic" {
            return Err(at(
                self.doc,
                node,
                format!("sensor `{kind}` is not supported (perspective and orthographic are)"),
            ));
        }
        let mut p = self.props(node)?;
        let fov = if kind == "perspective" {
            Some(p.float("fov")?.ok_or_else(|| {
                at(
                    self.doc,
                    node,
                    "the sensor needs `fov` (raylab does not read `focal_length`)",
                )
            })?)
        } else {
            None
        };
        let axis = match fov {
            Some(_) => p.string("fov_axis")?.unwrap_or_else(|| "x".into()),
            None => String::new(),
        };
        let m = p.transform("to_world")?.unwrap_or(Affine3A::IDENTITY);
        if p.float("near_clip")?.is_some() | p.float("far_clip")?.is_some() {
            self.report.push(
                "sensor: near_clip and far_clip ignored (raylab's camera does not clip)".into(),
            );
        }
        let (mut width, mut height, mut filter, mut spp) =
            (768i64, 576i64, "gaussian".to_string(), None);
        let mut crop: Option<(i64, i64, i64, i64)> = None;
        for (_, child) in std::mem::take(&mut p.children) {
            match child.tag_name().name() {
                "film" => {
                    let film = self.kind(child)?;
                    if film != "hdrfilm" {
                        return Err(at(
                            self.doc,
                            child,
                            format!("film `{film}` is not supported (hdrfilm is)"),
                        ));
                    }
                    let mut f = self.props(child)?;
                    width = f.integer("width")?.unwrap_or(width);
                    height = f.integer("height")?.unwrap_or(height);
                    if !(1..=i64::from(crate::scene::describe::MAX_SIDE)).contains(&width)
                        || !(1..=i64::from(crate::scene::describe::MAX_SIDE)).contains(&height)
                    {
                        return Err(at(
                            self.doc,
                            child,
                            format!(
                                "the film is {width}x{height}: each side must be 1 to {}",
                                crate::scene::describe::MAX_SIDE
                            ),
                        ));
                    }
                    let offset = (f.integer("crop_offset_x")?, f.integer("crop_offset_y")?);
                    let size = (f.integer("crop_width")?, f.integer("crop_height")?);
                    if offset != (None, None) || size != (None, None) {
                        let (x, y) = (offset.0.unwrap_or(0), offset.1.unwrap_or(0));
                        let (w, h) = (size.0.unwrap_or(width - x), size.1.unwrap_or(height - y));
                        if x < 0 || y < 0 || w < 1 || h < 1 || x + w > width || y + h > height {
                            return Err(at(self.doc, child, format!("the crop {w}x{h} at ({x}, {y}) must lie inside the {width}x{height} film")));
                        }
                        crop = Some((x, y, w, h));
                    }
                    for (_, rf) in std::mem::take(&mut f.children) {
                        if rf.tag_name().name() != "rfilter" {
                            return Err(at(self.doc, rf, "only an <rfilter> goes inside the film"));
                        }
                        filter = match self.kind(rf)?.as_str() {
                            "box" => "box".into(),
                            "tent" => "tent".into(),
                            "gaussian" => "gaussian".into(),
                            other => {
                                return Err(at(
                                    self.doc,
                                    rf,
                                    format!(
                                    "filter `{other}` is not supported (box, tent, gaussian are)"
                                ),
                                ))
                            }
                        };
                        // Mitsuba's sizes: box and tent by radius, the Gaussian by its
                        // standard deviation, cut off at four of them.
                        let mut r = self.props(rf)?;
                        let size = if filter == "gaussian" {
                            r.float("stddev")?
                                .map(|s| format!("(stddev: {}, radius: {})", num(s), num(4.0 * s)))
                        } else {
                            r.float("radius")?.map(|v| format!("(radius: {})", num(v)))
                        };
                        if let Some(size) = size {
                            filter.push_str(&size);
                            filter
                                .parse::<raylab_integrators::Filter>()
                                .map_err(|e| at(self.doc, rf, e))?;
                        }
                        r.finish(&[])?;
                    }
                    f.finish(&[
                        "pixel_format",
                        "component_format",
                        "file_format",
                        "banner",
                        "sample_border",
                        "compensate",
                        "rfilter",
                    ])?;
                }
                "sampler" => {
                    let mut s = self.props(child)?;
                    spp = s.integer("sample_count")?;
                    if let Some(n) = spp.filter(|n| !(1..=i64::from(u32::MAX)).contains(n)) {
                        return Err(at(
                            self.doc,
                            child,
                            format!("sample_count {n}: it must be 1 to {}", u32::MAX),
                        ));
                    }
                    s.finish(&["seed", "jitter", "scramble_seed"])?;
                }
                tag => {
                    return Err(at(
                        self.doc,
                        child,
                        format!("<{tag}> inside the sensor is not supported"),
                    ))
                }
            }
        }
        // A pinhole's focus distance changes nothing.
        p.finish(&["focus_distance"])?;
        let (left, up, dir) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis);
        if up.cross(dir).dot(left) <= 0.0 {
            return Err(at(
                self.doc,
                node,
                "the sensor's to_world mirrors the image, which raylab's camera cannot",
            ));
        }
        let Some(fov) = fov else {
            self.camera = Some(orthographic(&m, (width, height), crop));
            return self.sensor_settings(filter, spp);
        };
        let (w, h) = (width as f32, height as f32);
        // raylab's fov is vertical.
        let half = (fov.to_radians() * 0.5).tan();
        let vertical = match axis.as_str() {
            "y" => half,
            "x" => half * h / w,
            "diagonal" => half * h / (w * w + h * h).sqrt(),
            "smaller" => {
                if w < h {
                    half * h / w
                } else {
                    half
                }
            }
            "larger" => {
                if w > h {
                    half * h / w
                } else {
                    half
                }
            }
            other => {
                return Err(at(
                    self.doc,
                    node,
                    format!("fov_axis `{other}` is not known"),
                ))
            }
        };
        let fov_y = 2.0 * vertical.atan().to_degrees();
        let eye = m.translation;
        let dir = dir.normalize();
        self.camera = Some(match crop {
            None => format!(
                "LookAt(eye: {}, look_at: {}, up: {}, fov: {}, resolution: ({width}, {height}))",
                v3(eye.into()),
                v3((eye + dir).into()),
                v3(up.normalize().into()),
                num(fov_y)
            ),
            // A crop: the film's part of the image plane at distance 1, as an image-plane
            // camera (Mitsuba writes the crop alone).
            Some((x, y, cw, ch)) => {
                let (up, right) = (up.normalize(), -left.normalize());
                let th = (fov_y.to_radians() * 0.5).tan();
                let tw = th * w / h;
                let at = |px: i64, py: i64| {
                    let (fx, fy) = (px as f32 / w, py as f32 / h);
                    eye + dir + right * (tw * (2.0 * fx - 1.0)) + up * (th * (1.0 - 2.0 * fy))
                };
                format!(
                    "ImagePlane(eye: {}, top_left: {}, top_right: {}, bottom_left: {}, bottom_right: {}, resolution: ({cw}, {ch}))",
                    v3(eye.into()),
                    v3(at(x, y).into()),
                    v3(at(x + cw, y).into()),
                    v3(at(x, y + ch).into()),
                    v3(at(x + cw, y + ch).into())
                )
            }
        });
        self.sensor_settings(filter, spp)
    }

    /// The sensor's film filter and sample count, as render settings.
    fn sensor_settings(&mut self, filter: String, spp: Option<i64>) -> Result<(), Located> {
        self.render.push(format!("filter: {}", quote(&filter)));
        if let Some(spp) = spp {
            self.render.push(format!("spp: {spp}"));
        }
        Ok(())
    }

    fn integrator(&mut self, node: Node<'a, 'input>) -> Result<(), Located> {
        if self.render.iter().any(|r| r.starts_with("integrator:")) {
            return Err(at(
                self.doc,
                node,
                "a second <integrator>: a scene names one",
            ));
        }
        let kind = self.kind(node)?;
        let mut p = self.props(node)?;
        match kind.as_str() {
            "path" | "ptracer" => {
                let max_depth = p.integer("max_depth")?.unwrap_or(-1);
                if max_depth == 0 || max_depth < -1 {
                    return Err(at(
                        self.doc,
                        node,
                        format!("max_depth {max_depth}: raylab takes -1 (unlimited) or a positive depth"),
                    ));
                }
                let rr_depth = p.integer("rr_depth")?.unwrap_or(5);
                if p.boolean("hide_emitters")? == Some(true) {
                    self.approximate(
                        node,
                        "hide_emitters is not supported: emitters seen directly are shown".into(),
                    )?;
                }
                // Mitsuba's max_depth counts the segments of a path, raylab's the scattering
                // events: one less; -1 is unlimited in both.
                let depth = if max_depth < 0 {
                    "inf".to_string()
                } else {
                    (max_depth - 1).max(0).to_string()
                };
                // Mitsuba's ptracer is raylab's lighttracer (paths from the lights, each vertex
                // connected to the sensor); its passes are raylab's passes.
                let name = if kind == "path" {
                    "path"
                } else {
                    "lighttracer"
                };
                if kind == "ptracer" {
                    p.integer("samples_per_pass")?;
                }
                self.render.push(format!("integrator: \"{name}\", params: {{\"max-depth\": {depth}, \"rr-depth\": {rr_depth}}}"));
                self.report.push(format!("integrator: Mitsuba's {kind} max_depth {max_depth} is raylab's {name} max-depth {depth}"));
            }
            "direct" => {
                let shading = p.integer("shading_samples")?;
                let count = |p: &mut Props<'a, 'input>, name: &str| -> Result<i64, Located> {
                    let n = p.integer(name)?.or(shading).unwrap_or(1);
                    if !(0..=1024).contains(&n) {
                        return Err(at(
                            self.doc,
                            node,
                            format!("{name} {n} must lie in 0..=1024"),
                        ));
                    }
                    Ok(n)
                };
                let (emitter, bsdf) = (
                    count(&mut p, "emitter_samples")?,
                    count(&mut p, "bsdf_samples")?,
                );
                if p.boolean("hide_emitters")? == Some(true) {
                    self.approximate(
                        node,
                        "hide_emitters is not supported: emitters seen directly are shown".into(),
                    )?;
                }
                self.render.push(format!("integrator: \"direct\", params: {{\"emitter-samples\": {emitter}, \"bsdf-samples\": {bsdf}}}"));
            }
            "moment" => {
                // A wrapper that adds a second moment image: the estimate is its inner
                // integrator's.
                let inner: Vec<Node> = p.children.iter().map(|(_, n)| *n).collect();
                p.children.clear();
                let [inner] = inner[..] else {
                    return Err(at(
                        self.doc,
                        node,
                        "<integrator type=\"moment\"> wraps one integrator",
                    ));
                };
                self.report.push("integrator: Mitsuba's moment wrapper: raylab keeps each pixel's variance already; its inner integrator renders".into());
                p.finish(&[])?;
                return self.integrator(inner);
            }
            other => {
                self.approximate(node, format!("integrator `{other}` is not supported (path, ptracer, direct, moment are): rendered with path"))?;
                self.render.push("integrator: \"path\"".into());
                return Ok(());
            }
        }
        p.finish(&[])
    }
}

/// Converts the Mitsuba XML `text` into RON; `overrides` are `-D` parameters.
pub fn to_ron(text: &str, overrides: &[(String, String)]) -> Result<Imported, Located> {
    let options = ImportOptions {
        defines: overrides.to_vec(),
        approximate: false,
    };
    to_ron_with(text, &options)
}

/// [`to_ron`] with every import option (`-D`, `--approximate`).
pub fn to_ron_with(text: &str, options: &ImportOptions) -> Result<Imported, Located> {
    to_ron_in(text, options, None, &[])
}

/// [`to_ron_with`] for a scene in the folder `base` whose `<path>` folders are `search`:
/// a file named by a shape or texture that is not in `base` but in one of those folders is
/// named by its path from `base`.
pub fn to_ron_in(
    text: &str,
    options: &ImportOptions,
    files: Option<&crate::scene::access::SceneFiles>,
    search: &[String],
) -> Result<Imported, Located> {
    super::xml::check_attributes(text)?;
    let doc = Document::parse(text).map_err(|e| {
        let p = e.pos();
        (p.row, p.col, format!("malformed XML: {e}"))
    })?;
    super::include::check_nesting(&doc)?;
    let root = doc.root_element();
    if root.tag_name().name() != "scene" {
        return Err(at(
            &doc,
            root,
            format!("expected a <scene>, found <{}>", root.tag_name().name()),
        ));
    }
    let mut params = Params::new(&options.defines);
    // Mitsuba 3 reads a 0.x scene through its upgrade rules; so does raylab.
    params.legacy = major_version(&doc, root)?.is_some_and(|major| major < 2);
    let mut c = Converter {
        doc: &doc,
        params,
        ids: HashMap::new(),
        materials: Vec::new(),
        material_of: HashMap::new(),
        default_material: None,
        entities: Vec::new(),
        approximate: options.approximate,
        approximated: Vec::new(),
        files: files.cloned(),
        search: search.to_vec(),
        meshes: Vec::new(),
        environment: None,
        camera: None,
        render: Vec::new(),
        report: Vec::new(),
        bsdfs_open: Vec::new(),
        bsdf_of: HashMap::new(),
        room: crate::system::Room::now(),
        origins: Vec::new(),
    };
    let mut index = 0;
    for node in root.children().filter(Node::is_element) {
        index += 1;
        let tag = node.tag_name().name();
        if let Some(id) = attr(&c.params, &doc, node, "id")? {
            if c.ids.insert(id.clone(), node).is_some() {
                return Err(at(&doc, node, format!("id `{id}` is used twice")));
            }
        }
        match tag {
            "default" => {
                let name = attr(&c.params, &doc, node, "name")?
                    .ok_or_else(|| at(&doc, node, "<default> needs a `name`"))?;
                let value = node
                    .attribute("value")
                    .ok_or_else(|| at(&doc, node, "<default> needs a `value`"))?;
                c.params.default(&name, value);
            }
            "bsdf" => {
                // Written when a shape uses it (unused ones are left out).
            }
            "texture" => {}
            // The search folders, read with the includes.
            "path" => {}
            "include" => {
                return Err(at(
                    &doc,
                    node,
                    "<include> is read only in a scene file (the text given has no file)",
                ));
            }
            "shape" => match c.kind(node)?.as_str() {
                // Placed by its instances.
                "shapegroup" => {}
                "instance" => c.instance(node, index)?,
                _ => c.shape(node, index)?,
            },
            "emitter" => c.emitter(node, index)?,
            "sensor" => c.sensor(node)?,
            "integrator" => c.integrator(node)?,
            other => {
                return Err(at(
                    &doc,
                    node,
                    format!("<{other}> is not supported at the top of a scene"),
                ))
            }
        }
    }
    let camera = c.camera.ok_or_else(|| {
        (
            1,
            1,
            "the scene has no <sensor>: raylab needs a camera".to_string(),
        )
    })?;
    if c.entities.is_empty() {
        return Err((1, 1, "the scene has no shapes or emitters".into()));
    }
    let (line, col) = position(&doc, root);
    let ron = RonScene {
        header: format!("Imported by raylab from a Mitsuba 3 scene (its <scene> at {line}:{col})."),
        camera: &camera,
        render: &c.render.join(", "),
        environment: c.environment.clone(),
        materials: &c.materials,
        meshes: &c.meshes,
        entities: &c.entities,
    }
    .write();
    // Places in the text converted (no file: the caller knows which file each came from).
    let mut origins = crate::scene::import::Origins::default();
    for (entity, name, (line, col)) in c.origins {
        let table = if entity {
            &mut origins.entities
        } else {
            &mut origins.materials
        };
        table.insert(name, (std::path::PathBuf::new(), line, col));
    }
    Ok(Imported {
        ron,
        report: c.report,
        approximated: c.approximated,
        origins,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const CORNELL: &str = include_str!("../../../scenes/mitsuba/cornell_box.xml");

    proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(300))]
        /// The shipped XML scene cut short, or with a piece cut out or replaced by a token:
        /// an error, or RON that the loader takes or refuses, never a panic.
        #[test]
        fn mangled_xml_never_panics(
            at in any::<proptest::sample::Index>(),
            len in 0usize..40,
            token in prop::sample::select(vec![
                "", "<", ">", "/>", "\"", "$", "$spp", "type=\"cube\"", "<ref id=\"white\"/>",
                "<transform name=\"to_world\">", "value=\"1e39\"", "NaN", "-1", "&amp;", "<!--",
            ]),
        ) {
            let mut start = at.index(CORNELL.len() + 1);
            while !CORNELL.is_char_boundary(start) {
                start -= 1;
            }
            let mut end = (start + len).min(CORNELL.len());
            while !CORNELL.is_char_boundary(end) {
                end -= 1;
            }
            let text = if len == 0 {
                CORNELL[..start].to_string()
            } else {
                format!("{}{token}{}", &CORNELL[..start], &CORNELL[end..])
            };
            if let Ok(imported) = to_ron(&text, &[]) {
                let _ = crate::scene::parse_scene(&imported.ron, std::path::Path::new("mangled.xml"));
            }
        }
    }

    #[test]
    fn the_ron_names_what_the_xml_names() {
        let imported = to_ron(CORNELL, &[("spp".into(), "9".into())]).unwrap();
        for needle in [
            "\"white\": Lambert(albedo: (0.885809, 0.698859, 0.666422))",
            "(name: \"small-box\", transform: (matrix: [",
            "shape: Box(min: (-1, -1, -1), max: (1, 1, 1)), material: \"white\"",
            "emitter: Area(radiance: (18.387, 13.9873, 6.75357))",
            "filter: \"gaussian\", spp: 9",
            "\"max-depth\": 7",
        ] {
            assert!(
                imported.ron.contains(needle),
                "no {needle} in\n{}",
                imported.ron
            );
        }
    }
}
