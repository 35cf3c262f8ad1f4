//! Pixel reconstruction filters: how a camera sample at a film position is shared between
//! the pixels around it.
//!
//! A pixel's value is the filter-weighted mean of the samples near it,
//! `sum w_i L_i / sum w_i`, with `w_i = f(x_i - centre) f(y_i - centre)` (Mitsuba 3's
//! `ImageBlock`, pbrt-v3's film). Pixel `(i, j)` covers `[i, i + 1) x [j, j + 1)` of the film
//! and has its centre at `(i + 0.5, j + 0.5)`.
//!
//! * `box` (the default): each sample counts in the pixel it falls in, with weight 1.
//!   `box(radius: r)` counts it in every pixel whose centre is within `r` in x and y.
//! * `tent`: `f(x) = max(0, 1 - |x| / r)`, radius 1 pixel (Mitsuba 3's `tent`);
//!   `tent(radius: 2)` is pbrt-v4's `triangle`.
//! * `gaussian`: Mitsuba 3's default, a Gaussian of standard deviation 0.5 pixel cut off at 4
//!   standard deviations and shifted down to reach 0 there:
//!   `f(x) = max(0, exp(-x^2 / (2 s^2)) - exp(-r^2 / (2 s^2)))`, `s = 0.5`, `r = 2`;
//!   `gaussian(stddev: 0.5, radius: 1.5)` is pbrt-v4's default.
//!
//! Radii are at most [`MAX_RADIUS`] pixels. Splats (radiance an integrator adds at any film
//! position, light paths) are spread with the same filter, normalised to unit integral so
//! that they keep their energy.

use std::fmt;

/// The largest filter radius, in pixels (a footprint spans at most 16 pixels a side).
pub const MAX_RADIUS: f32 = 6.0;

/// A separable pixel reconstruction filter.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Filter {
    /// The pixel a sample falls in (radius 0.5).
    #[default]
    Box,
    /// A box of another radius.
    WideBox { radius: f32 },
    /// A tent of `radius` (1 is Mitsuba's).
    Tent { radius: f32 },
    /// A Gaussian cut off and shifted to zero at `radius` (Mitsuba's: 0.5 and 2).
    Gaussian { stddev: f32, radius: f32 },
}

/// The filters by name, as `--filter` and the scene's `render.filter` take them.
pub const FILTER_NAMES: [&str; 3] = ["box", "tent", "gaussian"];

impl fmt::Display for Filter {
    /// The name [`str::parse`] reads back: `box`, `tent(radius: 2)`, ...; parameters that
    /// equal the defaults are left out.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Filter::Box => f.write_str("box"),
            Filter::WideBox { radius } => write!(f, "box(radius: {radius})"),
            Filter::Tent { radius: 1.0 } => f.write_str("tent"),
            Filter::Tent { radius } => write!(f, "tent(radius: {radius})"),
            Filter::Gaussian { stddev, radius } if stddev == 0.5 && radius == 2.0 => {
                f.write_str("gaussian")
            }
            Filter::Gaussian { stddev, radius } => {
                write!(f, "gaussian(stddev: {stddev}, radius: {radius})")
            }
        }
    }
}

impl std::str::FromStr for Filter {
    type Err = String;

    /// `box`, `tent` or `gaussian`, optionally with parameters in parentheses:
    /// `box(radius: 1)`, `tent(radius: 2)`, `gaussian(stddev: 0.5, radius: 1.5)` (a
    /// Gaussian's radius defaults to four standard deviations, as Mitsuba's).
    fn from_str(text: &str) -> Result<Filter, String> {
        let (name, args) = match text.split_once('(') {
            None => (text.trim(), None),
            Some((name, rest)) => {
                let args = rest
                    .trim_end()
                    .strip_suffix(')')
                    .ok_or_else(|| format!("filter `{text}`: the parameters must end with `)`"))?;
                (name.trim(), Some(args))
            }
        };
        let mut radius_given = false;
        let (mut radius, mut stddev) = match name {
            "box" => (0.5, None),
            "tent" => (1.0, None),
            "gaussian" => (2.0, Some(0.5)),
            _ => {
                return Err(format!(
                    "unknown filter `{name}`; valid filters: {}",
                    FILTER_NAMES.join(", ")
                ))
            }
        };
        for arg in args.iter().flat_map(|a| a.split(',')).map(str::trim) {
            if arg.is_empty() {
                continue;
            }
            let (key, value) = arg
                .split_once(':')
                .ok_or_else(|| format!("filter `{text}`: `{arg}` is not `name: value`"))?;
            let value: f32 = value
                .trim()
                .parse()
                .map_err(|_| format!("filter `{text}`: `{}` is not a number", value.trim()))?;
            match (key.trim(), stddev.is_some()) {
                ("radius", _) => {
                    radius = value;
                    radius_given = true;
                }
                ("stddev", true) => stddev = Some(value),
                (key, _) => {
                    return Err(format!(
                        "filter `{text}`: {name} takes {}, not `{key}`",
                        if stddev.is_some() {
                            "`stddev` and `radius`"
                        } else {
                            "`radius`"
                        }
                    ))
                }
            }
        }
        if stddev.is_some_and(|s| !(s > 0.0 && s.is_finite())) {
            return Err(format!("filter `{text}`: the stddev must be above 0"));
        }
        // Mitsuba's Gaussian reaches four standard deviations.
        if let (Some(s), false) = (stddev, radius_given) {
            radius = 4.0 * s;
        }
        if !(radius > 0.0 && radius <= MAX_RADIUS) {
            return Err(format!(
                "filter `{text}`: the radius must be above 0 and at most {MAX_RADIUS} pixels"
            ));
        }
        Ok(match (name, stddev) {
            ("box", _) if radius == 0.5 => Filter::Box,
            ("box", _) => Filter::WideBox { radius },
            ("tent", _) => Filter::Tent { radius },
            (_, Some(stddev)) if stddev > 0.0 && stddev.is_finite() => {
                Filter::Gaussian { stddev, radius }
            }
            _ => return Err(format!("filter `{text}`: the stddev must be above 0")),
        })
    }
}

impl Filter {
    /// Half-width of the filter's support, in pixels.
    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Box => 0.5,
            Filter::WideBox { radius }
            | Filter::Tent { radius }
            | Filter::Gaussian { radius, .. } => radius,
        }
    }

    /// The one-dimensional filter at offset `x` (pixels) from a pixel centre.
    pub fn eval_1d(&self, x: f32) -> f32 {
        match *self {
            Filter::Box | Filter::WideBox { .. } => {
                if x.abs() <= self.radius() {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Tent { radius } => (1.0 - x.abs() / radius).max(0.0),
            Filter::Gaussian { stddev, radius } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                ((alpha * x * x).exp() - (alpha * radius * radius).exp()).max(0.0)
            }
        }
    }

    /// Integral of [`Filter::eval_1d`] over its support (to normalise splats).
    pub fn integral_1d(&self) -> f32 {
        match *self {
            Filter::Box | Filter::WideBox { .. } => 2.0 * self.radius(),
            Filter::Tent { radius } => radius,
            Filter::Gaussian { .. } => {
                // Midpoint rule on 1024 cells: exact to far below f32 rounding for this
                // smooth, compact function.
                let r = self.radius();
                let n = 1024;
                let h = 2.0 * r as f64 / n as f64;
                (0..n)
                    .map(|i| self.eval_1d((-r as f64 + (i as f64 + 0.5) * h) as f32) as f64 * h)
                    .sum::<f64>() as f32
            }
        }
    }

    /// Calls `add(x, y, weight)` for every pixel of a `width x height` image whose weight
    /// for a sample at film position `(fx, fy)` is positive. The box filter gives the pixel
    /// the position falls in, with weight exactly 1.
    #[inline]
    pub fn footprint(
        &self,
        fx: f32,
        fy: f32,
        width: u32,
        height: u32,
        mut add: impl FnMut(u32, u32, f32),
    ) {
        if let Filter::Box = self {
            let (x, y) = (fx.floor(), fy.floor());
            if x >= 0.0 && y >= 0.0 && (x as u32) < width && (y as u32) < height {
                add(x as u32, y as u32, 1.0);
            }
            return;
        }
        let r = self.radius();
        // Pixels whose centre lies within the radius: i + 0.5 in (fx - r, fx + r).
        let range = |f: f32, len: u32| {
            let lo = (f - 0.5 - r).ceil().max(0.0) as i64;
            let hi = ((f - 0.5 + r).floor() as i64).min(len as i64 - 1);
            lo..=hi
        };
        let mut wx = [0.0f32; 16];
        let xs = range(fx, width);
        let x0 = *xs.start();
        for x in xs.clone() {
            wx[(x - x0) as usize] = self.eval_1d(x as f32 + 0.5 - fx);
        }
        for y in range(fy, height) {
            let wy = self.eval_1d(y as f32 + 0.5 - fy);
            if wy <= 0.0 {
                continue;
            }
            for x in xs.clone() {
                let w = wx[(x - x0) as usize] * wy;
                if w > 0.0 {
                    add(x as u32, y as u32, w);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_list_the_valid_ones() {
        for name in FILTER_NAMES {
            assert_eq!(name.parse::<Filter>().unwrap().to_string(), name);
        }
        let err = "lanczos".parse::<Filter>().unwrap_err();
        assert!(err.contains("box, tent, gaussian"), "{err}");
    }

    #[test]
    fn parameters_parse_print_back_and_are_checked() {
        for (text, filter) in [
            ("tent", Filter::Tent { radius: 1.0 }),
            ("tent(radius: 2)", Filter::Tent { radius: 2.0 }),
            ("box(radius: 1.5)", Filter::WideBox { radius: 1.5 }),
            (
                "gaussian",
                Filter::Gaussian {
                    stddev: 0.5,
                    radius: 2.0,
                },
            ),
            (
                "gaussian(stddev: 0.5, radius: 1.5)",
                Filter::Gaussian {
                    stddev: 0.5,
                    radius: 1.5,
                },
            ),
        ] {
            assert_eq!(text.parse::<Filter>(), Ok(filter));
            assert_eq!(filter.to_string(), text);
        }
        assert_eq!("box(radius: 0.5)".parse::<Filter>(), Ok(Filter::Box));
        assert_eq!(
            "gaussian(stddev: 0.25)".parse::<Filter>(),
            Ok(Filter::Gaussian {
                stddev: 0.25,
                radius: 1.0
            })
        );
        for (bad, says) in [
            ("tent(radius: 0)", "above 0"),
            ("tent(radius: 9)", "at most 6"),
            ("box(stddev: 1)", "takes `radius`"),
            ("gaussian(stddev: -1)", "stddev must be above 0"),
            ("gaussian(radius 2)", "not `name: value`"),
            ("tent(radius: x)", "not a number"),
            ("tent(radius: 2", "must end with"),
        ] {
            let err = bad.parse::<Filter>().unwrap_err();
            assert!(err.contains(says), "{bad}: {err}");
        }
    }

    #[test]
    fn every_filters_integral_is_its_evaluations_sum() {
        for filter in [
            "box(radius: 1.5)",
            "tent(radius: 2)",
            "gaussian(stddev: 0.5, radius: 1.5)",
        ] {
            let f: Filter = filter.parse().unwrap();
            let (r, n) = (f.radius() as f64, 100_000);
            let h = 2.0 * r / n as f64;
            let sum: f64 = (0..n)
                .map(|i| f.eval_1d((-r + (i as f64 + 0.5) * h) as f32) as f64 * h)
                .sum();
            assert!(
                (sum - f.integral_1d() as f64).abs() < 1e-3,
                "{filter}: {sum}"
            );
        }
    }

    #[test]
    fn mitsubas_gaussian_reaches_zero_at_four_standard_deviations() {
        let g: Filter = "gaussian".parse().unwrap();
        assert_eq!(g.radius(), 2.0);
        assert_eq!(g.eval_1d(2.0), 0.0);
        assert_eq!(g.eval_1d(2.5), 0.0);
        let bias = (-8.0f32).exp();
        assert!((g.eval_1d(0.0) - (1.0 - bias)).abs() < 1e-7);
        assert!((g.eval_1d(0.5) - ((-0.5f32).exp() - bias)).abs() < 1e-7);
        // sqrt(2 pi) s minus the cut-off's share.
        let expected = (2.0 * std::f32::consts::PI).sqrt() * 0.5 - 4.0 * bias;
        assert!(
            (g.integral_1d() - expected).abs() < 1e-4,
            "{}",
            g.integral_1d()
        );
    }

    #[test]
    fn footprints_cover_the_pixels_within_the_radius() {
        let mut seen = Vec::new();
        Filter::Box.footprint(3.7, 1.2, 8, 8, |x, y, w| seen.push((x, y, w)));
        assert_eq!(seen, vec![(3, 1, 1.0)]);
        seen.clear();
        Filter::Tent { radius: 1.0 }.footprint(3.7, 1.2, 8, 8, |x, y, w| seen.push((x, y, w)));
        // x centres 3.5 and 4.5 lie within 1 of 3.7; y centres 0.5 and 1.5 within 1 of 1.2.
        let pixels: Vec<_> = seen.iter().map(|&(x, y, _)| (x, y)).collect();
        assert_eq!(pixels, vec![(3, 0), (4, 0), (3, 1), (4, 1)]);
        let total: f32 = seen.iter().map(|s| s.2).sum();
        // (0.8 + 0.2) * (0.3 + 0.7)
        assert!((total - 1.0).abs() < 1e-6);
        // At the image's corner, only pixels inside.
        seen.clear();
        "gaussian"
            .parse::<Filter>()
            .unwrap()
            .footprint(0.1, 0.1, 4, 4, |x, y, w| seen.push((x, y, w)));
        assert!(seen.iter().all(|&(x, y, w)| x < 2 && y < 2 && w > 0.0));
        assert_eq!(seen.len(), 4);
    }
}
