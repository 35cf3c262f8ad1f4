//! `Shape "curve"`: pbrt-v4's curves (`Curve::Create` in pbrt-v4's `shapes.cpp`) as raylab's
//! `Curves`. Each curve's control points `P` (a Bézier or uniform B-spline basis, of degree 2
//! or 3) are turned into cubic Bézier segments as pbrt-v4 turns them (a B-spline's segments
//! blossomed into Bézier form, a quadratic's raised to a cubic), with its `type`, `width0` and
//! `width1` (or `width`), a ribbon's normals `N` and `splitdepth`.
//!
//! Hair models are many thousands of `Shape "curve"` directives: consecutive curves with the
//! same material, transform, orientation, type and split depth are gathered into one entity
//! (one `Curves` shape), and the memory they will take is checked curve after curve.

use super::*;
use crate::formats::memory::{check_curves_made, curve_triangle_equivalent};
use crate::formats::schema::{CurveDesc, CurveType, MAX_SPLIT_DEPTH};

/// pbrt-v4's `Lerp(t, a, b)`.
fn lerp(t: f64, a: DVec3, b: DVec3) -> DVec3 {
    a * (1.0 - t) + b * t
}

/// A curve's control points `P` in `basis` of `degree` as cubic Bézier segments, one after
/// the other (`3 n + 1` points for `n` segments).
fn bezier_chain(points: &[DVec3], basis: &str, degree: usize) -> Vec<DVec3> {
    let mut chain = Vec::new();
    let mut push = |segment: [DVec3; 4]| {
        if chain.is_empty() {
            chain.push(segment[0]);
        }
        chain.extend_from_slice(&segment[1..]);
    };
    // A quadratic Bézier segment raised to a cubic.
    let cubic = |q: [DVec3; 3]| {
        [
            q[0],
            lerp(2.0 / 3.0, q[0], q[1]),
            lerp(1.0 / 3.0, q[1], q[2]),
            q[2],
        ]
    };
    match (basis, degree) {
        ("bezier", 3) => {
            for s in points.windows(4).step_by(3) {
                push([s[0], s[1], s[2], s[3]]);
            }
        }
        ("bezier", _) => {
            for s in points.windows(3).step_by(2) {
                push(cubic([s[0], s[1], s[2]]));
            }
        }
        (_, 3) => {
            // Blossomed from p012, p123, p234, p345 to p222, p223, p233, p333.
            for s in points.windows(4) {
                let (p012, p123, p234, p345) = (s[0], s[1], s[2], s[3]);
                let p122 = lerp(2.0 / 3.0, p012, p123);
                let p223 = lerp(1.0 / 3.0, p123, p234);
                let p233 = lerp(2.0 / 3.0, p123, p234);
                let p334 = lerp(1.0 / 3.0, p234, p345);
                push([lerp(0.5, p122, p223), p223, p233, lerp(0.5, p233, p334)]);
            }
        }
        _ => {
            for s in points.windows(3) {
                push(cubic([lerp(0.5, s[0], s[1]), s[1], lerp(0.5, s[1], s[2])]));
            }
        }
    }
    chain
}

/// Whether `m`'s linear part is a rotation (or mirror) times a uniform scale.
fn is_similarity(m: &DMat4) -> bool {
    let (x, y, z) = (
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    );
    let l2 = x.length_squared();
    let tol = 1e-5 * l2;
    (y.length_squared() - l2).abs() <= tol
        && (z.length_squared() - l2).abs() <= tol
        && x.dot(y).abs() <= tol
        && x.dot(z).abs() <= tol
        && y.dot(z).abs() <= tol
}

impl Converter<'_> {
    /// `Shape "curve"` with parameters `p` (its `alpha` already read), gathered into the
    /// entity of the curves before it where they agree.
    pub(super) fn curve(
        &mut self,
        d: &Directive,
        mut p: ParamList,
        alpha: Option<FloatDesc>,
    ) -> Result<(), Located> {
        let what = p.what.clone();
        if let Some((object, _, _)) = &self.defining {
            return Err((d.pos, format!("{what}: curves inside the object \"{object}\" are not supported (raylab instances meshes only)")));
        }
        if self.state.area.is_some() {
            return Err((
                d.pos,
                format!("{what}: a curve cannot be an area light (nor can pbrt-v4's)"),
            ));
        }
        let degree = match p.integer("degree")? {
            None => 3,
            Some(k @ (2 | 3)) => k as usize,
            Some(k) => {
                return Err((
                    p.present("degree").unwrap_or(d.pos),
                    format!("{what}: degree {k}: only degree 2 and 3 curves are supported"),
                ))
            }
        };
        let basis = match p.string_at("basis")? {
            None => "bezier".to_string(),
            Some((b, _)) if b == "bezier" || b == "bspline" => b,
            Some((b, pos)) => {
                return Err((
                    pos,
                    format!(
                        "{what}: unknown basis \"{b}\" (\"bezier\" and \"bspline\" are supported)"
                    ),
                ))
            }
        };
        let (numbers, ppos) = p
            .numbers("P", &["point3", "point"])?
            .ok_or_else(|| (d.pos, format!("{what} needs \"point3 P\"")))?;
        if numbers.len() % 3 != 0 || numbers.iter().any(|x| !x.is_finite()) {
            return Err((
                ppos,
                format!(
                    "{what}: P has {} numbers, not finite points (three numbers each)",
                    numbers.len()
                ),
            ));
        }
        let points: Vec<DVec3> = numbers
            .chunks(3)
            .map(|c| DVec3::new(c[0], c[1], c[2]))
            .collect();
        let n = points.len();
        let segments = if basis == "bezier" {
            if n < degree + 1 || !(n - 1 - degree).is_multiple_of(degree) {
                return Err((ppos, format!("{what}: {n} control points; a degree {degree} Bézier curve has {} + n * {degree} (n >= 0)", degree + 1)));
            }
            (n - 1) / degree
        } else {
            if n < degree + 1 {
                return Err((
                    ppos,
                    format!(
                        "{what}: {n} control points; a degree {degree} B-spline needs at least {}",
                        degree + 1
                    ),
                ));
            }
            n - degree
        };
        let kind = match p.string_at("type")? {
            None => CurveType::Flat,
            Some((t, pos)) => match t.as_str() {
                "flat" => CurveType::Flat,
                "cylinder" => CurveType::Cylinder,
                "ribbon" => CurveType::Ribbon,
                other => {
                    self.approximate(pos, format!("{what}: unknown curve type \"{other}\" (flat, cylinder, ribbon), rendered as \"cylinder\" as pbrt-v4 does"))?;
                    CurveType::Cylinder
                }
            },
        };
        let normals = match (p.numbers("N", &["normal", "normal3"])?, kind) {
            (None, CurveType::Ribbon) => {
                return Err((
                    d.pos,
                    format!("{what}: a ribbon needs normals \"normal N\" at its segments' ends"),
                ))
            }
            (None, _) => None,
            (Some(_), CurveType::Flat | CurveType::Cylinder) => {
                self.report(format!(
                    "{what}: normals N are used by ribbons only; ignored, as pbrt-v4 does"
                ));
                None
            }
            (Some((v, pos)), CurveType::Ribbon) => {
                if v.len() != 3 * (segments + 1) || v.iter().any(|x| !x.is_finite()) {
                    return Err((pos, format!("{what}: a ribbon of {segments} segment(s) needs {} finite normals, got {} numbers", segments + 1, v.len())));
                }
                Some(
                    v.chunks(3)
                        .map(|c| DVec3::new(c[0], c[1], c[2]))
                        .collect::<Vec<_>>(),
                )
            }
        };
        let split_depth = match p.integer("splitdepth")? {
            None => 3,
            Some(k) if (0..=MAX_SPLIT_DEPTH as i64).contains(&k) => k as u32,
            Some(k) => {
                return Err((
                    p.present("splitdepth").unwrap_or(d.pos),
                    format!("{what}: splitdepth {k} is not in 0..={MAX_SPLIT_DEPTH}"),
                ))
            }
        };
        let mut width = |name: &str, default: f64| -> Result<f64, Located> {
            match p.float(name)? {
                None => Ok(default),
                Some(w) if w.is_finite() && w >= 0.0 => Ok(w),
                Some(w) => Err((
                    p.present(name).unwrap_or(d.pos),
                    format!("{what}: `{name}` must be finite and not negative, got {w}"),
                )),
            }
        };
        let w = width("width", 1.0)?;
        let (w0, w1) = (width("width0", w)?, width("width1", w)?);
        p.finish()?;

        let medium = self.shape_media();
        let Some(material) = self.current_material() else {
            return self.approximate(
                d.pos,
                format!(
                    "{what}: a shape with the `interface` material (a medium's boundary) left out"
                ),
            );
        };
        let material = match alpha {
            None => material,
            Some(alpha) => self.cut_out(material, alpha),
        };
        let mut chain = bezier_chain(&points, &basis, degree);
        let mut normals = normals;
        let mut widths = (w0, w1);
        let mut ctm = self.state.ctm;
        let flip = self.state.reverse ^ (ctm.determinant() < 0.0);
        if affine(&ctm).is_none() {
            return Err((d.pos, format!("{what}: a projective transform")));
        }
        if !is_similarity(&ctm) {
            self.approximate(d.pos, format!("{what}: under a transform that stretches or shears, the curve is placed in the world with its width scaled by the transform's mean scale"))?;
            let scale = ctm.determinant().abs().cbrt();
            chain = chain.iter().map(|p| ctm.transform_point3(*p)).collect();
            let inv_t = ctm.inverse().transpose();
            normals = normals.map(|ns| ns.iter().map(|n| inv_t.transform_vector3(*n)).collect());
            widths = (w0 * scale, w1 * scale);
            ctm = DMat4::IDENTITY;
        }
        let curve = CurveDesc {
            points: chain.into_iter().map(f3).collect(),
            width: (widths.0 as f32, widths.1 as f32),
            normals: normals.map(|ns| ns.into_iter().map(f3).collect()),
        };
        // Checked before the curve joins the scene: what the curves made so far will take.
        self.curve_segments += segments as u64;
        self.curve_triangles += curve_triangle_equivalent(segments as u64, split_depth);
        check_curves_made(self.curve_segments, self.curve_triangles, &self.room)
            .map_err(|e| (d.pos, e))?;
        let transform = match affine(&ctm) {
            Some(a) if a != Affine3A::IDENTITY => crate::formats::import::placed(&a),
            _ => TransformDesc::default(),
        };
        // The entity of the curves just before, if this one agrees with them.
        if let Some(last) = self.curve_group.filter(|&i| i + 1 == self.entities.len()) {
            let e = &mut self.entities[last];
            if let Some(ShapeDesc::Curves {
                kind: k,
                split_depth: s,
                curves,
            }) = &mut e.shape
            {
                if *k == kind
                    && *s == split_depth
                    && e.material.as_deref() == Some(material.as_str())
                    && e.transform == transform
                    && e.flip_normals == flip
                    && e.medium == medium
                {
                    curves.push(curve);
                    return Ok(());
                }
            }
        }
        self.entities.push(EntityDesc {
            name: Some(format!("curves ({})", self.place(d.pos))),
            transform,
            shape: Some(ShapeDesc::Curves {
                kind,
                split_depth,
                curves: vec![curve],
            }),
            material: Some(material),
            emitter: None,
            medium,
            flip_normals: flip,
        });
        self.curve_group = Some(self.entities.len() - 1);
        crate::formats::import::check_entities_made(self.entities.len(), &self.room)
            .map_err(|e| (d.pos, e))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A B-spline's Bézier segments join end to end and lie where the B-spline does: its
    /// segment `i` starts at `(p_i + 4 p_{i+1} + p_{i+2}) / 6`.
    #[test]
    fn bsplines_and_quadratics_become_cubic_bezier_chains() {
        let p: Vec<DVec3> = (0..6)
            .map(|i| DVec3::new(i as f64, (i * i) as f64 * 0.1, (i % 2) as f64))
            .collect();
        let chain = bezier_chain(&p, "bspline", 3);
        assert_eq!(chain.len(), 3 * 3 + 1);
        for i in 0..3 {
            let start = (p[i] + p[i + 1] * 4.0 + p[i + 2]) / 6.0;
            assert!((chain[3 * i] - start).length() < 1e-12, "{i}");
        }
        let cubic = bezier_chain(&p[..4], "bezier", 3);
        assert_eq!(cubic, p[..4].to_vec());
        // A quadratic Bézier raised: the same curve, its middle point at (p0 + 2 p1 + p2) / 4.
        let q = bezier_chain(&p[..5], "bezier", 2);
        assert_eq!(q.len(), 7);
        let mid = (q[0] + q[1] * 3.0 + q[2] * 3.0 + q[3]) / 8.0;
        assert!((mid - (p[0] + p[1] * 2.0 + p[2]) / 4.0).length() < 1e-12);
        // A quadratic B-spline: each segment from the midpoints of its legs.
        let b2 = bezier_chain(&p[..4], "bspline", 2);
        assert_eq!(b2.len(), 7);
        assert!((b2[0] - (p[0] + p[1]) / 2.0).length() < 1e-12);
        assert!((b2[6] - (p[2] + p[3]) / 2.0).length() < 1e-12);
    }
}
