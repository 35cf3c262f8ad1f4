//! Mitsuba 3's plugins, one by one, as raylab's scene description.

use super::xml::{at, attr, major_version, position, snake_case, value, Located, Params, Value};
pub use crate::formats::import::Imported;
use crate::formats::import::{placed, ImportOptions};
use crate::formats::schema::{
    CameraDesc, ColorDesc, EmitterDesc, EntityDesc, FloatDesc, Ior, MaterialDesc, NamedTable,
    RenderDesc, SceneFile, ShapeDesc, V3,
};
use crate::formats::spectra::{self, Use};
use glam::Affine3A;
use raylab_integrators::sampler::SamplerKind;
use roxmltree::{Document, Node};
use std::collections::HashMap;

mod bsdf;
mod medium;
mod sensor;
mod shapes;

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

    /// A point-like emitter's colour (default white), or white and the spectrum given by
    /// wavelength, which stays one (its colour is made where the scene is loaded).
    #[allow(clippy::type_complexity)]
    fn emission_or_spectrum(
        &mut self,
        name: &str,
    ) -> Result<([f32; 3], Option<Vec<(f64, f64)>>), Located> {
        let spectrum = self.spectrum(name);
        let rgb = self.emission(name)?.unwrap_or([1.0; 3]);
        Ok(match spectrum {
            Some(pairs) => ([1.0; 3], Some(pairs)),
            None => (rgb, None),
        })
    }

    /// Property `name` if it is a spectrum given by wavelength (left in place), as pairs.
    fn spectrum(&self, name: &str) -> Option<Vec<(f64, f64)>> {
        match self.values.get(name) {
            Some((Value::Spectrum(pairs), _)) => Some(pairs.clone()),
            _ => None,
        }
    }

    fn transform(&mut self, name: &str) -> Result<Option<Affine3A>, Located> {
        self.typed(name, "a <transform>", |v| match v {
            Value::Transform(m) => Some(m),
            _ => None,
        })
    }

    /// An index of refraction: a number, or a name of the table of dielectrics (`"bk7"`).
    fn ior(&mut self, name: &str) -> Result<Option<Ior>, Located> {
        match self.take(name) {
            None => Ok(None),
            Some((Value::Float(v), _)) => Ok(Some(Ior(v))),
            Some((Value::String(s), n)) => raylab_integrators::bsdf::ior::dielectric(&s)
                .map(|v| Some(Ior(v)))
                .map_err(|e| at(self.doc, n, e)),
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

/// The conversion's state: the output's parts and the named things seen so far.
struct Converter<'a, 'input> {
    doc: &'a Document<'input>,
    params: Params,
    /// Top-level plugins with an id, for `<ref>`.
    ids: HashMap<String, Node<'a, 'input>>,
    /// The materials made so far, by name, and the name of each BSDF node that made one.
    materials: Vec<(String, MaterialDesc)>,
    material_of: HashMap<roxmltree::NodeId, String>,
    /// The name given to Mitsuba's default BSDF, once a shape needs it.
    default_material: Option<String>,
    entities: Vec<EntityDesc>,
    /// The participating media made so far, by name, and the one around the camera.
    media: Vec<(String, crate::formats::schema::MediumDesc)>,
    camera_medium: Option<String>,
    /// The name of each medium node converted so far.
    medium_of: HashMap<roxmltree::NodeId, String>,
    /// `--approximate`, and what it replaced.
    approximate: bool,
    approximated: Vec<String>,
    /// The scene's folder and its `<path>` folders, to find the files it names.
    /// The scene's files, when it has a folder: names are found through them (and recorded).
    files: Option<crate::formats::access::SceneFiles>,
    search: Vec<String>,
    /// Mesh assets of shapegroups, by name.
    meshes: Vec<(String, ShapeDesc)>,
    environment: Option<V3>,
    camera: Option<CameraDesc>,
    render: RenderDesc,
    /// Whether the scene's <integrator> was read (a second one is an error).
    integrator_read: bool,
    report: Vec<String>,
    /// The BSDFs being converted, outermost first (a nested or referenced one inside).
    bsdfs_open: Vec<roxmltree::NodeId>,
    /// Each BSDF converted so far, by its node.
    bsdf_of: HashMap<roxmltree::NodeId, MaterialDesc>,
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
        let mut props = Props::read(&self.params, self.doc, node)?;
        for (value, at_node) in props.values.values_mut() {
            if let Value::SpectrumFile(name) = value {
                let pairs = self
                    .spectrum_file(name)
                    .map_err(|e| at(self.doc, *at_node, e))?;
                *value = Value::Spectrum(pairs);
            }
        }
        Ok(props)
    }

    /// The spectrum in the file `name` (Mitsuba's `.spd`: a `wavelength value` pair per line,
    /// `#` comments), found as [`Self::file_name`] finds files.
    fn spectrum_file(&self, name: &str) -> Result<Vec<(f64, f64)>, String> {
        let what = format!("<spectrum filename=\"{name}\">");
        let files = self
            .files
            .as_ref()
            .ok_or_else(|| format!("{what}: no scene folder to read it from"))?;
        let path = files
            .named(&self.file_name(name.to_string()))
            .map_err(|e| format!("{what}: {e}"))?;
        let text = crate::files::read_text_capped(&path, crate::files::MAX_TEXT)
            .map_err(|e| format!("{what}: cannot read `{}`: {e}", path.display()))?;
        let mut pairs = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let numbers: Vec<f64> = line
                .split_whitespace()
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|_| format!("{what}: line {}: `{line}` is not two numbers", i + 1))?;
            match numbers[..] {
                [nm, v] if nm.is_finite() && v.is_finite() => pairs.push((nm, v)),
                _ => {
                    return Err(format!(
                        "{what}: line {}: `{line}` is not a wavelength and a value",
                        i + 1
                    ))
                }
            }
        }
        raylab_integrators::spectrum::curve::Curve::table(&crate::formats::texture_desc::narrow(
            &pairs,
        ))
        .map_err(|e| format!("{what}: {e}"))?;
        Ok(pairs)
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
}

/// Converts the Mitsuba XML `text` into a scene description; `overrides` are `-D` parameters.
pub fn to_ron(text: &str, overrides: &[(String, String)]) -> Result<Imported, Located> {
    let options = ImportOptions {
        defines: overrides.to_vec(),
        approximate: false,
        ..ImportOptions::default()
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
    files: Option<&crate::formats::access::SceneFiles>,
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
        media: Vec::new(),
        camera_medium: None,
        medium_of: HashMap::new(),
        approximate: options.approximate,
        approximated: Vec::new(),
        files: files.cloned(),
        search: search.to_vec(),
        meshes: Vec::new(),
        environment: None,
        camera: None,
        // Mitsuba 3 picks an emitter uniformly, then a point on it by area.
        render: RenderDesc {
            light_selection: crate::formats::schema::LightSelection::Uniform,
            ..RenderDesc::default()
        },
        integrator_read: false,
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
            // Converted when a shape or the sensor refers to it (unused ones are left out).
            "medium" => {}
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
    let header =
        format!("Imported by raylab from a Mitsuba 3 scene (its <scene> at {line}:{col}).");
    let scene = SceneFile {
        camera,
        render: c.render,
        materials: NamedTable(c.materials),
        meshes: NamedTable(c.meshes),
        environment: c.environment,
        media: NamedTable(c.media),
        camera_medium: c.camera_medium,
        entities: c.entities,
    };
    // Places in the text converted (no file: the caller knows which file each came from).
    let mut origins = crate::formats::import::Origins::default();
    for (entity, name, (line, col)) in c.origins {
        let table = if entity {
            &mut origins.entities
        } else {
            &mut origins.materials
        };
        table.insert(name, (std::path::PathBuf::new(), line, col));
    }
    Ok(Imported {
        scene,
        header,
        report: c.report,
        approximated: c.approximated,
        origins,
    })
}

#[cfg(test)]
mod tests;
