//! Mitsuba's sensor (with its film, sampler and reconstruction filter) and integrator
//! plugins as raylab's camera and render settings.

use super::*;

/// Mitsuba's `orthographic` sensor as raylab's `Orthographic` camera. Its camera space maps
/// `x` in `[-1, 1]` across the film's width and `y` in `[-1/aspect, 1/aspect]` across its
/// height (aspect = width / height), from `+x` (`to_world`'s left) on the image's left; so
/// `to_world`'s scales set the view's size. A crop is the crop's part of that rectangle.
fn orthographic(
    m: &Affine3A,
    (width, height): (i64, i64),
    crop: Option<(i64, i64, i64, i64)>,
) -> CameraDesc {
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
    CameraDesc::Orthographic {
        eye: eye.into(),
        look_at: (eye + dir).into(),
        up: up.into(),
        width: 2.0 * half_w * cw as f32 / w,
        height: Some(2.0 * half_h * ch as f32 / h),
        resolution: (cw as u32, ch as u32),
    }
}

impl<'a, 'input> Converter<'a, 'input> {
    pub(super) fn sensor(&mut self, node: Node<'a, 'input>) -> Result<(), Located> {
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
        let (fov, axis) = if kind == "perspective" {
            let (fov, axis) = self.field_of_view(&mut p, node)?;
            (Some(fov), axis)
        } else {
            (None, String::new())
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
        for (child_name, child) in std::mem::take(&mut p.children) {
            let child = self.resolve(child)?;
            match child.tag_name().name() {
                "medium" if child_name.is_empty() || child_name == "medium" => {
                    self.camera_medium = Some(self.medium(child)?);
                }
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
                    if !(1..=i64::from(crate::formats::schema::MAX_SIDE)).contains(&width)
                        || !(1..=i64::from(crate::formats::schema::MAX_SIDE)).contains(&height)
                    {
                        return Err(at(
                            self.doc,
                            child,
                            format!(
                                "the film is {width}x{height}: each side must be 1 to {}",
                                crate::formats::schema::MAX_SIDE
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
                                .map(|s| format!("(stddev: {s:?}, radius: {:?})", 4.0 * s))
                        } else {
                            r.float("radius")?.map(|v| format!("(radius: {v:?})"))
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
                    self.render.sampler = self.sampler_kind(child)?;
                    let mut s = self.props(child)?;
                    spp = s.integer("sample_count")?;
                    if let Some(n) = spp.filter(|n| !(1..=i64::from(u32::MAX)).contains(n)) {
                        return Err(at(
                            self.doc,
                            child,
                            format!("sample_count {n}: it must be 1 to {}", u32::MAX),
                        ));
                    }
                    s.finish(&["seed", "jitter", "scramble_seed", "strength", "scramble"])?;
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
            return self.sensor_settings(node, filter, spp);
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
            None => CameraDesc::LookAt {
                eye: eye.into(),
                look_at: (eye + dir).into(),
                up: up.normalize().into(),
                fov: fov_y,
                resolution: (width as u32, height as u32),
            },
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
                CameraDesc::ImagePlane {
                    eye: eye.into(),
                    top_left: at(x, y).into(),
                    top_right: at(x + cw, y).into(),
                    bottom_left: at(x, y + ch).into(),
                    bottom_right: at(x + cw, y + ch).into(),
                    resolution: (cw as u32, ch as u32),
                }
            }
        });
        self.sensor_settings(node, filter, spp)
    }

    /// A perspective sensor's field of view in degrees and the axis it spans: `fov` along
    /// `fov_axis` (default `x`), or, as Mitsuba 3 reads it, a `focal_length` (default
    /// `"50mm"`) of a 35 mm camera, whose 36 x 24 mm frame's diagonal it spans.
    pub(super) fn field_of_view(
        &self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
    ) -> Result<(f32, String), Located> {
        let fov = p.float("fov")?;
        let focal = p.take("focal_length");
        match (fov, focal) {
            (Some(_), Some((_, n))) => Err(at(
                self.doc,
                n,
                "give the sensor `fov` or `focal_length`, not both",
            )),
            (Some(fov), None) => Ok((fov, p.string("fov_axis")?.unwrap_or_else(|| "x".into()))),
            (None, focal) => {
                let (text, n) = match focal {
                    None => ("50mm".to_string(), node),
                    Some((Value::String(t), n)) => (t, n),
                    Some((_, n)) => {
                        return Err(at(self.doc, n, "`focal_length` must be a <string> such as \"50mm\" (Mitsuba 3 reads it as text)"))
                    }
                };
                let mm = text.strip_suffix("mm").unwrap_or(&text).trim();
                let f: f64 = mm.parse().ok().filter(|f: &f64| *f > 0.0 && f.is_finite()).ok_or_else(|| {
                    at(self.doc, n, format!("`focal_length` \"{text}\" must be a positive length in mm, such as \"50mm\""))
                })?;
                let diagonal = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt();
                let fov = 2.0 * (diagonal / (2.0 * f)).atan().to_degrees();
                Ok((fov as f32, "diagonal".into()))
            }
        }
    }

    /// The raylab sampler for a `<sampler>`: Mitsuba's own where raylab has it (Mitsuba 3's,
    /// and 0.6's `sobol` and `halton`, which older scenes name), the nearest stratified or
    /// low-discrepancy one where not, said in the report: a sampler changes the noise, not
    /// the expected image.
    fn sampler_kind(&mut self, node: Node<'a, 'input>) -> Result<SamplerKind, Located> {
        let name = node.attribute("type").unwrap_or("independent");
        let (kind, nearest) = match name {
            "independent" => (SamplerKind::Independent, false),
            "stratified" => (SamplerKind::Stratified, false),
            "sobol" => (SamplerKind::Sobol, false),
            "halton" => (SamplerKind::Halton, false),
            "multijitter" | "orthogonal" => (SamplerKind::Stratified, true),
            "ldsampler" => (SamplerKind::Sobol, true),
            "hammersley" => (SamplerKind::Halton, true),
            _ => {
                return Err(at(
                    self.doc,
                    node,
                    format!("sampler `{name}`: no such sampler (Mitsuba 3: independent, stratified, multijitter, orthogonal, ldsampler; 0.6: sobol, halton, hammersley)"),
                ))
            }
        };
        if nearest {
            self.report.push(format!(
                "sampler `{name}`: raylab's `{kind}` sampler, the nearest it has"
            ));
        }
        Ok(kind)
    }

    /// The sensor's film filter and sample count, as render settings.
    pub(super) fn sensor_settings(
        &mut self,
        node: Node<'a, 'input>,
        filter: String,
        spp: Option<i64>,
    ) -> Result<(), Located> {
        self.render.filter = filter.parse().map_err(|e| at(self.doc, node, e))?;
        if let Some(spp) = spp {
            // Checked to lie in 1..=u32::MAX where the sampler was read.
            self.render.spp = spp as u32;
        }
        Ok(())
    }

    pub(super) fn integrator(&mut self, node: Node<'a, 'input>) -> Result<(), Located> {
        if self.integrator_read {
            return Err(at(
                self.doc,
                node,
                "a second <integrator>: a scene names one",
            ));
        }
        self.integrator_read = true;
        self.integrator_plugin(node)
    }

    /// One integrator plugin (a `moment` wrapper's inner one too).
    fn integrator_plugin(&mut self, node: Node<'a, 'input>) -> Result<(), Located> {
        let kind = self.kind(node)?;
        let mut p = self.props(node)?;
        match kind.as_str() {
            "path" | "ptracer" | "volpath" | "volpathmis" => {
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
                    f64::INFINITY
                } else {
                    (max_depth - 1).max(0) as f64
                };
                // Mitsuba's ptracer is raylab's lighttracer (paths from the lights, each vertex
                // connected to the sensor); its passes are raylab's passes. Its volpath and
                // volpathmis (spectral MIS) estimate what raylab's volpath does, which weighs
                // the colour channels by MIS as volpathmis does.
                let name = match kind.as_str() {
                    "path" => "path",
                    "ptracer" => "lighttracer",
                    _ => "volpath",
                };
                if kind == "ptracer" {
                    p.integer("samples_per_pass")?;
                }
                self.set_integrator(name, &[("max-depth", depth), ("rr-depth", rr_depth as f64)]);
                let depth = if depth.is_infinite() {
                    "inf".to_string()
                } else {
                    depth.to_string()
                };
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
                self.set_integrator(
                    "direct",
                    &[
                        ("emitter-samples", emitter as f64),
                        ("bsdf-samples", bsdf as f64),
                    ],
                );
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
                return self.integrator_plugin(inner);
            }
            other => {
                self.approximate(node, format!("integrator `{other}` is not supported (path, volpath, volpathmis, ptracer, direct, moment are): rendered with path"))?;
                self.set_integrator("path", &[]);
                return Ok(());
            }
        }
        p.finish(&[])
    }

    /// The integrator of the render settings, with its parameters.
    fn set_integrator(&mut self, name: &str, params: &[(&str, f64)]) {
        self.render.integrator = name.to_string();
        self.render.params = params.iter().map(|(k, v)| (k.to_string(), *v)).collect();
    }
}
