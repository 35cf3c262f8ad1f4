//! Warping functions from the unit square to directions and points, with their densities.
//! Every warp here is checked by a chi-square test (see `chi2.rs`).

use glam::{Vec2, Vec3A};
use std::f32::consts::{FRAC_1_PI, PI};

/// Cosine-weighted direction on the upper (`z > 0`) hemisphere, by Malley's method.
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3A {
    let d = concentric_disk(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3A::new(d.x, d.y, z)
}

/// Density of [`cosine_hemisphere`] per unit solid angle.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the upper hemisphere.
#[inline]
pub fn uniform_hemisphere(u: Vec2) -> Vec3A {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3A::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_HEMISPHERE_PDF: f32 = 0.5 * FRAC_1_PI;

/// Uniform direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3A {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3A::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_SPHERE_PDF: f32 = 0.25 * FRAC_1_PI;

/// Shirley–Chiu concentric map from the square to the unit disk.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // The angle is a quarter turn's offset in [-pi/4, pi/4] (or pi/2 minus one, whose cosine
    // and sine swap), where a short polynomial is as exact as libm's sincos and cheaper.
    if o.x.abs() > o.y.abs() {
        let (sin, cos) = sin_cos_quarter(0.25 * PI * (o.y / o.x));
        Vec2::new(o.x * cos, o.x * sin)
    } else {
        let (sin, cos) = sin_cos_quarter(0.25 * PI * (o.x / o.y));
        Vec2::new(o.y * sin, o.y * cos)
    }
}

/// `(sin a, cos a)` for `|a| <= pi/4`, by their Taylor series to the a^9 and a^10 terms:
/// the first term left out is below 2e-9 (the sine's a^11 / 11! at pi/4), under half an ulp of
/// the results.
#[inline]
pub(crate) fn sin_cos_quarter(a: f32) -> (f32, f32) {
    let a2 = a * a;
    let sin = a
        * (1.0
            + a2 * (-1.0 / 6.0
                + a2 * (1.0 / 120.0 + a2 * (-1.0 / 5040.0 + a2 * (1.0 / 362_880.0)))));
    let cos = 1.0
        + a2 * (-0.5
            + a2 * (1.0 / 24.0
                + a2 * (-1.0 / 720.0 + a2 * (1.0 / 40_320.0 + a2 * (-1.0 / 3_628_800.0)))));
    (sin, cos)
}

/// Uniform barycentric coordinates `(b1, b2)` on a triangle (the point is
/// `p0 + b1 * e1 + b2 * e2`). Preserves stratification of `u`.
#[inline]
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

/// Power heuristic with beta = 2 (Veach 1997) for two strategies taking one sample each.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if a == 0.0 && b == 0.0 {
        0.0
    } else if a.is_infinite() {
        1.0
    } else {
        a / (a + b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quarter_sin_cos_is_as_exact_as_f32_allows() {
        // The error in units of the last place of the exact value rounded to f32: small
        // angles too (an absolute bound of 1e-7 would let a sine of 1e-4 be 0.1% off).
        let ulps = |x: f32, exact: f64| {
            let ulp = ((exact as f32).abs().next_up() - (exact as f32).abs()) as f64;
            (x as f64 - exact).abs() / ulp
        };
        let mut worst = 0.0f64;
        for k in 0..=100_000 {
            let a = (k as f32 / 100_000.0 * 2.0 - 1.0) * std::f32::consts::FRAC_PI_4;
            if a == 0.0 {
                continue;
            }
            let (s, c) = sin_cos_quarter(a);
            let (es, ec) = (a as f64).sin_cos();
            worst = worst.max(ulps(s, es)).max(ulps(c, ec));
        }
        // The rounding of the evaluation, not the series (libm's sinf and cosf are within one
        // ulp too).
        assert!(worst <= 1.5, "worst error {worst} ulp");
    }
    use crate::testing::chi2::{assert_chi2, Grid, SAMPLES};
    use crate::Sampler;

    #[test]
    fn chi2_uniform_hemisphere() {
        assert_chi2(
            "uniform hemisphere",
            &Grid::hemisphere(20, 40),
            SAMPLES,
            101,
            |s| Some(uniform_hemisphere(s.next_2d())),
            |w| {
                if w.z > 0.0 {
                    UNIFORM_HEMISPHERE_PDF
                } else {
                    0.0
                }
            },
        );
    }

    #[test]
    fn chi2_uniform_sphere() {
        assert_chi2(
            "uniform sphere",
            &Grid::sphere(20, 40),
            SAMPLES,
            102,
            |s| Some(uniform_sphere(s.next_2d())),
            |_| UNIFORM_SPHERE_PDF,
        );
    }

    #[test]
    fn concentric_disk_stays_in_the_disk_and_keeps_quadrants() {
        let mut s = Sampler::new(5, 0, 0);
        for _ in 0..10_000 {
            let u = s.next_2d();
            let d = concentric_disk(u);
            assert!(d.length() <= 1.0 + 1e-6);
            assert_eq!(d.x >= 0.0, u.x >= 0.5, "{u} -> {d}");
        }
        assert_eq!(concentric_disk(Vec2::splat(0.5)), Vec2::ZERO);
    }

    #[test]
    fn uniform_triangle_is_inside_with_the_centroid_as_mean() {
        let mut s = Sampler::new(6, 0, 0);
        let n = 200_000;
        let mut mean = Vec2::ZERO;
        for _ in 0..n {
            let b = uniform_triangle(s.next_2d());
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            mean += b / n as f32;
        }
        // Standard deviation of a barycentric coordinate is sqrt(1/18); allow 5 standard errors.
        let tol = 5.0 * (1.0f32 / 18.0 / n as f32).sqrt();
        assert!(
            (mean - Vec2::splat(1.0 / 3.0)).abs().max_element() < tol,
            "{mean}"
        );
    }

    #[test]
    fn power_heuristic_limits() {
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-7);
        assert!((power_heuristic(2.0, 1.0) - 0.8).abs() < 1e-6);
    }

    #[test]
    fn the_guided_search_finds_the_cell_a_search_of_the_whole_table_finds() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::SmallRng::seed_from_u64(11);
        // Uniform (11 and 19 stretches of 16 cells: there a number just below g / m can
        // round into stretch g, under a running sum equal to g / m, so the guides do not
        // bracket it), peaked, with runs of empty cells (flat stretches of the running sums),
        // one cell, all empty, and random.
        let mut peaked = vec![1e-3f32; 300];
        peaked[17] = 500.0;
        peaked[200] = 40.0;
        let mut gaps = vec![0.0f32; 257];
        gaps[3] = 1.0;
        gaps[128] = 2.0;
        gaps[250] = 0.5;
        let random: Vec<f32> = (0..1000).map(|_| rng.random::<f32>().powi(8)).collect();
        let tables = [
            vec![1.0; 64],
            vec![1.0; 11 * CELLS_PER_GUIDE],
            vec![1.0; 19 * CELLS_PER_GUIDE],
            peaked,
            gaps,
            vec![3.0],
            vec![0.0; 10],
            random,
        ];
        for weights in &tables {
            let d = Distribution1D::new(weights);
            let m = d.guide.len() - 1;
            // Random numbers, and every stretch's ends and their neighbours in f32.
            let mut us: Vec<f32> = (0..20_000).map(|_| rng.random::<f32>()).collect();
            for g in 0..=m {
                let edge = g as f32 / m as f32;
                us.extend([edge.next_down(), edge, edge.next_up()]);
            }
            us.extend(
                d.cells
                    .iter()
                    .flat_map(|&[c, _]| [c.next_down(), c, c.next_up()]),
            );
            for u in us.into_iter().filter(|u| (0.0..1.0).contains(u)) {
                let i = d.cells.partition_point(|c| c[0] <= u);
                assert_eq!(d.sums_at_most(u), i, "u = {u}");
                // The cell found is the one whose running sums bracket u, and it carries its
                // own probability.
                let (x, cell, p) = d.sample(u);
                let (start, end) = (d.cells[cell][0], d.cells[cell + 1][0]);
                assert!(cell + 1 == i && start <= u && (u < end || end == 1.0));
                assert!(p == d.pmf(cell) && (cell as f32..=(cell + 1) as f32).contains(&x));
            }
            // Each cell's probability is its weight over the sum (equal without weights).
            let total: f64 = weights.iter().map(|&w| w as f64).sum();
            for (i, &w) in weights.iter().enumerate() {
                let expected = if total > 0.0 {
                    (w as f64 / total) as f32
                } else {
                    1.0 / weights.len() as f32
                };
                assert_eq!(d.pmf(i), expected);
            }
            assert_eq!(d.pmf(weights.len()), 0.0);
        }
    }
}

/// Cells per guide of [`Distribution1D`]'s search (see its `guide`).
const CELLS_PER_GUIDE: usize = 16;

/// A piecewise-constant distribution over `n` equal cells of `[0, n)`, proportional to
/// non-negative weights (uniform when they are all zero): the rows and columns of an
/// environment map's sampling distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    /// `cells[i] = [cdf_i, pmf_i]`, for `i` in `0..=n`: the normalised running sum of the
    /// weights before cell `i` (`cdf_0 = 0`, `cdf_n = 1`) and cell `i`'s weight over their
    /// sum (0 for `i = n`), side by side, so that a sample reads its cell's two numbers from
    /// one cache line (a 2048-texel row of an environment map's distribution holds 16 kB).
    cells: Vec<[f32; 2]>,
    /// `guide[g]`: how many running sums are at most `g / m`, for `g` in `0..=m`, with `m` =
    /// `n / CELLS_PER_GUIDE` (rounded up) stretches of `u`. A number `u` between `g / m` and
    /// `(g + 1) / m` usually lands in a cell between the two guides (not always: its stretch
    /// `g` is found by rounding), which a search of that stretch finds in a few steps within
    /// a cache line or two, where a search of the whole table would take `log2(n)` dependent
    /// steps across it. A quarter of a byte per cell: the guides of every row of a
    /// 2048x1024 environment map (512 kB) stay in the processor's cache.
    guide: Vec<u32>,
    /// Sum of the weights (0 when they were all zero and the distribution is uniform).
    pub total: f64,
}

impl Distribution1D {
    /// The distribution of `weights` (NaN or negative weights count as 0).
    pub fn new(weights: &[f32]) -> Distribution1D {
        let n = weights.len().max(1);
        let clean = |w: f32| {
            if w > 0.0 && w.is_finite() {
                w as f64
            } else {
                0.0
            }
        };
        let total: f64 = weights.iter().map(|&w| clean(w)).sum();
        let pmf: Vec<f32> = if total > 0.0 {
            weights.iter().map(|&w| (clean(w) / total) as f32).collect()
        } else {
            vec![1.0 / n as f32; n]
        };
        let mut cdf = Vec::with_capacity(n + 1);
        let mut sum = 0.0f64;
        cdf.push(0.0);
        for &w in weights.iter().take(n) {
            sum += if total > 0.0 {
                clean(w) / total
            } else {
                1.0 / n as f64
            };
            cdf.push(sum as f32);
        }
        if weights.is_empty() {
            cdf.push(1.0);
        }
        // Pin the end (and everything after the last non-empty cell) to exactly 1.
        let last = pmf.iter().rposition(|&p| p > 0.0).unwrap_or(n - 1);
        for c in &mut cdf[last + 1..] {
            *c = 1.0;
        }
        let m = n.div_ceil(CELLS_PER_GUIDE);
        let guide = (0..=m)
            .map(|g| cdf.partition_point(|&c| c <= g as f32 / m as f32) as u32)
            .collect();
        let cells = (cdf.iter().enumerate())
            .map(|(i, &c)| [c, pmf.get(i).copied().unwrap_or(0.0)])
            .collect();
        Distribution1D {
            cells,
            guide,
            total,
        }
    }

    /// The number of cells, `n`.
    #[inline]
    fn len(&self) -> usize {
        self.cells.len() - 1
    }

    /// The number of running sums at most `u` (`cells.partition_point(|c| c[0] <= u)`), searched
    /// between the guides of `u`'s stretch when they bracket it (the stretch is found by
    /// rounding, so near its ends they may not), in the whole table otherwise. The same
    /// index either way.
    #[inline]
    fn sums_at_most(&self, u: f32) -> usize {
        let m = self.guide.len() - 1;
        let g = ((u * m as f32) as usize).min(m - 1);
        let (lo, hi) = (self.guide[g] as usize, self.guide[g + 1] as usize);
        let cells = &self.cells;
        let above_lo = lo == 0 || cells[lo - 1][0] <= u;
        let below_hi = hi == cells.len() || cells[hi][0] > u;
        if above_lo && below_hi {
            lo + cells[lo..hi].partition_point(|c| c[0] <= u)
        } else {
            cells.partition_point(|c| c[0] <= u)
        }
    }

    /// A point of `[0, n)` for `u` in `[0, 1)`, its cell, and its density (per unit of `x`).
    /// Never lands in a cell of zero weight.
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, usize, f32) {
        let u = u.clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        let i = self.sums_at_most(u).saturating_sub(1).min(self.len() - 1);
        let [start, p] = self.cells[i];
        let within = if p > 0.0 {
            ((u - start) / p).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
        } else {
            0.5
        };
        (i as f32 + within, i, p)
    }

    /// Probability of cell `i` (its density per unit of `x`, cells being one unit wide).
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.cells.get(i).map_or(0.0, |c| c[1])
    }
}
