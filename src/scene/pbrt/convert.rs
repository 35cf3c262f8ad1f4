//! pbrt-v4's directives, one by one, as raylab's RON: the graphics state (transform,
//! orientation, material, area light), the scene-wide settings, and the shapes and lights.

use super::directives::{Directive, Parser};
use super::materials::{self, Notes, Textures};
use super::params::{Colour, Located, ParamList};
use super::tokens::{Pos, Tokens};
use crate::scene::access::SceneFiles;
use crate::scene::import::{matrix, num, quote, v3, ImportOptions, Imported, RonScene};
use glam::{Affine3A, DMat4, DVec3, DVec4};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

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

/// What `AttributeBegin` saves.
#[derive(Clone)]
struct State {
    ctm: DMat4,
    reverse: bool,
    /// The current material: a RON description (`Material`) or a material's RON name
    /// (`NamedMaterial`); `None` is `interface` (no surface).
    material: Current,
    /// `AreaLightSource diffuse`: (radiance, two-sided, its place).
    area: Option<([f64; 3], bool, Option<f64>, Pos)>,
    /// After `ActiveTransform EndTime`: transforms set the shutter's end only.
    end_time_only: bool,
}

#[derive(Clone)]
enum Current {
    Desc { ron: Option<String>, kind: String },
    Named(String),
}

/// A shape of an object definition, placed again by each `ObjectInstance`.
struct ObjectShape {
    /// A RON shape that is a triangle mesh (for the `meshes` table), or any other shape.
    shape: String,
    is_mesh: bool,
    material: String,
    /// Its transform inside the definition.
    ctm: DMat4,
    flip: bool,
    name: String,
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
    integrator: Option<String>,
    materials: Vec<(String, String)>,
    /// The materials' RON by name, and the first name of each RON (anonymous materials that
    /// are alike share one).
    material_rons: HashMap<String, String>,
    material_by_ron: HashMap<String, String>,
    named_materials: HashMap<String, String>,
    textures: Textures,
    meshes: Vec<(String, String)>,
    mesh_names: std::collections::HashSet<String>,
    objects: HashMap<String, Vec<ObjectShape>>,
    /// The object being defined: its name and shapes so far.
    defining: Option<(String, Vec<ObjectShape>, Pos)>,
    entities: Vec<String>,
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
            "MakeNamedMedium" | "MediumInterface" => {
                self.approximate(d.pos, format!("{}: participating media are not supported: ignored, surfaces render as in vacuum", d.name))?;
            }
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
                self.report(format!("Sampler \"{}\": raylab's independent sampler with the same sample count", d.strings[0]));
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
                let ron = self.material(&kind, &mut p)?;
                let ron = ron.ok_or_else(|| (d.pos, format!("MakeNamedMaterial \"{name}\": `interface` as a named material is not supported")))?;
                if self.named_materials.contains_key(&name) {
                    return Err((d.pos, format!("MakeNamedMaterial: \"{name}\" is defined twice")));
                }
                let ron_name = self.add_material(&name, ron);
                self.named_materials.insert(name, ron_name);
            }
            "NamedMaterial" => {
                let name = &d.strings[0];
                let ron = self.named_materials.get(name).cloned().ok_or_else(|| {
                    (d.pos, format!("NamedMaterial: no material is named \"{name}\" (MakeNamedMaterial must come before)"))
                })?;
                self.state.material = Current::Named(ron);
            }
            "Material" => {
                world_only(self, &d)?;
                let kind = d.strings[0].clone();
                let mut p = self.params(&mut d)?;
                let ron = self.material(&kind, &mut p)?;
                self.state.material = Current::Desc { ron, kind };
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

    fn camera(&mut self, d: &mut Directive) -> Result<(), Located> {
        let kind = d.strings[0].clone();
        if kind != "perspective" {
            return Err((
                d.pos,
                format!("Camera \"{kind}\" is not supported (perspective is)"),
            ));
        }
        let mut p = self.params(d)?;
        let fov = p.float("fov")?.unwrap_or(90.0);
        if !(fov > 0.0 && fov < 180.0) {
            return Err((
                d.pos,
                format!("Camera: fov {fov} must lie between 0 and 180 degrees"),
            ));
        }
        let screen = match p.numbers("screenwindow", &["float"])? {
            None => None,
            Some((v, pos)) => {
                let [x0, x1, y0, y1] = v[..] else {
                    return Err((pos, "Camera: screenwindow takes four numbers".into()));
                };
                if x0 >= x1 || y0 >= y1 {
                    return Err((
                        pos,
                        "Camera: screenwindow must run from low to high in x and y".into(),
                    ));
                }
                Some([x0, x1, y0, y1])
            }
        };
        let aspect = p.float("frameaspectratio")?;
        if let Some(r) = p.float("lensradius")? {
            if r > 0.0 {
                self.approximate(
                    d.pos,
                    format!("Camera: a lens of radius {r} (depth of field) rendered as a pinhole"),
                )?;
            }
        }
        // The film's exposure is the shutter's open time (pbrt-v4's imaging ratio with its
        // default ISO 100): it scales the whole image, so every emitter.
        let open = p.float("shutteropen")?.unwrap_or(0.0);
        let close = p.float("shutterclose")?.unwrap_or(1.0);
        if close.partial_cmp(&open) != Some(std::cmp::Ordering::Greater) {
            return Err((
                d.pos,
                format!("Camera: shutterclose {close} must come after shutteropen {open}"),
            ));
        }
        self.exposure = close - open;
        if self.exposure != 1.0 {
            self.report(format!(
                "Camera: an exposure time of {} scales every emitter",
                self.exposure
            ));
        }
        p.ignore(&["focaldistance"]);
        p.finish()?;
        let camera_from_world = self.state.ctm;
        if camera_from_world.determinant().abs() < 1e-12 {
            return Err((d.pos, "Camera: the transform is singular".into()));
        }
        self.named_coords
            .insert("camera".into(), camera_from_world.inverse());
        self.camera = Some(CameraSpec {
            camera_from_world,
            fov,
            screen,
            aspect,
            pos: d.pos,
        });
        Ok(())
    }

    fn film(&mut self, d: &mut Directive) -> Result<(), Located> {
        let kind = d.strings[0].clone();
        if kind != "rgb" {
            self.approximate(d.pos, format!("Film \"{kind}\": written as an rgb film"))?;
        }
        let mut p = self.params(d)?;
        let w = p.integer("xresolution")?.unwrap_or(1280);
        let h = p.integer("yresolution")?.unwrap_or(720);
        if !(1..=65536).contains(&w) || !(1..=65536).contains(&h) {
            return Err((
                d.pos,
                format!("Film: resolution {w}x{h} must be 1 to 65536 a side"),
            ));
        }
        let crop = match p.numbers("cropwindow", &["float"])? {
            None => None,
            Some((v, pos)) => {
                let [x0, x1, y0, y1] = v[..] else {
                    return Err((pos, "Film: cropwindow takes four numbers".into()));
                };
                let (x0, x1) = (x0.min(x1).clamp(0.0, 1.0), x0.max(x1).clamp(0.0, 1.0));
                let (y0, y1) = (y0.min(y1).clamp(0.0, 1.0), y0.max(y1).clamp(0.0, 1.0));
                Some([x0, x1, y0, y1])
            }
        };
        if let Some(pos) = p.present("pixelbounds") {
            return Err((
                pos,
                "Film: pixelbounds is not supported (give a cropwindow)".into(),
            ));
        }
        if let Some(s) = p.string("sensor")? {
            if s != "cie1931" {
                return Err((
                    d.pos,
                    format!("Film: sensor \"{s}\" is not supported (raylab's film is cie1931's)"),
                ));
            }
        }
        for name in ["iso", "whitebalance"] {
            if let Some(v) = p.float(name)? {
                let default = if name == "iso" { 100.0 } else { 0.0 };
                if v != default {
                    return Err((d.pos, format!("Film: {name} {v} is not supported (raylab's film has pbrt-v4's defaults)")));
                }
            }
        }
        if let Some(v) = p.float("maxcomponentvalue")? {
            if v.is_finite() {
                self.approximate(
                    d.pos,
                    format!("Film: maxcomponentvalue {v} (clamping samples, a bias) ignored"),
                )?;
            }
        }
        p.ignore(&["filename", "savefp16", "diagonal", "writefp16"]);
        p.finish()?;
        self.film = (w, h, crop);
        Ok(())
    }

    fn pixel_filter(&mut self, d: &mut Directive) -> Result<(), Located> {
        let kind = d.strings[0].clone();
        let mut p = self.params(d)?;
        let default = match kind.as_str() {
            "box" => 0.5,
            "triangle" | "mitchell" => 2.0,
            "gaussian" => 1.5,
            "sinc" | "lanczos" => 4.0,
            other => {
                return Err((
                    d.pos,
                    format!(
                    "PixelFilter \"{other}\" is not known (box, triangle, gaussian are supported)"
                ),
                ))
            }
        };
        let rx = p.float("xradius")?.unwrap_or(default);
        let ry = p.float("yradius")?.unwrap_or(default);
        if rx != ry {
            return Err((d.pos, format!("PixelFilter: xradius {rx} and yradius {ry} differ, which raylab's filters cannot")));
        }
        let filter = match kind.as_str() {
            "box" => format!("box(radius: {rx})"),
            "triangle" => format!("tent(radius: {rx})"),
            "gaussian" => {
                let s = p.float("sigma")?.unwrap_or(0.5);
                format!("gaussian(stddev: {s}, radius: {rx})")
            }
            _ => {
                p.ignore(&["B", "C", "tau"]);
                self.approximate(
                    d.pos,
                    format!("PixelFilter \"{kind}\": replaced by pbrt-v4's default gaussian"),
                )?;
                "gaussian(stddev: 0.5, radius: 1.5)".to_string()
            }
        };
        p.finish()?;
        filter
            .parse::<raylab_integrators::Filter>()
            .map_err(|e| (d.pos, format!("PixelFilter: {e}")))?;
        self.filter = filter;
        Ok(())
    }

    fn integrator(&mut self, d: &mut Directive) -> Result<(), Located> {
        let kind = d.strings[0].clone();
        let mut p = self.params(d)?;
        let depth = p.integer("maxdepth")?.unwrap_or(5);
        if depth < 0 {
            return Err((
                d.pos,
                format!("Integrator: maxdepth {depth} must be 0 or more"),
            ));
        }
        let name = match kind.as_str() {
            "path" | "volpath" | "simplepath" | "simplevolpath" | "randomwalk" => "path",
            "sppm" => "sppm",
            // pbrt-v4's light tracer; its maxdepth counts scattering events too.
            "lightpath" => "lighttracer",
            "bdpt" => "bdpt",
            "mlt" => {
                self.approximate(d.pos, format!("Integrator \"{kind}\": not in raylab yet, rendered with path (the same image, other noise)"))?;
                "path"
            }
            other => return Err((d.pos, format!("Integrator \"{other}\" is not supported (path, volpath, simplepath, randomwalk, lightpath, bdpt, sppm are)"))),
        };
        // raylab's bdpt keeps its subpaths in fixed arrays: at most 30 scattering events.
        let depth = if name == "bdpt" && depth > 30 {
            self.approximate(
                d.pos,
                format!("Integrator \"bdpt\": maxdepth {depth} cut to raylab's bdpt's 30 (paths of more bounces are left out)"),
            )?;
            30
        } else {
            depth
        };
        if p.boolean("regularize")? == Some(true) {
            self.approximate(d.pos, "Integrator: regularize (a bias) ignored".into())?;
        }
        p.ignore(&[
            "lightsampler",
            "sampleLights",
            "sampleBSDF",
            "samplelights",
            "samplebsdf",
            "bootstrapsamples",
            "chains",
            "mutationsperpixel",
            "largestepprobability",
            "sigma",
            "iterations",
            "photonsperiteration",
            "radius",
            "seed",
            "visualizestrategies",
            "visualizeweights",
        ]);
        p.finish()?;
        // pbrt-v4's maxdepth counts scattering events as raylab's max-depth does (1 is direct
        // light only).
        self.integrator = Some(format!(
            "integrator: {}, params: {{\"max-depth\": {depth}}}",
            quote(name)
        ));
        if kind != name {
            self.report(format!(
                "Integrator \"{kind}\": raylab's {name} (without media the same estimate)"
            ));
        }
        Ok(())
    }

    fn material(&mut self, kind: &str, p: &mut ParamList) -> Result<Option<String>, Located> {
        // The textures are lent out while the converter takes the notes.
        let textures = std::mem::take(&mut self.textures);
        let out = materials::material(kind, p, &textures, self);
        self.textures = textures;
        let out = out?;
        p.finish()?;
        Ok(out)
    }

    /// Adds a material under `name` (or a variant of it that is free) and returns the name.
    fn add_material(&mut self, name: &str, ron: String) -> String {
        let mut name = name.to_string();
        while self.material_rons.contains_key(&name) {
            name.push('\'');
        }
        self.material_rons.insert(name.clone(), ron.clone());
        self.material_by_ron
            .entry(ron.clone())
            .or_insert_with(|| name.clone());
        self.materials.push((name.clone(), ron));
        name
    }

    /// The RON description of the current material, `None` for `interface`.
    fn current_material_ron(&self) -> Option<String> {
        match &self.state.material {
            Current::Desc { ron, .. } => ron.clone(),
            Current::Named(name) => self.material_rons.get(name).cloned(),
        }
    }

    /// The RON name of the current material, `None` for `interface`.
    fn current_material(&mut self) -> Option<String> {
        match self.state.material.clone() {
            Current::Named(name) => Some(name),
            Current::Desc { ron: None, .. } => None,
            Current::Desc {
                ron: Some(ron),
                kind,
            } => {
                if let Some(name) = self.material_by_ron.get(&ron) {
                    return Some(name.clone());
                }
                let count = self.materials.len() + 1;
                Some(self.add_material(&format!("{kind} {count}"), ron))
            }
        }
    }

    /// The RON of the texture `name` of type `ty` (`float` or `spectrum`).
    fn named_texture(&self, ty: &str, name: &str, pos: Pos, what: &str) -> Result<String, Located> {
        let map = if ty == "float" {
            &self.textures.float
        } else {
            &self.textures.spectrum
        };
        map.get(name)
            .cloned()
            .ok_or_else(|| (pos, format!("{what}: no {ty} texture is named \"{name}\"")))
    }

    fn texture(&mut self, d: &mut Directive) -> Result<(), Located> {
        let (name, ty, class) = (
            d.strings[0].clone(),
            d.strings[1].clone(),
            d.strings[2].clone(),
        );
        let mut p = self.params(d)?;
        let what = p.what.clone();
        let mapping = |p: &mut ParamList| -> Result<[f64; 4], Located> {
            if let Some((m, pos)) = p.string_at("mapping")? {
                if m != "uv" {
                    return Err((
                        pos,
                        format!("{what}: mapping \"{m}\" is not supported (uv is)"),
                    ));
                }
            }
            Ok([
                p.float("uscale")?.unwrap_or(1.0),
                p.float("vscale")?.unwrap_or(1.0),
                p.float("udelta")?.unwrap_or(0.0),
                p.float("vdelta")?.unwrap_or(0.0),
            ])
        };
        let ron = match class.as_str() {
            "imagemap" => {
                let file = p.string("filename")?.ok_or_else(|| (d.pos, format!("{what} needs \"string filename\"")))?;
                let [su, sv, du, dv] = mapping(&mut p)?;
                let filter = match p.string("filter")?.as_deref() {
                    None | Some("bilinear") => "bilinear",
                    Some("point") => "nearest",
                    Some(f @ ("trilinear" | "ewa" | "EWA")) => {
                        self.report(format!("{what}: filter \"{f}\" as bilinear (raylab does not prefilter textures)"));
                        "bilinear"
                    }
                    Some(f) => return Err((d.pos, format!("{what}: filter \"{f}\" is not known"))),
                };
                let wrap = match p.string("wrap")?.as_deref() {
                    None | Some("repeat") => "repeat",
                    Some("clamp") => "clamp",
                    Some("octahedralsphere") | Some("black") | Some(_) => {
                        return Err((d.pos, format!("{what}: only \"repeat\" and \"clamp\" wraps are supported")))
                    }
                };
                let linear = match p.string("encoding")?.as_deref() {
                    None => {
                        let lower = file.to_ascii_lowercase();
                        ![".png", ".jpg", ".jpeg", ".tga", ".bmp"].iter().any(|e| lower.ends_with(e))
                    }
                    Some("linear") => true,
                    Some("sRGB") => false,
                    Some(e) => return Err((d.pos, format!("{what}: encoding \"{e}\" is not supported (sRGB, linear are)"))),
                };
                if p.float("scale")?.is_some_and(|s| s != 1.0) || p.boolean("invert")? == Some(true) {
                    return Err((d.pos, format!("{what}: `scale` and `invert` are not supported on image textures")));
                }
                p.ignore(&["maxanisotropy"]);
                // pbrt-v4 looks images up at (s, 1 - t); raylab at (u, v) from the top row.
                format!(
                    "Image(path: {}, filter: \"{filter}\", wrap: \"{wrap}\", raw: {linear}, uv_scale: ({}, {}), uv_offset: ({}, {}))",
                    quote(&file), num(su as f32), num(-sv as f32), num(du as f32), num((1.0 - dv) as f32)
                )
            }
            "checkerboard" => {
                if p.integer("dimension")?.is_some_and(|n| n != 2) {
                    return Err((d.pos, format!("{what}: only the 2D checkerboard is supported")));
                }
                let [su, sv, du, dv] = mapping(&mut p)?;
                let side = |p: &mut ParamList, name: &str, default: f64| -> Result<String, Located> {
                    let c = if ty == "float" { p.float_or_texture(name)? } else { p.colour(name)? };
                    match c {
                        None => Ok(num(default as f32)),
                        Some((Colour::Rgb(v), _)) => Ok(v3(v.map(|x| x as f32))),
                        Some((_, pos)) => Err((pos, format!("{what}: `{name}` must be a constant colour (raylab's checkerboard has no nested textures)"))),
                    }
                };
                let (t1, t2) = (side(&mut p, "tex1", 1.0)?, side(&mut p, "tex2", 0.0)?);
                // pbrt-v4's squares are one unit wide; Mitsuba's (raylab's) half a unit, with
                // color0 where floor(s) + floor(t) is even as pbrt's tex1.
                format!(
                    "Checkerboard(color0: {t1}, color1: {t2}, uv_scale: ({}, {}), uv_offset: ({}, {}))",
                    num((su * 0.5) as f32), num((sv * 0.5) as f32), num((du * 0.5) as f32), num((dv * 0.5) as f32)
                )
            }
            "constant" => {
                let c = if ty == "float" { p.float_or_texture("value")? } else { p.colour("value")? };
                match c {
                    None => "1.0".to_string(),
                    Some((Colour::Texture(t), pos)) => self.named_texture(&ty, &t, pos, &what)?,
                    Some((Colour::Rgb(v), _)) if ty == "float" => num(v[0] as f32),
                    Some((c, pos)) => {
                        let textures = std::mem::take(&mut self.textures);
                        let r = materials::colour(&c, pos, &what, &textures, self);
                        self.textures = textures;
                        r?
                    }
                }
            }
            "scale" => {
                // Both default to 1.
                let one = |c: Option<(Colour, Pos)>| c.or(Some((Colour::Rgb([1.0; 3]), d.pos)));
                let tex = one(if ty == "float" { p.float_or_texture("tex")? } else { p.colour("tex")? });
                let scale = one(p.float_or_texture("scale")?);
                let unit = |s: &Option<(Colour, Pos)>| match s {
                    None => true,
                    Some((Colour::Rgb(v), _)) => v[0] == 1.0,
                    _ => false,
                };
                match (tex, scale) {
                    (Some((Colour::Rgb(a), _)), Some((Colour::Rgb(s), _))) if ty == "float" => {
                        num((a[0] * s[0]) as f32)
                    }
                    (Some((Colour::Rgb(a), _)), Some((Colour::Rgb(s), _))) => {
                        v3([a[0] * s[0], a[1] * s[0], a[2] * s[0]].map(|x| x as f32))
                    }
                    (Some((Colour::Texture(t), pos)), s) if unit(&s) => {
                        self.named_texture(&ty, &t, pos, &what)?
                    }
                    _ => return Err((d.pos, format!("{what}: a scale texture is supported for a constant times a constant, or a texture times 1"))),
                }
            }
            other => return Err((d.pos, format!("{what}: texture \"{other}\" is not supported (imagemap, checkerboard, constant, scale are)"))),
        };
        p.finish()?;
        match ty.as_str() {
            "spectrum" => self.textures.spectrum.insert(name, ron),
            "float" => self.textures.float.insert(name, ron),
            other => {
                return Err((
                    d.pos,
                    format!(
                        "Texture \"{name}\": type \"{other}\" must be \"spectrum\" or \"float\""
                    ),
                ))
            }
        };
        Ok(())
    }

    /// An emitter's colour: `rgb` as it is (pbrt-v4 normalises the illuminant, so rgb
    /// (1, 1, 1) renders as 1), any other spectrum as white of luminance 1 (pbrt-v4
    /// normalises it so; raylab does not reproduce its colour), times `scale` and the
    /// camera's exposure time.
    fn light_colour(&mut self, p: &mut ParamList, name: &str) -> Result<[f64; 3], Located> {
        let scale = p.float("scale")?.unwrap_or(1.0);
        let c = match p.colour(name)? {
            None => [1.0; 3],
            Some((Colour::Rgb(v), _)) => v,
            Some((Colour::Named(n), _)) if n == "stdillum-D65" => {
                self.report(format!(
                    "{}: stdillum-D65 as white of luminance 1, as pbrt-v4 renders it",
                    p.what
                ));
                [1.0; 3]
            }
            Some((Colour::Texture(t), pos)) => {
                return Err((
                    pos,
                    format!("{}: `{name}` cannot be a texture (\"{t}\")", p.what),
                ))
            }
            Some((c, pos)) => {
                let what = match c {
                    Colour::Named(n) => format!("the spectrum \"{n}\""),
                    Colour::Blackbody(t) => format!("a blackbody of {t} K"),
                    _ => "a spectrum by wavelength".to_string(),
                };
                self.approximate(
                    pos,
                    format!("{}: `{name}` is {what}, which pbrt-v4 normalises to luminance 1: rendered white (its colour is not reproduced)", p.what),
                )?;
                [1.0; 3]
            }
        };
        if c.iter().any(|x| *x < 0.0) || scale < 0.0 {
            return Err((p.at, format!("{}: negative emission", p.what)));
        }
        Ok(c.map(|x| x * scale * self.exposure))
    }

    fn light(&mut self, d: &mut Directive) -> Result<(), Located> {
        let kind = d.strings[0].clone();
        let mut p = self.params(d)?;
        let name = format!("{kind} light ({})", self.place(d.pos));
        let m = self.state.ctm;
        let entity = match kind.as_str() {
            "point" => {
                let mut i = self.light_colour(&mut p, "I")?;
                if let Some(power) = p.float("power")? {
                    i = i.map(|x| x * power / (4.0 * std::f64::consts::PI));
                }
                let from = p.point("from")?.unwrap_or([0.0; 3]);
                let at = m * DMat4::from_translation(d3(from));
                let a = affine(&at).ok_or_else(|| (d.pos, "a projective transform".to_string()))?;
                format!(
                    "emitter: Point(intensity: {}), transform: {}",
                    v3(i.map(|x| x as f32)),
                    matrix(&a)
                )
            }
            "spot" => {
                let i = self.light_colour(&mut p, "I")?;
                let from = d3(p.point("from")?.unwrap_or([0.0; 3]));
                let to = d3(p.point("to")?.unwrap_or([0.0, 0.0, 1.0]));
                let cone = p.float("coneangle")?.unwrap_or(30.0);
                let delta = p.float("conedeltaangle")?.unwrap_or(5.0);
                // pbrt-v4's falloff: a smoothstep in the cosine over the same cone.
                let pos = m.transform_point3(from);
                let target = m.transform_point3(to);
                format!(
                    "emitter: Spot(intensity: {}, look_at: {}, cutoff_angle: {}, beam_width: {}, falloff: \"smoothstep\"), transform: (translate: {})",
                    v3(i.map(|x| x as f32)), v3(f3(target)), num(cone as f32), num((cone - delta).max(0.0) as f32), v3(f3(pos))
                )
            }
            "distant" => {
                let mut e = self.light_colour(&mut p, "L")?;
                if let Some(illum) = p.float("illuminance")? {
                    e = e.map(|x| x * illum);
                }
                let from = d3(p.point("from")?.unwrap_or([0.0; 3]));
                let to = d3(p.point("to")?.unwrap_or([0.0, 0.0, 1.0]));
                let dir = m.transform_vector3(to - from);
                if dir.length() == 0.0 {
                    return Err((
                        d.pos,
                        "LightSource \"distant\": from and to coincide".into(),
                    ));
                }
                format!(
                    "emitter: Directional(direction: {}, irradiance: {})",
                    v3(f3(dir.normalize())),
                    v3(e.map(|x| x as f32))
                )
            }
            "infinite" => {
                if let Some((file, pos)) = p.string_at("filename")? {
                    if p.present("L").is_some() || p.present("illuminance").is_some() {
                        return Err((pos, "LightSource \"infinite\": give `filename`, or `L` (and `illuminance`), not both".into()));
                    }
                    let scale = p.float("scale")?.unwrap_or(1.0) * self.exposure;
                    if let Some(portal) = p.present("portal") {
                        p.ignore(&["portal"]);
                        self.report(format!(
                            "{}: portal ignored at line {} (a sampling aid)",
                            p.what, portal.line
                        ));
                    }
                    p.finish()?;
                    // raylab's map frame has +y up where pbrt's light frame has +z: the
                    // resampled map is read through that turn, so the placement carries it.
                    let turn = DMat4::from_cols(DVec4::X, DVec4::Z, -DVec4::Y, DVec4::W);
                    let placed = affine(&(m * turn)).ok_or_else(|| {
                        (
                            d.pos,
                            "LightSource \"infinite\": a projective transform".to_string(),
                        )
                    })?;
                    self.report(format!("{}: pbrt-v4's equal-area octahedral map resampled at load into a latitude-longitude map (its nearest pixels, 4 texels across per map pixel)", p.what));
                    self.entities.push(format!(
                        "(name: {}, emitter: Environment(path: {}, scale: {}, mapping: \"octahedral\"), transform: {}),",
                        quote(&name), quote(&file), num(scale as f32), matrix(&placed)
                    ));
                    return Ok(());
                }
                let mut l = self.light_colour(&mut p, "L")?;
                if let Some(illum) = p.float("illuminance")? {
                    l = l.map(|x| x * illum / std::f64::consts::PI);
                }
                if let Some(pos) = p.present("portal") {
                    p.ignore(&["portal"]);
                    self.report(format!(
                        "{}: portal ignored at {} (a sampling aid)",
                        p.what, pos.line
                    ));
                }
                p.finish()?;
                if let Some(prev) = self.environment {
                    l = [prev[0] + l[0], prev[1] + l[1], prev[2] + l[2]];
                }
                self.environment = Some(l);
                return Ok(());
            }
            other => {
                return Err((
                    d.pos,
                    format!(
                    "LightSource \"{other}\" is not supported (point, spot, distant, infinite are)"
                ),
                ))
            }
        };
        p.finish()?;
        self.entities
            .push(format!("(name: {}, {entity}),", quote(&name)));
        Ok(())
    }

    fn area_light(&mut self, d: &mut Directive) -> Result<(), Located> {
        if d.strings[0] != "diffuse" {
            return Err((
                d.pos,
                format!(
                    "AreaLightSource \"{}\" is not supported (diffuse is)",
                    d.strings[0]
                ),
            ));
        }
        let mut p = self.params(d)?;
        if let Some(pos) = p.present("filename") {
            return Err((
                pos,
                "AreaLightSource: an emission image is not supported".into(),
            ));
        }
        let l = self.light_colour(&mut p, "L")?;
        let two = p.boolean("twosided")?.unwrap_or(false);
        let power = p.float("power")?;
        p.finish()?;
        self.state.area = Some((l, two, power, d.pos));
        Ok(())
    }

    fn shape(&mut self, d: &mut Directive) -> Result<(), Located> {
        let kind = d.strings[0].clone();
        let mut p = self.params(d)?;
        let what = p.what.clone();
        if let Some(pos) = p.present("alpha") {
            self.approximate(
                pos,
                format!("{what}: an alpha cut-out ignored (the shape is opaque)"),
            )?;
            p.ignore(&["alpha"]);
        }
        let world = self.state.ctm;
        let swaps = world.determinant() < 0.0;
        // pbrt-v4 turns a shape's normal around under ReverseOrientation and under a
        // transform that swaps handedness; raylab's flip_normals turns it around.
        let mut flip = self.state.reverse ^ swaps;
        let textured = self
            .current_material_ron()
            .is_some_and(|r| r.contains("Image(") || r.contains("Checkerboard("));
        if textured && matches!(kind.as_str(), "sphere" | "disk" | "cylinder") {
            self.approximate(d.pos, format!("{what}: a texture on a {kind} is looked up at Mitsuba's texture coordinates of it, not pbrt-v4's"))?;
        }
        let (shape, local, is_mesh, area) = match kind.as_str() {
            "sphere" => {
                let r = p.float("radius")?.unwrap_or(1.0);
                let partial = p.float("zmin")?.is_some_and(|z| z > -r)
                    | p.float("zmax")?.is_some_and(|z| z < r)
                    | p.float("phimax")?.is_some_and(|a| a < 360.0);
                if partial {
                    return Err((d.pos, format!("{what}: a partial sphere (zmin, zmax, phimax) is not supported")));
                }
                (format!("Sphere(radius: {})", num(r as f32)), DMat4::IDENTITY, false, Area::Known(4.0 * std::f64::consts::PI * r * r))
            }
            "disk" => {
                let h = p.float("height")?.unwrap_or(0.0);
                let r = p.float("radius")?.unwrap_or(1.0);
                if p.float("innerradius")?.is_some_and(|x| x > 0.0) | p.float("phimax")?.is_some_and(|a| a < 360.0) {
                    return Err((d.pos, format!("{what}: an annulus or a partial disk is not supported")));
                }
                let local = DMat4::from_translation(DVec3::new(0.0, 0.0, h)) * DMat4::from_scale(DVec3::new(r, r, 1.0));
                ("Disk".to_string(), local, false, Area::Known(std::f64::consts::PI * r * r))
            }
            "cylinder" => {
                let r = p.float("radius")?.unwrap_or(1.0);
                let (za, zb) = (p.float("zmin")?.unwrap_or(-1.0), p.float("zmax")?.unwrap_or(1.0));
                let (z0, z1) = (za.min(zb), za.max(zb));
                if p.float("phimax")?.is_some_and(|a| a < 360.0) {
                    return Err((d.pos, format!("{what}: a partial cylinder is not supported")));
                }
                (format!("Cylinder(p0: (0.0, 0.0, {}), p1: (0.0, 0.0, {}), radius: {})", num(z0 as f32), num(z1 as f32), num(r as f32)), DMat4::IDENTITY, false, Area::Known(2.0 * std::f64::consts::PI * r * (z1 - z0)))
            }
            "trianglemesh" | "bilinearmesh" => {
                let frame = MeshFrame {
                    world,
                    orient: if self.defining.is_some() { DMat4::IDENTITY } else { world },
                    default_uvs: textured,
                };
                let mesh = self.mesh(&kind, &mut p, &frame)?;
                // Each triangle already faces where pbrt-v4's does.
                flip = false;
                (mesh.ron, DMat4::IDENTITY, true, Area::PerPrimitive(mesh.areas))
            }
            "plymesh" => {
                let file = p.string("filename")?.ok_or_else(|| (d.pos, format!("{what} needs \"string filename\"")))?;
                if let Some(pos) = p.present("displacement") {
                    self.approximate(pos, format!("{what}: displacement ignored"))?;
                    p.ignore(&["displacement", "edgelength"]);
                }
                if self.defining.is_some() && flip {
                    return Err((d.pos, format!("{what}: a PLY mesh turned around (ReverseOrientation or a mirroring transform) inside an object definition is not supported")));
                }
                self.report(format!("{what}: faces by its winding; pbrt-v4 faces a PLY mesh with normals towards them"));
                (format!("Ply(path: {})", quote(&file)), DMat4::IDENTITY, true, Area::Unknown)
            }
            other => return Err((d.pos, format!("Shape \"{other}\" is not supported (sphere, disk, cylinder, trianglemesh, bilinearmesh, plymesh are)"))),
        };
        p.ignore(&["emissionfilename"]);
        p.finish()?;
        let Some(material) = self.current_material() else {
            self.approximate(
                d.pos,
                format!(
                    "{what}: a shape with the `interface` material (a medium's boundary) left out"
                ),
            )?;
            return Ok(());
        };
        let placed = world * local;
        let name = format!("{kind} ({})", self.place(d.pos));
        if let Some((shapes_name, _, _)) = &self.defining {
            if self.state.area.is_some() {
                return Err((d.pos, format!("{what}: an area light inside the object \"{shapes_name}\" (pbrt-v4 does not support them either)")));
            }
            let shape = ObjectShape {
                shape,
                is_mesh,
                material,
                ctm: placed,
                flip,
                name,
            };
            if let Some((_, shapes, _)) = &mut self.defining {
                shapes.push(shape);
            }
            return Ok(());
        }
        let a =
            affine(&placed).ok_or_else(|| (d.pos, format!("{what}: a projective transform")))?;
        let mut entity = format!(
            "(name: {}, shape: {shape}, material: {}",
            quote(&name),
            quote(&material)
        );
        if let Some((l, two, power, pos)) = self.state.area {
            let mut l = l;
            if let Some(power) = power {
                let area = area.single().map_err(|why| {
                    (
                        pos,
                        format!("AreaLightSource: `power` on this {kind} is not supported: {why}"),
                    )
                })?;
                let k = power / ((if two { 2.0 } else { 1.0 }) * area * std::f64::consts::PI);
                l = l.map(|x| x * k);
            }
            let _ = write!(
                entity,
                ", emitter: Area(radiance: {}, two_sided: {two})",
                v3(l.map(|x| x as f32))
            );
        }
        if a != Affine3A::IDENTITY {
            let _ = write!(entity, ", transform: {}", matrix(&a));
        }
        if flip {
            entity.push_str(", flip_normals: true");
        }
        entity.push_str("),");
        self.entities.push(entity);
        crate::scene::import::check_entities_made(self.entities.len(), &self.room)
            .map_err(|e| (d.pos, e))?;
        Ok(())
    }

    fn instance(&mut self, d: &Directive) -> Result<(), Located> {
        let name = &d.strings[0];
        let shapes = self.objects.get(name).ok_or_else(|| {
            (
                d.pos,
                format!(
                    "ObjectInstance: no object is named \"{name}\" (ObjectBegin must come before)"
                ),
            )
        })?;
        let ctm = self.state.ctm;
        let mut entities = Vec::new();
        let mut new_meshes = Vec::new();
        for (i, s) in shapes.iter().enumerate() {
            let placed = ctm * s.ctm;
            let a = affine(&placed)
                .ok_or_else(|| (d.pos, "ObjectInstance: a projective transform".to_string()))?;
            let shape = if s.is_mesh {
                let mesh = format!("{name}/{i}");
                if self.mesh_names.insert(mesh.clone()) {
                    new_meshes.push((mesh.clone(), s.shape.clone()));
                }
                format!("Instance(mesh: {})", quote(&mesh))
            } else {
                s.shape.clone()
            };
            let mut e = format!(
                "(name: {}, shape: {shape}, material: {}, transform: {}",
                quote(&format!("{name} @ {} / {}", self.place(d.pos), s.name)),
                quote(&s.material),
                matrix(&a)
            );
            if s.flip && !s.is_mesh {
                e.push_str(", flip_normals: true");
            }
            e.push_str("),");
            entities.push(e);
        }
        self.meshes.extend(new_meshes);
        crate::scene::import::check_entities(self.entities.len() + entities.len(), &self.room)
            .map_err(|e| (d.pos, format!("ObjectInstance: {e}")))?;
        self.entities.extend(entities);
        Ok(())
    }
}

/// What an area light's `power` needs: the area pbrt-v4 divides by. pbrt makes one light
/// per triangle or patch, each of its own world-space area, and a quadric's light takes the
/// quadric's unplaced area.
enum Area {
    Known(f64),
    PerPrimitive(Vec<f64>),
    Unknown,
}

impl Area {
    /// The one area every light of the shape divides by, if there is one.
    fn single(&self) -> Result<f64, &'static str> {
        match self {
            Area::Known(a) => Ok(*a),
            Area::PerPrimitive(areas) => {
                let first = areas.first().copied().unwrap_or(0.0);
                if areas.iter().all(|a| (a - first).abs() <= 1e-4 * first) {
                    Ok(first)
                } else {
                    Err("its triangles differ in area, and pbrt-v4 gives each the radiance of its own area")
                }
            }
            Area::Unknown => Err("its area is not known before loading"),
        }
    }
}

/// An inline mesh as RON, with the world-space area of each of its primitives (triangles, or
/// bilinear patches).
struct Mesh {
    ron: String,
    areas: Vec<f64>,
}

/// How a mesh is written: where it faces from, and whether it needs pbrt's default texture
/// coordinates.
struct MeshFrame {
    /// The placement its areas are measured after.
    world: DMat4,
    /// The space its facing is decided in: the world for a shape, the object's own space for
    /// a shape of an object definition (an instance's placement turns its normals as
    /// normals, which keeps their side).
    orient: DMat4,
    /// Write pbrt-v4's default texture coordinates when the file gives none.
    default_uvs: bool,
}

impl Converter<'_> {
    /// `trianglemesh` or `bilinearmesh` as a RON `Mesh` whose triangles each face where
    /// pbrt-v4's do (towards the given normals, else by winding, turned by ReverseOrientation
    /// and by a mirroring transform).
    fn mesh(&mut self, kind: &str, p: &mut ParamList, frame: &MeshFrame) -> Result<Mesh, Located> {
        let what = p.what.clone();
        let at = p.at;
        let (pts, ppos) = p
            .numbers("P", &["point3", "point"])?
            .ok_or_else(|| (at, format!("{what} needs \"point3 P\"")))?;
        if pts.len() % 3 != 0 {
            return Err((
                ppos,
                format!("{what}: P has {} numbers, not a multiple of 3", pts.len()),
            ));
        }
        let n = pts.len() / 3;
        let corners = if kind == "bilinearmesh" { 4 } else { 3 };
        let indices: Vec<usize> = match p.numbers("indices", &["integer"])? {
            Some((v, pos)) => {
                if v.len() % corners != 0 || v.is_empty() {
                    return Err((pos, format!("{what}: indices has {} entries, not a multiple of {corners}", v.len())));
                }
                let mut out = Vec::with_capacity(v.len());
                for i in v {
                    if i < 0.0 || i >= n as f64 || i.fract() != 0.0 {
                        return Err((pos, format!("{what}: index {i} is not one of the {n} points")));
                    }
                    out.push(i as usize);
                }
                out
            }
            None if n == corners => (0..corners).collect(),
            None => return Err((at, format!("{what} needs \"integer indices\" (only a mesh of exactly {corners} points may leave them out)"))),
        };
        let per_vertex = |p: &mut ParamList,
                          name: &str,
                          types: &[&str],
                          dim: usize|
         -> Result<Option<Vec<f64>>, Located> {
            match p.numbers(name, types)? {
                None => Ok(None),
                Some((v, _)) if v.len() == n * dim => Ok(Some(v)),
                Some((v, pos)) => Err((
                    pos,
                    format!(
                        "{what}: {name} has {} numbers for {n} points (needs {})",
                        v.len(),
                        n * dim
                    ),
                )),
            }
        };
        let normals = per_vertex(p, "N", &["normal", "normal3"], 3)?;
        let uvs = per_vertex(p, "uv", &["point2", "float"], 2)?;
        p.ignore(&["S", "faceIndices"]);
        let point = |i: usize| DVec3::new(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
        // pbrt-v4 turns the given normals around under ReverseOrientation.
        let sign = if self.state.reverse { -1.0 } else { 1.0 };
        let normal = |i: usize| {
            normals
                .as_ref()
                .map(|nv| sign * DVec3::new(nv[3 * i], nv[3 * i + 1], nv[3 * i + 2]))
        };
        let uv = |i: usize| uvs.as_ref().map(|u| [u[2 * i], u[2 * i + 1]]);
        let orient = frame.orient;
        let inv_t = orient.inverse().transpose();
        let flip = self.state.reverse ^ (orient.determinant() < 0.0);
        let default_uvs = frame.default_uvs && uvs.is_none();
        // The vertices written: the file's, or, for pbrt's default texture coordinates, each
        // primitive's own corners (pbrt gives every triangle (0,0) (1,0) (1,1) and every
        // patch its bilinear (u, v)).
        let mut verts: Vec<(usize, Option<[f64; 2]>)> = if default_uvs {
            Vec::with_capacity(indices.len())
        } else {
            (0..n).map(|i| (i, uv(i))).collect()
        };
        let mut tris: Vec<[usize; 3]> = Vec::with_capacity(indices.len() / corners * 2);
        let mut areas = Vec::with_capacity(indices.len() / corners);
        for c in indices.chunks(corners) {
            let c: Vec<usize> = if default_uvs {
                let corner_uvs: &[[f64; 2]] = if corners == 4 {
                    &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]
                } else {
                    &[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]
                };
                let start = verts.len();
                verts.extend(c.iter().zip(corner_uvs).map(|(&i, &t)| (i, Some(t))));
                (start..start + corners).collect()
            } else {
                c.to_vec()
            };
            let at_point = |v: usize| point(verts[v].0);
            let parts: Vec<[usize; 3]> = if corners == 4 {
                // pbrt-v4's patch p00 p10 p01 p11: its normal is (p10 - p00) x (p01 - p00).
                let (a, b, c2, d) = (c[0], c[1], c[2], c[3]);
                let plane = (at_point(b) - at_point(a)).cross(at_point(c2) - at_point(a));
                let off = plane
                    .normalize_or_zero()
                    .dot(at_point(d) - at_point(a))
                    .abs();
                let size = (at_point(d) - at_point(a)).length().max(1e-30);
                if off > 1e-4 * size {
                    self.approximate(
                        at,
                        format!("{what}: a curved bilinear patch split into two flat triangles"),
                    )?;
                }
                vec![[a, b, d], [a, d, c2]]
            } else {
                vec![[c[0], c[1], c[2]]]
            };
            let mut area = 0.0;
            for t in parts {
                let w = t.map(|v| frame.world.transform_point3(at_point(v)));
                area += 0.5 * (w[1] - w[0]).cross(w[2] - w[0]).length();
                let o = t.map(|v| orient.transform_point3(at_point(v)));
                let cross = (o[1] - o[0]).cross(o[2] - o[0]);
                // pbrt-v4's front: towards the interpolated normal if given, else by the
                // winding (turned by ReverseOrientation and a mirroring transform).
                let ns = t.map(|v| normal(verts[v].0));
                let front = match ns {
                    [Some(a), Some(b), Some(c)] => {
                        (inv_t.transform_vector3(a + b + c)).dot(cross) >= 0.0
                    }
                    _ => !flip,
                };
                tris.push(if front { t } else { [t[0], t[2], t[1]] });
            }
            areas.push(area);
        }
        let list = |items: Vec<String>| items.join(", ");
        let mut ron = format!(
            "Mesh(positions: [{}], indices: [{}]",
            list(verts.iter().map(|v| v3(f3(point(v.0)))).collect()),
            list(
                tris.iter()
                    .map(|t| format!("({}, {}, {})", t[0], t[1], t[2]))
                    .collect()
            )
        );
        if normals.is_some() {
            let _ = write!(
                ron,
                ", normals: [{}]",
                list(
                    verts
                        .iter()
                        .filter_map(|v| normal(v.0).map(|v| v3(f3(v))))
                        .collect()
                )
            );
        }
        if verts.iter().all(|v| v.1.is_some()) && !verts.is_empty() {
            let _ = write!(
                ron,
                ", uvs: [{}]",
                list(
                    verts
                        .iter()
                        .filter_map(|v| v.1)
                        .map(|t| format!("({}, {})", num(t[0] as f32), num(t[1] as f32)))
                        .collect()
                )
            );
        }
        ron.push(')');
        Ok(Mesh { ron, areas })
    }

    /// The camera as raylab's image-plane camera: the eye and the corners of the (cropped)
    /// screen window at distance 1, which keeps pbrt-v4's left-handed image orientation.
    fn camera_ron(&self, root: Pos) -> Result<(String, i64, i64), Located> {
        let default = CameraSpec {
            camera_from_world: DMat4::IDENTITY,
            fov: 90.0,
            screen: None,
            aspect: None,
            pos: root,
        };
        let cam = self.camera.as_ref().unwrap_or(&default);
        let (w, h, crop) = self.film;
        let aspect = cam.aspect.unwrap_or(w as f64 / h as f64);
        let [x0, x1, y0, y1] = cam.screen.unwrap_or(if aspect > 1.0 {
            [-aspect, aspect, -1.0, 1.0]
        } else {
            [-1.0, 1.0, -1.0 / aspect, 1.0 / aspect]
        });
        // Pixel bounds of the crop window, as pbrt-v4 rounds them.
        let [cx0, cx1, cy0, cy1] = crop.unwrap_or([0.0, 1.0, 0.0, 1.0]);
        let (px0, px1) = ((w as f64 * cx0).ceil(), (w as f64 * cx1).ceil());
        let (py0, py1) = ((h as f64 * cy0).ceil(), (h as f64 * cy1).ceil());
        if px1 <= px0 || py1 <= py0 {
            return Err((cam.pos, "Film: the crop window holds no pixel".into()));
        }
        let t = (cam.fov.to_radians() * 0.5).tan();
        let to_world = cam.camera_from_world.inverse();
        // Raster (x, y) to the world point on the plane z = 1 of camera space.
        let raster = |x: f64, y: f64| {
            let sx = x0 + (x / w as f64) * (x1 - x0);
            let sy = y1 - (y / h as f64) * (y1 - y0);
            f3(to_world.transform_point3(DVec3::new(sx * t, sy * t, 1.0)))
        };
        let eye = f3(to_world.transform_point3(DVec3::ZERO));
        let ron = format!(
            "ImagePlane(eye: {}, top_left: {}, top_right: {}, bottom_left: {}, bottom_right: {}, resolution: ({}, {}))",
            v3(eye),
            v3(raster(px0, py0)),
            v3(raster(px1, py0)),
            v3(raster(px0, py1)),
            v3(raster(px1, py1)),
            px1 - px0,
            py1 - py0
        );
        Ok((ron, (px1 - px0) as i64, (py1 - py0) as i64))
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
                ron: Some("Lambert(albedo: 0.5)".into()),
                kind: "diffuse".into(),
            },
            area: None,
            end_time_only: false,
        },
        stack: Vec::new(),
        named_coords: HashMap::new(),
        world: false,
        camera: None,
        exposure: 1.0,
        film: (1280, 720, None),
        filter: "gaussian(stddev: 0.5, radius: 1.5)".into(),
        spp: 16,
        integrator: None,
        materials: Vec::new(),
        material_rons: HashMap::new(),
        material_by_ron: HashMap::new(),
        named_materials: HashMap::new(),
        textures: Textures::default(),
        meshes: Vec::new(),
        mesh_names: std::collections::HashSet::new(),
        objects: HashMap::new(),
        defining: None,
        entities: Vec::new(),
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
        c.camera_ron(root)
    });
    let (camera, _, _) = result.map_err(|e| located(&c, e))?;
    if c.camera.is_none() {
        c.report.push("Camera: none given; pbrt-v4's default, a perspective camera of fov 90 at the origin looking along +z".into());
    }
    let integrator = c
        .integrator
        .clone()
        .unwrap_or_else(|| "integrator: \"path\", params: {\"max-depth\": 5}".into());
    let ron = RonScene {
        header: format!(
            "Imported by raylab from a pbrt-v4 scene ({}).",
            path.file_name()
                .map_or_else(String::new, |f| f.to_string_lossy().into_owned())
        ),
        camera: &camera,
        render: &format!("{integrator}, spp: {}, filter: {}", c.spp, quote(&c.filter)),
        environment: c.environment.map(|env| v3(env.map(|x| x as f32))),
        materials: &c.materials,
        meshes: &c.meshes,
        entities: &c.entities,
    }
    .write();
    Ok(Imported {
        ron,
        report: c.report,
        approximated: c.approximated,
        origins: Default::default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const CORNELL: &str = include_str!("../../../scenes/pbrt/cornell_box.pbrt");

    fn convert(text: &str, approximate: bool) -> Result<Imported, PbrtError> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/pbrt/mangled.pbrt");
        let files = SceneFiles::new(&path, &[]);
        let options = ImportOptions {
            defines: Vec::new(),
            approximate,
        };
        to_ron(&path, text, &files, &options)
    }

    proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(300))]
        /// The shipped pbrt scene cut short, or with a piece cut out or replaced by a token:
        /// an error, or RON that the loader takes or refuses, never a panic.
        #[test]
        fn mangled_pbrt_never_panics(
            at in any::<proptest::sample::Index>(),
            len in 0usize..40,
            approximate in any::<bool>(),
            token in prop::sample::select(vec![
                "", "[", "]", "\"", "#", "1e39", "-1", "nan", "AttributeEnd", "ObjectEnd",
                "\"float radius\"", "Scale 0 0 0", "ReverseOrientation", "Include \"cornell_box.pbrt\"",
                "Shape \"sphere\"", "Camera \"perspective\"", "WorldBegin", "\"integer indices\" [9]",
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
            if let Ok(imported) = convert(&text, approximate) {
                let _ = crate::scene::parse_scene(&imported.ron, Path::new("mangled.pbrt"));
            }
        }
    }

    #[test]
    fn the_ron_names_what_the_pbrt_file_names() {
        let imported = convert(CORNELL, false).unwrap();
        for needle in [
            "\"white\": Lambert(albedo: (0.885809, 0.698859, 0.666422))",
            "\"cube/0\": Mesh(positions: [",
            "shape: Instance(mesh: \"cube/0\"), material: \"white\", transform: (matrix: [",
            "emitter: Area(radiance: (18.387, 13.9873, 6.75357), two_sided: false)",
            "spp: 64, filter: \"gaussian(stddev: 0.5, radius: 2)\"",
            "\"max-depth\": 7",
        ] {
            assert!(
                imported.ron.contains(needle),
                "no {needle} in\n{}",
                imported.ron
            );
        }
    }

    #[test]
    fn textures_follow_pbrts_coordinates() {
        let scene = |texture: &str| {
            format!("WorldBegin\n{texture}\nMaterial \"diffuse\" \"texture reflectance\" \"t\"\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n")
        };
        // pbrt-v4 looks an image up at (s, 1 - t); raylab from the top row at (u, v).
        let image = convert(&scene(r#"Texture "t" "spectrum" "imagemap" "string filename" "a.png" "float uscale" 2 "float vdelta" 0.25"#), false).unwrap();
        assert!(image.ron.contains(r#"Image(path: "a.png", filter: "bilinear", wrap: "repeat", raw: false, uv_scale: (2.0, -1.0), uv_offset: (0.0, 0.75))"#), "{}", image.ron);
        // pbrt-v4's squares are a unit wide, Mitsuba's half a unit.
        let checks = convert(&scene(r#"Texture "t" "spectrum" "checkerboard" "rgb tex1" [1 0 0] "float uscale" 8 "float vscale" 4"#), false).unwrap();
        assert!(checks.ron.contains("Checkerboard(color0: (1.0, 0.0, 0.0), color1: 0.0, uv_scale: (4.0, 2.0), uv_offset: (0.0, 0.0))"), "{}", checks.ron);
    }

    #[test]
    fn materials_map_with_pbrts_defaults() {
        for (material, expected) in [
            ("\"conductor\"", "Conductor(metal: \"Cu\")"),
            ("\"conductor\" \"float roughness\" 0.04", "RoughConductor(metal: \"Cu\", distribution: \"ggx\", alpha: 0.2)"),
            ("\"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\" \"bool remaproughness\" false \"float uroughness\" 0.1 \"float vroughness\" 0.3", "RoughConductor(metal: \"Au\", distribution: \"ggx\", alpha_u: 0.1, alpha_v: 0.3)"),
            ("\"conductor\" \"rgb reflectance\" [0.5 0.5 0.5]", "Conductor(eta: (1.0, 1.0, 1.0), k: (2.0, 2.0, 2.0))"),
            ("\"dielectric\"", "Dielectric(int_ior: 1.5, ext_ior: 1.0)"),
            ("\"thindielectric\" \"float eta\" 1.33", "ThinDielectric(int_ior: 1.33, ext_ior: 1.0)"),
            ("\"coateddiffuse\" \"float roughness\" 0", "Plastic(diffuse_reflectance: 0.5, int_ior: 1.5, ext_ior: 1.0, nonlinear: true)"),
        ] {
            let text = format!("WorldBegin\nMaterial {material}\nShape \"sphere\"\n");
            let imported = convert(&text, false).unwrap();
            assert!(imported.ron.contains(expected), "{material}: no {expected} in\n{}", imported.ron);
        }
    }

    #[test]
    fn states_lights_samplers_and_uvs_follow_pbrt_v4() {
        let quad = r#"Shape "bilinearmesh" "point3 P" [0 0 0  2 0 0  0 1 0  2 1 0]"#;
        // TransformBegin/End restore everything, as AttributeBegin/End.
        let text = format!("WorldBegin\nTransformBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\nTransformEnd\n{quad}\n");
        assert!(!convert(&text, false).unwrap().ron.contains("emitter"));
        // `power` over each primitive's own area: a 2 x 1 patch, 2 pi W -> 1.
        let text =
            format!("WorldBegin\nAreaLightSource \"diffuse\" \"float power\" 6.2831853\n{quad}\n");
        let ron = convert(&text, false).unwrap().ron;
        assert!(ron.contains("Area(radiance: (1.0, 1.0, 1.0)"), "{ron}");
        // The shutter's open time scales the image.
        let text = format!("Camera \"perspective\" \"float shutterclose\" 0.5\nWorldBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n{quad}\n");
        assert!(convert(&text, false)
            .unwrap()
            .ron
            .contains("Area(radiance: (2.0, 2.0, 2.0)"));
        // A spectrum on a light is normalised to luminance 1 by pbrt-v4: white, approximately.
        let text = format!(
            "WorldBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [300 8 800 8]\n{quad}\n"
        );
        assert!(convert(&text, false)
            .unwrap_err()
            .3
            .contains("--approximate"));
        assert!(convert(&text, true)
            .unwrap()
            .ron
            .contains("Area(radiance: (1.0, 1.0, 1.0)"));
        // A spot light falls off as pbrt-v4's: a smoothstep in the cosine.
        let text = "WorldBegin\nLightSource \"spot\" \"float coneangle\" 40 \"float conedeltaangle\" 10\nShape \"sphere\"\n";
        let ron = convert(text, false).unwrap().ron;
        assert!(
            ron.contains("cutoff_angle: 40.0, beam_width: 30.0, falloff: \"smoothstep\""),
            "{ron}"
        );
        // A float texture that names another reads the float textures.
        let text = "WorldBegin\nTexture \"a\" \"float\" \"constant\" \"float value\" 0.3\nTexture \"b\" \"float\" \"constant\" \"texture value\" \"a\"\nMaterial \"conductor\" \"bool remaproughness\" false \"texture roughness\" \"b\"\nShape \"sphere\"\n";
        let ron = convert(text, false).unwrap().ron;
        assert!(ron.contains("alpha: 0.3"), "{ron}");
        // The stratified sampler takes xsamples x ysamples.
        let text = format!("Sampler \"stratified\" \"integer xsamples\" 8 \"integer ysamples\" 8\nWorldBegin\n{quad}\n");
        assert!(convert(&text, false).unwrap().ron.contains("spp: 64"));
        // A textured patch without uv gets pbrt's (u, v) at its corners.
        let text = format!("WorldBegin\nTexture \"c\" \"spectrum\" \"checkerboard\"\nMaterial \"diffuse\" \"texture reflectance\" \"c\"\n{quad}\n");
        let ron = convert(&text, false).unwrap().ron;
        assert!(
            ron.contains("uvs: [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]"),
            "{ron}"
        );
        // A mesh of an object definition keeps its own winding under a mirroring transform
        // (an instance turns its normals as normals).
        let text = "WorldBegin\nObjectBegin \"o\"\nScale 1 1 -1\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\nObjectEnd\nObjectInstance \"o\"\n";
        assert!(convert(text, false)
            .unwrap()
            .ron
            .contains("indices: [(0, 1, 2)]"));
        let text =
            "WorldBegin\nScale 1 1 -1\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n";
        assert!(convert(text, false)
            .unwrap()
            .ron
            .contains("indices: [(0, 2, 1)]"));
    }
}
