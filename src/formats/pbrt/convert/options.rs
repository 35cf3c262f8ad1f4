//! pbrt-v4's scene-wide options: the camera, the film, the pixel filter and the integrator
//! and the sampler (its kind, and its count, which the film's directive carries no more than
//! pbrt's does).

use super::*;

/// pbrt-v4's `Integrator` as raylab's: the name in the file, raylab's integrator for a scene
/// without media, its parameters.
pub(super) struct IntegratorChoice {
    kind: String,
    name: &'static str,
    params: BTreeMap<String, f64>,
}

/// pbrt-v4's integrators that render media: raylab's `volpath` renders them when the scene
/// has media (without, `path` gives the same image).
const VOLUMETRIC: [&str; 2] = ["volpath", "simplevolpath"];

impl<'a> Converter<'a> {
    /// The raylab sampler for a `Sampler` directive: pbrt-v4's own where raylab has it
    /// (`sobol`, pbrt's one sequence over the image, and `pmj02bn` are the nearest ones, said
    /// in the report); an unknown name is an error.
    pub(super) fn sampler_kind(&mut self, d: &Directive) -> Result<SamplerKind, Located> {
        let name = d.strings[0].as_str();
        let (kind, note) = match name {
            "independent" => (SamplerKind::Independent, None),
            "stratified" => (SamplerKind::Stratified, None),
            "halton" => (SamplerKind::Halton, None),
            "zsobol" => (SamplerKind::ZSobol, None),
            "paddedsobol" => (SamplerKind::Sobol, None),
            "sobol" => (SamplerKind::Sobol, Some("raylab's padded, per-pixel Owen-scrambled Sobol points")),
            "pmj02bn" => (SamplerKind::ZSobol, Some("raylab's zsobol (it has no pmj02bn tables)")),
            _ => {
                return Err((
                    d.pos,
                    format!("Sampler \"{name}\": pbrt-v4 has no such sampler (independent, stratified, halton, sobol, paddedsobol, zsobol, pmj02bn)"),
                ))
            }
        };
        if let Some(note) = note {
            self.report(format!("Sampler \"{name}\": {note}"));
        }
        Ok(kind)
    }

    pub(super) fn camera(&mut self, d: &mut Directive) -> Result<(), Located> {
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
        self.camera_media(camera_from_world.inverse(), d.pos)?;
        self.camera = Some(CameraSpec {
            camera_from_world,
            fov,
            screen,
            aspect,
            pos: d.pos,
        });
        Ok(())
    }

    pub(super) fn film(&mut self, d: &mut Directive) -> Result<(), Located> {
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

    pub(super) fn pixel_filter(&mut self, d: &mut Directive) -> Result<(), Located> {
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

    pub(super) fn integrator(&mut self, d: &mut Directive) -> Result<(), Located> {
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
        // raylab's bdpt keeps its subpaths in fixed arrays: at most DEPTH_LIMIT events.
        let limit = raylab_integrators::integrator::bdpt::DEPTH_LIMIT as i64;
        let depth = if name == "bdpt" && depth > limit {
            self.approximate(
                d.pos,
                format!("Integrator \"bdpt\": maxdepth {depth} cut to raylab's bdpt's {limit} (paths of more bounces are left out)"),
            )?;
            limit
        } else {
            depth
        };
        if p.boolean("regularize")? == Some(true) {
            self.approximate(d.pos, "Integrator: regularize (a bias) ignored".into())?;
        }
        if let Some((name, pos)) = p.string_at("lightsampler")? {
            self.light_selection = match name.as_str() {
                "bvh" => LightSelection::Bvh,
                "power" => LightSelection::Power,
                "uniform" => {
                    self.report("Integrator: lightsampler \"uniform\": raylab's uniform picks each emitting shape alike, then its triangles by power (pbrt-v4 picks each triangle alike)".into());
                    LightSelection::Uniform
                }
                "exhaustive" => {
                    self.report("Integrator: lightsampler \"exhaustive\": raylab's light BVH, the nearest it has".into());
                    LightSelection::Bvh
                }
                other => {
                    return Err((
                        pos,
                        format!("Integrator: lightsampler \"{other}\" is not one of bvh, power, uniform, exhaustive"),
                    ))
                }
            };
        }
        p.ignore(&[
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
            "seed",
            "visualizestrategies",
            "visualizeweights",
        ]);
        // pbrt-v4's maxdepth counts scattering events as raylab's max-depth does (1 is direct
        // light only).
        let mut params = BTreeMap::from([("max-depth".to_string(), depth as f64)]);
        if name == "sppm" {
            // pbrt-v4's SPPM bounds the camera side by maxdepth and, apart, lets a photon land
            // after 1 to maxdepth - 1 bounces; its first radius (default 1) is in scene units.
            params.insert("photon-depth".into(), (depth - 1).max(0) as f64);
            let radius = p.float("radius")?.unwrap_or(1.0);
            if !(radius.is_finite() && radius > 0.0) {
                return Err((
                    d.pos,
                    format!("Integrator \"sppm\": radius must be a positive number, got {radius}"),
                ));
            }
            params.insert("radius".into(), radius);
            // (Without it, the film's pixel count, known once the header is read.)
            if let Some(n) = p.integer("photonsperiteration")?.filter(|n| *n > 0) {
                params.insert("photons".into(), n as f64);
            }
        } else {
            p.ignore(&["photonsperiteration", "radius"]);
        }
        p.finish()?;
        self.integrator = Some(IntegratorChoice { kind, name, params });
        Ok(())
    }

    /// raylab's integrator and its parameters, once the scene's media are known: `volpath`
    /// for pbrt-v4's volumetric ones (and its default, `volpath` of maxdepth 5) on a scene
    /// with media, else the mapping of [`Converter::integrator`].
    pub(super) fn integrator_setting(&mut self) -> (&'static str, BTreeMap<String, f64>) {
        let given = self.integrator.take();
        let choice = given.as_ref().map_or(("volpath", "path", None), |c| {
            (c.kind.as_str(), c.name, Some(&c.params))
        });
        let (kind, name, params) = choice;
        let params = params
            .cloned()
            .unwrap_or_else(|| [("max-depth".to_string(), 5.0)].into());
        let has_media = !self.media.made.is_empty();
        let name = if has_media && VOLUMETRIC.contains(&kind) {
            "volpath"
        } else {
            name
        };
        if given.is_some() && kind != name {
            let why = if name == "volpath" {
                "the same estimate"
            } else if has_media {
                "which does not render media: raylab refuses it on this scene"
            } else {
                "without media the same estimate"
            };
            let line = format!("Integrator \"{kind}\": raylab's {name} ({why})");
            self.report(line);
        }
        (name, params)
    }

    /// The camera as raylab's image-plane camera: the eye and the corners of the (cropped)
    /// screen window at distance 1, which keeps pbrt-v4's left-handed image orientation.
    pub(super) fn camera_desc(&self, root: Pos) -> Result<CameraDesc, Located> {
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
        Ok(CameraDesc::ImagePlane {
            eye,
            top_left: raster(px0, py0),
            top_right: raster(px1, py0),
            bottom_left: raster(px0, py1),
            bottom_right: raster(px1, py1),
            resolution: ((px1 - px0) as u32, (py1 - py0) as u32),
        })
    }
}
