//! pbrt-v4's directives, one by one, as raylab's scene description: the graphics state
//! (transform, orientation, material, area light), the scene-wide settings, and the shapes and
//! lights.

use super::directives::{Directive, Parser};
use super::materials::{self, Notes, Textures};
use super::params::{Colour, Located, ParamList};
use super::tokens::{Pos, Tokens};
use crate::formats::access::SceneFiles;
use crate::formats::import::{placed, ImportOptions, Imported};
use crate::formats::schema::{
    CameraDesc, ColorDesc, EmitterDesc, EntityDesc, FloatDesc, LightSelection, MaterialDesc,
    NamedTable, RenderDesc, SceneFile, ShapeDesc, TransformDesc,
};
use glam::{Affine3A, DMat4, DVec3, DVec4};
use raylab_integrators::sampler::SamplerKind;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

mod curves;
mod lights;
mod media;
mod media_presets;
mod options;
mod shapes;
mod textures;

/// Includes nested deeper than this are refused (a cycle is caught before).
const MAX_INCLUDE_DEPTH: usize = 32;

/// The most text a scene may read through its includes, all files together (a file that
/// includes another twice at each level would otherwise read it 2^depth times).
const MAX_INCLUDED_BYTES: u64 = 4 * crate::files::MAX_TEXT;

/// Memory reading a byte of pbrt text takes at its peak (its numbers, the RON made of them
/// and the shapes made of that): measured 27 for a 16 MB list of one-digit numbers.
const BYTES_PER_TEXT_BYTE: u64 = 32;

/// The most files a scene may include, counting each include of a file.
const MAX_INCLUDES: usize = 10_000;

/// `AreaLightSource diffuse`: its radiance, and the spectrum behind it with the factor it was
/// scaled by (given as a spectrum), whether it is two-sided, its `power`, its place.
#[derive(Clone, Debug)]
struct AreaLight {
    radiance: [f64; 3],
    spectrum: Option<(Vec<(f64, f64)>, f64)>,
    two_sided: bool,
    power: Option<f64>,
    pos: Pos,
}

/// What `AttributeBegin` saves.
#[derive(Clone)]
struct State {
    ctm: DMat4,
    reverse: bool,
    /// The current material: a description (`Material`) or the name of a material of the
    /// table (`NamedMaterial`); `None` is `interface` (no surface).
    material: Current,
    /// `AreaLightSource diffuse`.
    area: Option<AreaLight>,
    /// After `ActiveTransform EndTime`: transforms set the shutter's end only.
    end_time_only: bool,
    /// `MediumInterface`: the media either side of the shapes to come.
    medium: media::MediumSides,
}

#[derive(Clone)]
enum Current {
    Desc {
        desc: Option<Box<MaterialDesc>>,
        kind: String,
        /// The description's [`textures::material_key`], made once per directive (shapes
        /// under it look their material up by it).
        key: String,
    },
    Named(String),
}

/// A shape of an object definition, placed again by each `ObjectInstance`.
struct ObjectShape {
    /// A shape that is a triangle mesh (for the `meshes` table), or any other shape.
    shape: ShapeDesc,
    is_mesh: bool,
    material: String,
    /// Its transform inside the definition.
    ctm: DMat4,
    flip: bool,
    name: String,
    /// The media it bounds, if any.
    medium: Option<crate::formats::schema::MediumInterfaceDesc>,
}

/// The camera as the scene gives it, placed once the film is known.
struct CameraSpec {
    camera_from_world: DMat4,
    fov: f64,
    screen: Option<[f64; 4]>,
    aspect: Option<f64>,
    pos: Pos,
}

struct Converter<'a> {
    files: &'a SceneFiles,
    options: &'a ImportOptions,
    /// Every file read, by index (tokens' `Pos::file`).
    paths: Vec<PathBuf>,
    /// Canonical paths of the files being read, innermost last (cycles).
    reading: Vec<PathBuf>,
    /// Bytes of text read through includes so far.
    included_bytes: u64,
    /// Bytes of text read so far, the scene's and its includes'.
    text_bytes: u64,
    /// The memory the process could allocate when the conversion began.
    room: crate::system::Room,
    state: State,
    stack: Vec<(State, &'static str, Pos)>,
    named_coords: HashMap<String, DMat4>,
    world: bool,
    camera: Option<CameraSpec>,
    /// The shutter's open time, which scales the image.
    exposure: f64,
    film: (i64, i64, Option<[f64; 4]>),
    filter: String,
    spp: i64,
    /// The `Sampler`'s kind (pbrt-v4's default, `zsobol`, without one).
    sampler: SamplerKind,
    /// The integrator's `lightsampler` (pbrt-v4's default, `bvh`, without one).
    light_selection: LightSelection,
    /// The `Integrator` directive as raylab's integrator.
    integrator: Option<options::IntegratorChoice>,
    materials: Vec<(String, MaterialDesc)>,
    /// The materials by name, and the first name of each description (anonymous materials
    /// that are alike share one).
    material_descs: HashMap<String, MaterialDesc>,
    material_by_desc: HashMap<String, String>,
    /// `MakeNamedMaterial` names: their table names, `None` for an `interface`.
    named_materials: HashMap<String, Option<String>>,
    textures: Textures,
    meshes: Vec<(String, ShapeDesc)>,
    mesh_names: std::collections::HashSet<String>,
    objects: HashMap<String, Vec<ObjectShape>>,
    /// The object being defined: its name and shapes so far.
    defining: Option<(String, Vec<ObjectShape>, Pos)>,
    entities: Vec<EntityDesc>,
    /// The participating media made so far, the ones used, and the one around the camera.
    media: media::MediaBook,
    /// The entity the last curves joined, which the next may join ([`Converter::curve`]).
    curve_group: Option<usize>,
    /// The curve segments made so far, and the triangles of as much memory.
    curve_segments: u64,
    curve_triangles: u64,
    environment: Option<[f64; 3]>,
    report: Vec<String>,
    approximated: Vec<String>,
}

impl Notes for Converter<'_> {
    fn report(&mut self, line: String) {
        if !self.report.contains(&line) {
            self.report.push(line);
        }
    }

    fn approximate(&mut self, pos: Pos, what: String) -> Result<(), Located> {
        if !self.options.approximate {
            return Err((pos, format!("{what}; give --approximate to render it so")));
        }
        let line = format!("{} (approximated)", what);
        self.report(line.clone());
        self.approximated.push(line);
        Ok(())
    }
}

fn d3(v: [f64; 3]) -> DVec3 {
    DVec3::from_array(v)
}

fn f3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

/// `m` as an affine transform, or why not (a projective last row).
fn affine(m: &DMat4) -> Option<Affine3A> {
    let row = m.row(3);
    if (row - DVec4::W).abs().max_element() > 1e-9 {
        return None;
    }
    let a = Affine3A::from_mat4(m.as_mat4());
    a.is_finite().then_some(a)
}

impl<'a> Converter<'a> {
    fn what(&self, d: &Directive) -> String {
        match d.strings.first() {
            Some(s) => format!("{} \"{s}\"", d.name),
            None => d.name.clone(),
        }
    }

    fn params(&self, d: &mut Directive) -> Result<ParamList, Located> {
        ParamList::new(d.pos, self.what(d), std::mem::take(&mut d.params))
    }

    fn place(&self, pos: Pos) -> String {
        let file = self.paths[pos.file]
            .file_name()
            .map_or_else(String::new, |f| f.to_string_lossy().into_owned());
        format!("{file}:{}", pos.line)
    }

    /// Reads and runs the file `path`.
    fn run_file(&mut self, path: &Path, text: &str) -> Result<(), Located> {
        let index = self.paths.len();
        self.paths.push(path.to_path_buf());
        // What reading the text will hold at its peak, all files so far together, checked
        // before it is read.
        self.text_bytes += text.len() as u64;
        let needed = self.text_bytes.saturating_mul(BYTES_PER_TEXT_BYTE);
        self.room
            .check(
                needed,
                &format!("{} MB of pbrt text", self.text_bytes >> 20),
            )
            .map_err(|message| {
                let start = Pos {
                    file: index,
                    line: 1,
                    col: 1,
                };
                (start, message)
            })?;
        let end_line = text.lines().count().max(1) as u32;
        let mut parser = Parser::new(
            Tokens::new(text, index),
            Pos {
                file: index,
                line: end_line,
                col: 1,
            },
        );
        while let Some(d) = parser.directive()? {
            self.directive(d)?;
        }
        Ok(())
    }

    /// `Include` and `Import`: the named file, relative to the main scene's folder, read in
    /// place.
    fn include(&mut self, d: &Directive) -> Result<(), Located> {
        let name = &d.strings[0];
        if self.reading.len() >= MAX_INCLUDE_DEPTH {
            return Err((
                d.pos,
                format!("{}: includes nest deeper than {MAX_INCLUDE_DEPTH}", d.name),
            ));
        }
        let file = self.files.named(name).map_err(|e| (d.pos, e))?;
        let real = file.canonicalize().unwrap_or_else(|_| file.clone());
        if self.reading.contains(&real) {
            return Err((
                d.pos,
                format!(
                    "{} \"{name}\": the file includes itself (a cycle of includes)",
                    d.name
                ),
            ));
        }
        let text = crate::files::read_text_capped(
            &file,
            crate::files::MAX_TEXT.min(MAX_INCLUDED_BYTES - self.included_bytes),
        )
        .map_err(|e| {
            (
                d.pos,
                format!(
                    "{} \"{name}\": cannot read `{}`: {e}",
                    d.name,
                    file.display()
                ),
            )
        })?;
        self.included_bytes += text.len() as u64;
        if self.paths.len() >= MAX_INCLUDES {
            return Err((
                d.pos,
                format!(
                    "{} \"{name}\": the scene includes more than {MAX_INCLUDES} files",
                    d.name
                ),
            ));
        }
        if self.included_bytes >= MAX_INCLUDED_BYTES {
            return Err((
                d.pos,
                format!(
                    "{} \"{name}\": the scene's includes hold more than {} MB of text",
                    d.name,
                    MAX_INCLUDED_BYTES >> 20
                ),
            ));
        }
        self.reading.push(real);
        let saved = (d.name == "Import").then(|| self.state.clone());
        self.run_file(&file, &text)?;
        if let Some(state) = saved {
            self.state = state;
        }
        self.reading.pop();
        Ok(())
    }

    fn directive(&mut self, mut d: Directive) -> Result<(), Located> {
        let n = &d.numbers;
        let world_only = |c: &Self, d: &Directive| -> Result<(), Located> {
            if c.world {
                Ok(())
            } else {
                Err((d.pos, format!("{} belongs after WorldBegin", d.name)))
            }
        };
        let before_world = |c: &Self, d: &Directive| -> Result<(), Located> {
            if c.world {
                Err((d.pos, format!("{} belongs before WorldBegin", d.name)))
            } else {
                Ok(())
            }
        };
        let transforms = [
            "Identity",
            "Translate",
            "Scale",
            "Rotate",
            "LookAt",
            "Transform",
            "ConcatTransform",
            "CoordSysTransform",
        ];
        if self.state.end_time_only && transforms.contains(&d.name.as_str()) {
            // The shutter's end: motion blur, which raylab does not render.
            return Ok(());
        }
        match d.name.as_str() {
            "Include" | "Import" => self.include(&d)?,
            "Identity" => self.state.ctm = DMat4::IDENTITY,
            "Translate" => self.state.ctm *= DMat4::from_translation(DVec3::new(n[0], n[1], n[2])),
            "Scale" => self.state.ctm *= DMat4::from_scale(DVec3::new(n[0], n[1], n[2])),
            "Rotate" => {
                let axis = DVec3::new(n[1], n[2], n[3]);
                if axis.length() == 0.0 {
                    return Err((d.pos, "Rotate: the axis is zero".into()));
                }
                self.state.ctm *= DMat4::from_axis_angle(axis.normalize(), n[0].to_radians());
            }
            "LookAt" => {
                let (eye, look, up) = (DVec3::new(n[0], n[1], n[2]), DVec3::new(n[3], n[4], n[5]), DVec3::new(n[6], n[7], n[8]));
                let dir = (look - eye).normalize();
                let right = up.normalize().cross(dir);
                if !dir.is_finite() || right.length().is_nan() || right.length() < 1e-9 {
                    return Err((d.pos, "LookAt: the eye and the target coincide, or up is along the view".into()));
                }
                // pbrt-v4's frame: x = up x dir (the image's right), y = dir x x, z = dir.
                let right = right.normalize();
                let new_up = dir.cross(right);
                let camera_to_world = DMat4::from_cols(right.extend(0.0), new_up.extend(0.0), dir.extend(0.0), eye.extend(1.0));
                self.state.ctm *= camera_to_world.inverse();
            }
            "Transform" | "ConcatTransform" => {
                // Column by column: elements 12 to 14 are the translation.
                let m = DMat4::from_cols_slice(n);
                if d.name == "Transform" {
                    self.state.ctm = m;
                } else {
                    self.state.ctm *= m;
                }
            }
            "CoordinateSystem" => {
                self.named_coords.insert(d.strings[0].clone(), self.state.ctm);
            }
            "CoordSysTransform" => {
                let name = &d.strings[0];
                self.state.ctm = *self.named_coords.get(name).ok_or_else(|| {
                    (d.pos, format!("CoordSysTransform: no coordinate system is named \"{name}\""))
                })?;
            }
            "ReverseOrientation" => self.state.reverse = !self.state.reverse,
            "AttributeBegin" | "TransformBegin" => {
                let kind = if d.name == "AttributeBegin" { "AttributeEnd" } else { "TransformEnd" };
                if self.stack.len() > 10_000 {
                    return Err((d.pos, "AttributeBegin nests too deep".into()));
                }
                self.stack.push((self.state.clone(), kind, d.pos));
            }
            "AttributeEnd" | "TransformEnd" => {
                let Some((saved, kind, _)) = self.stack.pop() else {
                    return Err((d.pos, format!("{} without a matching Begin", d.name)));
                };
                if kind == "ObjectEnd" {
                    return Err((d.pos, format!("{} inside an object definition closes what ObjectBegin opened: use ObjectEnd", d.name)));
                }
                // pbrt-v4 reads TransformBegin/End as AttributeBegin/End: all is restored.
                self.state = saved;
            }
            "WorldBegin" => {
                before_world(self, &d)?;
                self.check_camera_medium()?;
                self.world = true;
                self.state.ctm = DMat4::IDENTITY;
                self.state.end_time_only = false;
                self.named_coords.insert("world".into(), DMat4::IDENTITY);
            }
            "WorldEnd" => self.report("WorldEnd: a pbrt-v3 directive; pbrt-v4 ends the world at the end of the file".into()),
            "Option" => {
                let name = d.params[0].name.clone();
                if name == "forcediffuse" {
                    self.approximate(d.pos, "Option forcediffuse (every material diffuse) ignored".into())?;
                } else if name == "rendercoordsys" {
                    self.render_space(&d)?;
                } else {
                    self.report(format!("Option {name}: ignored (it changes how pbrt-v4 runs, not the image it converges to)"));
                }
            }
            "ColorSpace" => {
                if d.strings[0] != "srgb" {
                    return Err((d.pos, format!("ColorSpace \"{}\": raylab renders in linear sRGB only", d.strings[0])));
                }
            }
            "Attribute" => {
                return Err((d.pos, "Attribute (shared default parameters) is not supported: give the parameters on each directive".into()))
            }
            "TransformTimes" => {}
            "ActiveTransform" => match d.strings[0].as_str() {
                "All" | "StartTime" => self.state.end_time_only = false,
                "EndTime" => {
                    self.approximate(d.pos, "ActiveTransform EndTime: motion blur, ignored: raylab renders the shutter's start".into())?;
                    self.state.end_time_only = true;
                }
                other => return Err((d.pos, format!("ActiveTransform {other}: StartTime, EndTime or All"))),
            },
            "MakeNamedMedium" => self.make_named_medium(&mut d)?,
            "MediumInterface" => self.medium_interface(&d),
            "Camera" => {
                before_world(self, &d)?;
                self.camera(&mut d)?;
            }
            "Film" => {
                before_world(self, &d)?;
                self.film(&mut d)?;
            }
            "PixelFilter" => {
                before_world(self, &d)?;
                self.pixel_filter(&mut d)?;
            }
            "Sampler" => {
                before_world(self, &d)?;
                let mut p = self.params(&mut d)?;
                // The stratified sampler counts xsamples x ysamples (4 x 4 by default), the
                // others pixelsamples (16 by default).
                let spp = if d.strings[0] == "stratified" {
                    let x = p.integer("xsamples")?.unwrap_or(4);
                    let y = p.integer("ysamples")?.unwrap_or(4);
                    x.checked_mul(y).filter(|_| x > 0 && y > 0)
                } else {
                    Some(p.integer("pixelsamples")?.unwrap_or(16))
                };
                match spp {
                    Some(spp) if (1..=1 << 24).contains(&spp) => self.spp = spp,
                    _ => return Err((d.pos, "Sampler: the sample count must lie in 1..=16777216".into())),
                }
                p.ignore(&["seed", "jitter", "randomization", "dimensions"]);
                p.finish()?;
                self.sampler = self.sampler_kind(&d)?;
            }
            "Integrator" => {
                before_world(self, &d)?;
                self.integrator(&mut d)?;
            }
            "Accelerator" => {
                let p = self.params(&mut d)?;
                drop(p);
                self.report("Accelerator: ignored (raylab builds its own BVH)".into());
            }
            "MakeNamedMaterial" => {
                world_only(self, &d)?;
                let name = d.strings[0].clone();
                let mut p = self.params(&mut d)?;
                let kind = p.string("type")?.ok_or_else(|| (d.pos, format!("MakeNamedMaterial \"{name}\" needs \"string type\"")))?;
                let desc = self.material(&kind, &mut p)?;
                if self.named_materials.contains_key(&name) {
                    return Err((d.pos, format!("MakeNamedMaterial: \"{name}\" is defined twice")));
                }
                // An `interface` (a medium's boundary, no surface) has no table entry.
                let table_name = desc.map(|desc| self.add_material(&name, desc));
                self.named_materials.insert(name, table_name);
            }
            "NamedMaterial" => {
                let name = &d.strings[0];
                let table_name = self.named_materials.get(name).cloned().ok_or_else(|| {
                    (d.pos, format!("NamedMaterial: no material is named \"{name}\" (MakeNamedMaterial must come before)"))
                })?;
                self.state.material = match table_name {
                    Some(table_name) => Current::Named(table_name),
                    None => Current::Desc {
                        desc: None,
                        kind: "interface".into(),
                        key: String::new(),
                    },
                };
            }
            "Material" => {
                world_only(self, &d)?;
                let kind = d.strings[0].clone();
                let mut p = self.params(&mut d)?;
                let desc = self.material(&kind, &mut p)?;
                let key = desc.as_ref().map(textures::material_key).unwrap_or_default();
                self.state.material = Current::Desc {
                    desc: desc.map(Box::new),
                    kind,
                    key,
                };
            }
            "Texture" => {
                world_only(self, &d)?;
                self.texture(&mut d)?;
            }
            "LightSource" => {
                world_only(self, &d)?;
                self.light(&mut d)?;
            }
            "AreaLightSource" => {
                world_only(self, &d)?;
                self.area_light(&mut d)?;
            }
            "Shape" => {
                world_only(self, &d)?;
                self.shape(&mut d)?;
            }
            "ObjectBegin" => {
                world_only(self, &d)?;
                if let Some((name, _, _)) = &self.defining {
                    return Err((d.pos, format!("ObjectBegin inside the definition of \"{name}\"")));
                }
                self.stack.push((self.state.clone(), "ObjectEnd", d.pos));
                self.defining = Some((d.strings[0].clone(), Vec::new(), d.pos));
            }
            "ObjectEnd" => {
                let Some((name, shapes, _)) = self.defining.take() else {
                    return Err((d.pos, "ObjectEnd without ObjectBegin".into()));
                };
                match self.stack.pop() {
                    Some((saved, "ObjectEnd", _)) => self.state = saved,
                    _ => return Err((d.pos, "ObjectEnd closes an AttributeBegin: use AttributeEnd".into())),
                }
                if self.objects.insert(name.clone(), shapes).is_some() {
                    return Err((d.pos, format!("ObjectBegin: \"{name}\" is defined twice")));
                }
            }
            "ObjectInstance" => {
                world_only(self, &d)?;
                self.instance(&d)?;
            }
            other => return Err((d.pos, format!("{other} is not supported"))),
        }
        Ok(())
    }
}

/// A pbrt-v4 error: the file, line, column and message.
pub type PbrtError = (PathBuf, u32, u32, String);

/// Converts the pbrt-v4 scene `text` of the file `path` into RON; `Include`d files are read
/// through `files` (under the scene's folder or an allowed one).
pub fn to_ron(
    path: &Path,
    text: &str,
    files: &SceneFiles,
    options: &ImportOptions,
) -> Result<Imported, PbrtError> {
    // pbrt-v4's material before any `Material`: diffuse 0.5.
    let default_material = MaterialDesc::Lambert {
        albedo: ColorDesc::Constant([0.5; 3]),
    };
    let mut c = Converter {
        files,
        options,
        paths: Vec::new(),
        included_bytes: 0,
        text_bytes: 0,
        room: crate::system::Room::now(),
        reading: vec![path.canonicalize().unwrap_or_else(|_| path.to_path_buf())],
        state: State {
            ctm: DMat4::IDENTITY,
            reverse: false,
            material: Current::Desc {
                key: textures::material_key(&default_material),
                desc: Some(Box::new(default_material)),
                kind: "diffuse".into(),
            },
            area: None,
            end_time_only: false,
            medium: media::MediumSides::vacuum(),
        },
        stack: Vec::new(),
        named_coords: HashMap::new(),
        world: false,
        camera: None,
        exposure: 1.0,
        film: (1280, 720, None),
        filter: "gaussian(stddev: 0.5, radius: 1.5)".into(),
        spp: 16,
        sampler: SamplerKind::ZSobol,
        light_selection: LightSelection::Bvh,
        integrator: None,
        materials: Vec::new(),
        material_descs: HashMap::new(),
        material_by_desc: HashMap::new(),
        named_materials: HashMap::new(),
        textures: Textures::default(),
        meshes: Vec::new(),
        mesh_names: std::collections::HashSet::new(),
        objects: HashMap::new(),
        defining: None,
        entities: Vec::new(),
        media: media::MediaBook::default(),
        curve_group: None,
        curve_segments: 0,
        curve_triangles: 0,
        environment: None,
        report: Vec::new(),
        approximated: Vec::new(),
    };
    let located = |c: &Converter, (pos, msg): Located| -> PbrtError {
        let file = c
            .paths
            .get(pos.file)
            .cloned()
            .unwrap_or_else(|| path.to_path_buf());
        (file, pos.line, pos.col, msg)
    };
    let root = Pos {
        file: 0,
        line: 1,
        col: 1,
    };
    let result = c.run_file(path, text).and_then(|()| {
        if let Some((_, kind, pos)) = c.stack.last() {
            return Err((
                *pos,
                format!("not closed: no {kind} before the end of the file"),
            ));
        }
        if !c.world {
            return Err((root, "the scene has no WorldBegin".into()));
        }
        if c.entities.is_empty() && c.environment.is_none() {
            return Err((root, "the scene has no shapes or lights".into()));
        }
        c.finish_media()?;
        c.camera_desc(root)
    });
    let camera = result.map_err(|e| located(&c, e))?;
    if c.camera.is_none() {
        c.report.push("Camera: none given; pbrt-v4's default, a perspective camera of fov 90 at the origin looking along +z".into());
    }
    let (integrator, mut params) = c.integrator_setting();
    if integrator == "sppm" {
        // pbrt-v4 traces as many photons per pass as the film has pixels unless told.
        let pixels = (c.film.0 * c.film.1) as f64;
        params.entry("photons".into()).or_insert(pixels);
    }
    let header = format!(
        "Imported by raylab from a pbrt-v4 scene ({}).",
        path.file_name()
            .map_or_else(String::new, |f| f.to_string_lossy().into_owned())
    );
    let filter = c.filter.parse().map_err(|e| located(&c, (root, e)))?;
    let spp = u32::try_from(c.spp)
        .map_err(|_| located(&c, (root, "the sample count must be 1 to 2^24".into())))?;
    let scene = SceneFile {
        camera,
        render: RenderDesc {
            integrator: integrator.to_string(),
            spp,
            params,
            filter,
            sampler: c.sampler,
            light_selection: c.light_selection,
            ..RenderDesc::default()
        },
        materials: NamedTable(c.materials),
        meshes: NamedTable(c.meshes),
        environment: c.environment.map(|env| env.map(|x| x as f32)),
        media: NamedTable(c.media.made),
        camera_medium: c.media.camera.map(|(name, _)| name),
        entities: c.entities,
    };
    Ok(Imported {
        scene,
        header,
        report: c.report,
        approximated: c.approximated,
        origins: Default::default(),
    })
}

#[cfg(test)]
mod tests;
