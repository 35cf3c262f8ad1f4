//! Chi-square goodness-of-fit tests for direction samplers.
//!
//! In the style of pbrt-v3/v4's BSDF chi-square tests and Mitsuba 3's `ChiSquareTest`: draw
//! many directions from a sampler with a fixed seed, histogram them over a grid on the sphere,
//! compare with the counts expected from the sampler's claimed density, and reject if the
//! p-value of Pearson's statistic is below the Šidák-corrected significance level.
//!
//! * **Grid.** Cells are uniform in `t = 1 - cos(theta)` and `phi` around a chosen pole, so
//!   every cell has the same solid angle (`dw = dt dphi`). The histogram may cover only a
//!   window `t_range x phi_range` (a cap around the pole for narrow lobes, a patch near the
//!   equator for area lights); everything outside is one overflow cell. `t` is computed from
//!   `|w x pole|^2 / (1 + cos)` so that narrow caps keep full precision.
//! * **Expected counts.** `n_total * integral of pdf over the cell`, integrated with a
//!   `sub x sub` (16 x 16) midpoint rule in `(t, phi)`, refined to 64 x 64 in cells where the
//!   density's support ends (edges and corners of area lights, cone boundaries). Samples the sampler rejects (`None`) still count
//!   in `n_total`, so the density must integrate to the sampler's success rate.
//! * **Statistic.** As in pbrt: cells are sorted by expected count, cells expecting fewer than
//!   5 are pooled; a cell that expects nothing but received more than `1e-5 n_total` samples
//!   fails outright. The p-value is `Q(dof / 2, chi2 / 2)`, the regularised upper incomplete
//!   gamma function, implemented here (series and Lentz continued fraction).
//! * **Significance.** Each test fails below `1 - (1 - 0.01)^(1 / CHI2_TESTS)`, so that the
//!   whole suite of [`CHI2_TESTS`] tests has a 1% false-positive rate.
//!
//! It also has helpers for BSDFs: [`check_sample_matches_eval`] (the sampled `f` and `pdf`
//! equal `eval` and `pdf`) and [`directional_albedo`] / [`assert_energy_conserving`].

use crate::bsdf::Bxdf;
use crate::special::ln_gamma;
use crate::Sampler;
use glam::{DVec3, Vec3A};
use std::f64::consts::PI;

/// Number of chi-square tests in the suite (for the Šidák correction): the `#[test]`
/// functions named `chi2_*`, counted by the crate's build script (`build.rs`).
pub const CHI2_TESTS: u32 = parse_count(env!("RAYLAB_CHI2_TESTS"));

const fn parse_count(text: &str) -> u32 {
    let bytes = text.as_bytes();
    let mut n = 0;
    let mut i = 0;
    while i < bytes.len() {
        n = n * 10 + (bytes[i] - b'0') as u32;
        i += 1;
    }
    n
}

/// Refuses a chi-square test in a test function the count does not see: libtest names each
/// test's thread after its path, whose last part must start with `chi2_`.
fn check_counted(name: &str) {
    if let Some(thread) = std::thread::current().name().filter(|t| t.contains("::")) {
        let test = thread.rsplit("::").next().unwrap_or(thread);
        assert!(
            test.starts_with("chi2_"),
            "chi2 {name}: run from test `{thread}`; name chi-square tests `chi2_*` so that \
             CHI2_TESTS counts them"
        );
    }
}

/// Family-wise significance level of the suite.
pub const SIGNIFICANCE: f64 = 0.01;
/// Default number of samples per test.
pub const SAMPLES: usize = 1_000_000;
/// Cells expecting fewer samples than this are pooled.
const MIN_EXPECTED: f64 = 5.0;

/// The per-test significance threshold after the Šidák correction.
pub fn per_test_threshold() -> f64 {
    1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / CHI2_TESTS as f64)
}

// ---------------------------------------------------------------------------------------------
// Special functions (`ln_gamma` is in `crate::special`).

/// Regularised upper incomplete gamma function `Q(a, x) = Gamma(a, x) / Gamma(a)`.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    assert!(a > 0.0 && x >= 0.0, "gamma_q({a}, {x})");
    if x == 0.0 {
        return 1.0;
    }
    let log_prefix = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        // Series for P(a, x).
        let (mut ap, mut del) = (a, 1.0 / a);
        let mut sum = del;
        for _ in 0..100_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * log_prefix.exp()).max(0.0)
    } else {
        // Continued fraction for Q(a, x), modified Lentz.
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (log_prefix.exp() * h).clamp(0.0, 1.0)
    }
}

/// Survival function of the chi-square distribution: `P(X >= x)` for `dof` degrees of
/// freedom.
pub fn chi2_sf(x: f64, dof: usize) -> f64 {
    if dof == 0 {
        return 1.0;
    }
    gamma_q(0.5 * dof as f64, 0.5 * x.max(0.0))
}

// ---------------------------------------------------------------------------------------------
// Pearson's statistic with pooling.

/// Result of one chi-square test.
#[derive(Clone, Debug)]
pub struct Chi2Outcome {
    /// Pearson's statistic.
    pub statistic: f64,
    /// Degrees of freedom (cells after pooling, minus one).
    pub dof: usize,
    /// `P(X >= statistic)`.
    pub p_value: f64,
    /// Fraction of the samples that the sampler did not reject.
    pub success_rate: f64,
    /// Integral of the density over the whole sphere (should equal `success_rate`).
    pub pdf_integral: f64,
}

/// Pearson's chi-square of `observed` against `expected` counts, pooling cells that expect
/// fewer than 5 samples (pbrt's procedure). `Err` if a cell expecting nothing received more
/// than `1e-5 total` samples.
pub fn chi2_statistic(
    observed: &[u64],
    expected: &[f64],
    total: usize,
) -> Result<(f64, usize, f64), String> {
    assert_eq!(observed.len(), expected.len());
    let mut order: Vec<usize> = (0..observed.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pooled_obs, mut pooled_exp) = (0.0f64, 0.0f64);
    let (mut chi2, mut cells) = (0.0f64, 0usize);
    for &i in &order {
        let (obs, exp) = (observed[i] as f64, expected[i]);
        if exp <= 0.0 {
            if obs > total as f64 * 1e-5 {
                return Err(format!("cell {i} expects no samples but received {obs}"));
            }
        } else if exp < MIN_EXPECTED || (pooled_exp > 0.0 && pooled_exp < MIN_EXPECTED) {
            pooled_obs += obs;
            pooled_exp += exp;
        } else {
            chi2 += (obs - exp) * (obs - exp) / exp;
            cells += 1;
        }
    }
    if pooled_exp > 0.0 {
        chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        cells += 1;
    } else if pooled_obs > 0.0 {
        return Err(format!(
            "{pooled_obs} samples in pooled cells that expect none"
        ));
    }
    let dof = cells.saturating_sub(1);
    Ok((chi2, dof, chi2_sf(chi2, dof)))
}

/// Runs [`chi2_statistic`] on a discrete distribution and panics if it is rejected.
pub fn assert_chi2_discrete(name: &str, observed: &[u64], expected: &[f64], total: usize) -> f64 {
    check_counted(name);
    let (chi2, dof, p) =
        chi2_statistic(observed, expected, total).unwrap_or_else(|e| panic!("chi2 {name}: {e}"));
    println!("chi2 {name}: statistic {chi2:.1}, dof {dof}, p = {p:.4}");
    assert!(
        p >= per_test_threshold(),
        "chi2 {name}: rejected, p = {p:.3e} < {:.3e} (statistic {chi2:.1}, dof {dof})\nobserved {observed:?}\nexpected {expected:?}",
        per_test_threshold()
    );
    p
}

// ---------------------------------------------------------------------------------------------
// Histograms of directions.

/// A histogram grid on the sphere: `rows` bins in `t = 1 - cos(theta)` over `t_range` and
/// `cols` bins in `phi` over `phi_range`, in the frame `(s, t, axis)`; every other direction
/// falls in one overflow cell. `sub x sub` midpoint nodes per cell integrate the density;
/// cells on or next to a jump of the density to or from zero are integrated again with
/// `REFINE` times more nodes per side (polygon edges, sharp corners).
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    axis: DVec3,
    s: DVec3,
    t: DVec3,
    t_range: (f64, f64),
    phi_range: (f64, f64),
    rows: usize,
    cols: usize,
    sub: usize,
}

/// Extra subdivision per side of cells at a boundary of the density's support.
const REFINE: usize = 4;
/// Nodes per side of each of the (up to three) overflow regions.
const OVERFLOW_NODES: usize = 512;

fn to_d(v: Vec3A) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

/// RGB mode's spectrum as the colour's channels, in f64.
fn spectrum_to_d(v: crate::Spectrum) -> DVec3 {
    to_d(crate::spectrum::rgb_of(v))
}

fn to_f(v: DVec3) -> Vec3A {
    Vec3A::new(v.x as f32, v.y as f32, v.z as f32)
}

impl Grid {
    /// A grid around `axis` covering `1 - cos(theta) <= t_max` (2 is the whole sphere).
    pub fn new(axis: Vec3A, t_max: f64, rows: usize, cols: usize) -> Grid {
        let axis = to_d(axis).normalize();
        // Duff et al. 2017 orthonormal basis, in f64.
        let sign = 1.0f64.copysign(axis.z);
        let a = -1.0 / (sign + axis.z);
        let b = axis.x * axis.y * a;
        let s = DVec3::new(1.0 + sign * axis.x * axis.x * a, sign * b, -sign * axis.x);
        Grid::window(
            to_f(axis),
            to_f(s),
            (0.0, t_max),
            (0.0, 2.0 * PI),
            rows,
            cols,
        )
    }

    /// A window `t_range x phi_range` of the grid with pole `axis` and `phi = 0` towards `s`
    /// (made orthogonal to `axis`).
    pub fn window(
        axis: Vec3A,
        s: Vec3A,
        t_range: (f64, f64),
        phi_range: (f64, f64),
        rows: usize,
        cols: usize,
    ) -> Grid {
        let axis = to_d(axis).normalize();
        let s = (to_d(s) - axis * axis.dot(to_d(s))).normalize();
        let t = axis.cross(s);
        assert!(
            0.0 <= t_range.0 && t_range.0 < t_range.1 && t_range.1 <= 2.0,
            "{t_range:?}"
        );
        assert!(
            0.0 <= phi_range.0 && phi_range.0 < phi_range.1 && phi_range.1 <= 2.0 * PI,
            "{phi_range:?}"
        );
        assert!(rows > 0 && cols > 0 && s.is_finite());
        Grid {
            axis,
            s,
            t,
            t_range,
            phi_range,
            rows,
            cols,
            sub: 16,
        }
    }

    /// The whole sphere around `+z`.
    pub fn sphere(rows: usize, cols: usize) -> Grid {
        Grid::new(Vec3A::Z, 2.0, rows, cols)
    }

    /// The upper hemisphere around `+z` (the lower one is the overflow cell).
    pub fn hemisphere(rows: usize, cols: usize) -> Grid {
        Grid::new(Vec3A::Z, 1.0, rows, cols)
    }

    /// A cap around `axis` for a density that vanishes beyond `1 - cos(theta) = t_edge`. The
    /// edge is put in the middle of the last row, on a boundary between integration nodes
    /// (so the midpoint rule is exact across it) and away from histogram boundaries (so
    /// rounding of samples near the edge does not move them into an empty cell).
    pub fn cap_with_edge(axis: Vec3A, t_edge: f64, rows: usize, cols: usize) -> Grid {
        Grid::new(
            axis,
            (t_edge * rows as f64 / (rows as f64 - 0.5)).min(2.0),
            rows,
            cols,
        )
    }

    /// A window around a set of `points` seen from `p` (e.g. dense samples of an area light),
    /// with a margin of 10% of their extent on every side. The pole is perpendicular to the
    /// direction `view` (towards the points), so they lie near the equator, far from the
    /// parametrisation's singular poles, where cells are nearly square.
    pub fn around_points(
        p: Vec3A,
        view: Vec3A,
        points: &[Vec3A],
        rows: usize,
        cols: usize,
    ) -> Grid {
        let v = to_d(view).normalize();
        let helper = if v.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
        let axis = v.cross(helper).normalize();
        // phi = 0 opposite to the view direction: the points are around phi = pi.
        let probe = Grid::window(to_f(axis), to_f(-v), (0.0, 2.0), (0.0, 2.0 * PI), 1, 1);
        let (mut t_lo, mut t_hi, mut p_lo, mut p_hi) = (2.0f64, 0.0f64, 2.0 * PI, 0.0f64);
        for &q in points {
            let (t, phi) = probe.coords((to_d(q) - to_d(p)).normalize());
            t_lo = t_lo.min(t);
            t_hi = t_hi.max(t);
            p_lo = p_lo.min(phi);
            p_hi = p_hi.max(phi);
        }
        let (mt, mp) = (0.1 * (t_hi - t_lo) + 1e-6, 0.1 * (p_hi - p_lo) + 1e-6);
        let t_range = ((t_lo - mt).max(0.0), (t_hi + mt).min(2.0));
        let phi_range = ((p_lo - mp).max(0.0), (p_hi + mp).min(2.0 * PI));
        Grid::window(to_f(axis), to_f(-v), t_range, phi_range, rows, cols)
    }

    fn full_phi(&self) -> bool {
        self.phi_range == (0.0, 2.0 * PI)
    }

    /// The unit direction at `(t, phi)`.
    fn direction(&self, t: f64, phi: f64) -> DVec3 {
        let sin_theta = (t * (2.0 - t)).max(0.0).sqrt();
        let (sp, cp) = phi.sin_cos();
        self.s * (sin_theta * cp) + self.t * (sin_theta * sp) + self.axis * (1.0 - t)
    }

    /// `(t, phi)` of a unit direction.
    fn coords(&self, w: DVec3) -> (f64, f64) {
        let z = w.dot(self.axis);
        let (x, y) = (w.dot(self.s), w.dot(self.t));
        let t = if z > 0.0 {
            (x * x + y * y) / (1.0 + z)
        } else {
            1.0 - z
        };
        let mut phi = y.atan2(x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        (t, phi)
    }

    fn cell_size(&self) -> (f64, f64) {
        (
            (self.t_range.1 - self.t_range.0) / self.rows as f64,
            (self.phi_range.1 - self.phi_range.0) / self.cols as f64,
        )
    }

    /// Histogram cell of `w`; `rows * cols` is the overflow cell.
    fn cell(&self, w: DVec3) -> usize {
        let (t, phi) = self.coords(w);
        let ((t0, t1), (p0, p1)) = (self.t_range, self.phi_range);
        let t_inside = t >= t0 && (t < t1 || t1 == 2.0);
        let phi_inside = self.full_phi() || (phi >= p0 && phi < p1);
        if !(t_inside && phi_inside) {
            return self.rows * self.cols;
        }
        let (dt, dp) = self.cell_size();
        let row = (((t - t0) / dt) as usize).min(self.rows - 1);
        let col = (((phi - p0) / dp) as usize).min(self.cols - 1);
        row * self.cols + col
    }

    /// Midpoint-rule integral of `pdf` over `[t0, t1] x [phi0, phi1]` with `nt x nphi` nodes,
    /// and whether some node was zero and some non-zero.
    fn integrate(
        &self,
        pdf: &impl Fn(Vec3A) -> f32,
        (t0, t1): (f64, f64),
        (p0, p1): (f64, f64),
        nt: usize,
        np: usize,
    ) -> (f64, bool, bool) {
        let (dt, dp) = ((t1 - t0) / nt as f64, (p1 - p0) / np as f64);
        let (mut sum, mut any_zero, mut any_positive) = (0.0, false, false);
        for i in 0..nt {
            let t = t0 + (i as f64 + 0.5) * dt;
            for j in 0..np {
                let w = self.direction(t, p0 + (j as f64 + 0.5) * dp);
                let v = pdf(to_f(w)) as f64;
                assert!(v.is_finite() && v >= 0.0, "pdf({w}) = {v}");
                sum += v;
                any_zero |= v == 0.0;
                any_positive |= v > 0.0;
            }
        }
        (sum * dt * dp, any_zero, any_positive)
    }

    /// Integrals of `pdf` over every cell, and over the overflow region last.
    fn integrals(&self, pdf: &impl Fn(Vec3A) -> f32) -> Vec<f64> {
        let (rt, rp) = self.cell_size();
        let bounds = |r: usize, c: usize| {
            let ts = (
                self.t_range.0 + r as f64 * rt,
                self.t_range.0 + (r + 1) as f64 * rt,
            );
            let ps = (
                self.phi_range.0 + c as f64 * rp,
                self.phi_range.0 + (c + 1) as f64 * rp,
            );
            (ts, ps)
        };
        let mut cells = Vec::with_capacity(self.rows * self.cols);
        for r in 0..self.rows {
            for c in 0..self.cols {
                let (ts, ps) = bounds(r, c);
                cells.push(self.integrate(pdf, ts, ps, self.sub, self.sub));
            }
        }
        // Refine cells where the support's boundary may pass: mixed cells, and empty cells
        // next to a cell with support (a corner may poke in between the nodes).
        let positive = |r: usize, c: usize| cells[r * self.cols + c].2;
        let mut out = Vec::with_capacity(self.rows * self.cols + 1);
        for r in 0..self.rows {
            for c in 0..self.cols {
                let (value, any_zero, any_positive) = cells[r * self.cols + c];
                let mut near_support = any_positive;
                for dr in [-1i64, 0, 1] {
                    for dc in [-1i64, 0, 1] {
                        let rr = r as i64 + dr;
                        let mut cc = c as i64 + dc;
                        if self.full_phi() {
                            cc = cc.rem_euclid(self.cols as i64);
                        }
                        if (0..self.rows as i64).contains(&rr)
                            && (0..self.cols as i64).contains(&cc)
                        {
                            near_support |= positive(rr as usize, cc as usize);
                        }
                    }
                }
                // Cells at a pole all touch each other.
                let at_pole = (r == 0 && self.t_range.0 == 0.0)
                    || (r == self.rows - 1 && self.t_range.1 == 2.0);
                if at_pole && self.full_phi() {
                    near_support |= (0..self.cols).any(|cc| positive(r, cc));
                }
                if any_zero && near_support {
                    let (ts, ps) = bounds(r, c);
                    out.push(
                        self.integrate(pdf, ts, ps, self.sub * REFINE, self.sub * REFINE)
                            .0,
                    );
                } else {
                    out.push(value);
                }
            }
        }
        // The overflow: below, above, and beside the window.
        let n = OVERFLOW_NODES;
        let mut overflow = 0.0;
        if self.t_range.0 > 0.0 {
            overflow += self
                .integrate(pdf, (0.0, self.t_range.0), (0.0, 2.0 * PI), n, n)
                .0;
        }
        if self.t_range.1 < 2.0 {
            overflow += self
                .integrate(pdf, (self.t_range.1, 2.0), (0.0, 2.0 * PI), n, n)
                .0;
        }
        if !self.full_phi() {
            let (p0, p1) = self.phi_range;
            let frac = (2.0 * PI - (p1 - p0)) / (2.0 * PI);
            let np = ((n as f64 * frac).ceil() as usize).max(1);
            // phi beyond p1 up to p0 + 2 pi (wrapping).
            overflow += self
                .integrate(pdf, self.t_range, (p1, p0 + 2.0 * PI), n, np)
                .0;
        }
        out.push(overflow);
        out
    }
}

/// Histograms `samples` draws of `sample` (a fixed-seed [`Sampler`] supplies the random
/// numbers; `None` is a rejected sample) over `grid` and runs Pearson's test against `pdf`
/// (a solid-angle density over the whole sphere). Prints the outcome; panics if the sampler
/// is rejected or returns a non-unit direction.
pub fn assert_chi2(
    name: &str,
    grid: &Grid,
    samples: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Sampler) -> Option<Vec3A>,
    pdf: impl Fn(Vec3A) -> f32,
) -> Chi2Outcome {
    check_counted(name);
    let outcome = run_chi2(grid, samples, seed, &mut sample, &pdf)
        .unwrap_or_else(|e| panic!("chi2 {name}: {e}"));
    println!(
        "chi2 {name}: statistic {:.1}, dof {}, p = {:.4}, success rate {:.4}, pdf integral {:.4}",
        outcome.statistic, outcome.dof, outcome.p_value, outcome.success_rate, outcome.pdf_integral
    );
    assert!(
        outcome.p_value >= per_test_threshold(),
        "chi2 {name}: rejected, p = {:.3e} < {:.3e} ({outcome:?})",
        outcome.p_value,
        per_test_threshold()
    );
    outcome
}

/// [`assert_chi2`] without the assertion: `Err` only for a cell expecting nothing that
/// received samples, or a malformed sample.
pub fn run_chi2(
    grid: &Grid,
    samples: usize,
    seed: u64,
    sample: &mut impl FnMut(&mut Sampler) -> Option<Vec3A>,
    pdf: &impl Fn(Vec3A) -> f32,
) -> Result<Chi2Outcome, String> {
    let cells = grid.rows * grid.cols + 1;
    let mut observed = vec![0u64; cells];
    let mut sampler = Sampler::new(seed, 0, 0);
    let mut accepted = 0usize;
    for _ in 0..samples {
        if let Some(w) = sample(&mut sampler) {
            let w = to_d(w);
            let len = w.length();
            if !(w.is_finite() && (len - 1.0).abs() < 1e-3) {
                return Err(format!("sampled direction {w} is not a unit vector"));
            }
            observed[grid.cell(w / len)] += 1;
            accepted += 1;
        }
    }
    let integrals = grid.integrals(pdf);
    let expected: Vec<f64> = integrals.iter().map(|&i| i * samples as f64).collect();
    // Set CHI2_DEBUG=1 (with --nocapture) for per-row counts when a test fails.
    if std::env::var_os("CHI2_DEBUG").is_some() {
        for r in 0..grid.rows {
            let (mut o, mut e, mut c2) = (0.0, 0.0, 0.0);
            for c in 0..grid.cols {
                let i = r * grid.cols + c;
                o += observed[i] as f64;
                e += expected[i];
                if expected[i] > 0.0 {
                    c2 += (observed[i] as f64 - expected[i]).powi(2) / expected[i];
                }
            }
            eprintln!("row {r}: observed {o} expected {e:.1} chi2 {c2:.1}");
        }
        eprintln!(
            "overflow: observed {} expected {:.1}",
            observed[cells - 1],
            expected[cells - 1]
        );
    }
    let (statistic, dof, p_value) = chi2_statistic(&observed, &expected, samples)?;
    Ok(Chi2Outcome {
        statistic,
        dof,
        p_value,
        success_rate: accepted as f64 / samples as f64,
        pdf_integral: integrals.iter().sum(),
    })
}

// ---------------------------------------------------------------------------------------------
// BSDF helpers.

/// Draws `samples` samples of `bxdf` for `wo` and checks each against `eval` and `pdf`: the
/// sample's `pdf` must equal `pdf(wo, wi)` and its `f` must equal `eval(wo, wi)` (relative
/// tolerance 1e-4), `wi` must be a unit vector and the lobe must not claim to be specular.
pub fn check_sample_matches_eval<B: Bxdf>(bxdf: &B, wo: Vec3A, samples: usize, seed: u64) {
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-4 * a.abs().max(b.abs()) + 1e-7;
    let mut s = Sampler::new(seed, 0, 0);
    let mut accepted = 0;
    for _ in 0..samples {
        let (ul, u) = (s.next_1d(), s.next_2d());
        let Some(bs) = bxdf.sample(wo, ul, u) else {
            continue;
        };
        accepted += 1;
        assert!(
            (bs.wi.length() - 1.0).abs() < 1e-4,
            "wi {:?} not unit",
            bs.wi
        );
        assert!(!bs.specular);
        assert!(bs.pdf > 0.0 && bs.pdf.is_finite(), "pdf {}", bs.pdf);
        let pdf = bxdf.pdf(wo, bs.wi);
        assert!(
            close(bs.pdf, pdf),
            "sampled pdf {} != pdf() {} at wo {wo:?} wi {:?}",
            bs.pdf,
            pdf,
            bs.wi
        );
        let f = bxdf.eval(wo, bs.wi);
        for c in 0..3 {
            assert!(
                close(bs.f[c], f[c]),
                "sampled f {:?} != eval {:?} at wo {wo:?} wi {:?}",
                bs.f,
                f,
                bs.wi
            );
        }
        assert!(bs.weight().is_finite());
    }
    assert!(accepted > 0, "no sample accepted at wo {wo:?}");
}

/// Monte Carlo estimate of the directional albedo `integral f(wo, wi) cos(theta_i) dwi` with
/// `bxdf`'s own sampling (rejected samples count as zero): the mean and its standard error,
/// per channel.
pub fn directional_albedo<B: Bxdf>(
    bxdf: &B,
    wo: Vec3A,
    samples: usize,
    seed: u64,
) -> (DVec3, DVec3) {
    let mut s = Sampler::new(seed, 0, 0);
    let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
    for _ in 0..samples {
        let (ul, u) = (s.next_1d(), s.next_2d());
        if let Some(bs) = bxdf.sample(wo, ul, u) {
            let w = spectrum_to_d(bs.weight());
            sum += w;
            sum2 += w * w;
        }
    }
    let n = samples as f64;
    let mean = sum / n;
    let var = (sum2 / n - mean * mean).max(DVec3::ZERO);
    (mean, (var / n).sqrt())
}

/// Asserts that the directional albedo for `wo` does not exceed `bound` in any channel, up to
/// 4.5 standard errors. Returns the estimate.
pub fn assert_energy_conserving<B: Bxdf>(
    name: &str,
    bxdf: &B,
    wo: Vec3A,
    bound: crate::Spectrum,
    samples: usize,
    seed: u64,
) -> DVec3 {
    let (mean, err) = directional_albedo(bxdf, wo, samples, seed);
    println!(
        "energy {name}: wo.z {:.3}: albedo {mean:.4} +- {err:.4} (bound {bound})",
        wo.z
    );
    for c in 0..3 {
        assert!(
            mean[c] <= bound[c] as f64 + 4.5 * err[c] + 1e-5,
            "energy {name}: albedo {mean} +- {err} exceeds {bound} at wo {wo:?}"
        );
    }
    mean
}

/// A unit direction at polar angle `theta_deg` from `+z` and azimuth `phi_deg`.
pub fn dir(theta_deg: f32, phi_deg: f32) -> Vec3A {
    let (st, ct) = theta_deg.to_radians().sin_cos();
    let (sp, cp) = phi_deg.to_radians().sin_cos();
    Vec3A::new(st * cp, st * sp, ct)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};

    #[test]
    fn chi2_survival_function_matches_tables() {
        // Critical values from standard tables.
        assert!((chi2_sf(3.841_458_820_694_124, 1) - 0.05).abs() < 1e-9);
        assert!((chi2_sf(18.307_038_053_275_146, 10) - 0.05).abs() < 1e-9);
        assert!((chi2_sf(124.342_113_404_463_2, 100) - 0.05).abs() < 1e-8);
        assert!((chi2_sf(6.634_896_601_021_214, 1) - 0.01).abs() < 1e-9);
        // dof = 2 is an exponential distribution.
        for x in [0.1, 1.0, 5.0, 40.0] {
            assert!((chi2_sf(x, 2) - (-x / 2.0f64).exp()).abs() < 1e-12);
        }
        // Large dof (both branches): the median of chi2(k) is about k (1 - 2/(9k))^3.
        for k in [500usize, 3000] {
            let m = k as f64 * (1.0 - 2.0 / (9.0 * k as f64)).powi(3);
            assert!(
                (chi2_sf(m, k) - 0.5).abs() < 1e-3,
                "k {k}: {}",
                chi2_sf(m, k)
            );
        }
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
        assert!((ln_gamma(10.0) - 362_880f64.ln()).abs() < 1e-10);
    }

    #[test]
    fn sidak_threshold_is_about_one_percent_over_the_suite() {
        // The build script found the suite (41 tests when it was counted by hand).
        const { assert!(CHI2_TESTS >= 41) };
        let a = per_test_threshold();
        assert!((1.0 - (1.0 - a).powi(CHI2_TESTS as i32) - SIGNIFICANCE).abs() < 1e-12);
    }

    #[test]
    fn pooling_counts_zero_expectation_violations() {
        assert!(chi2_statistic(&[10, 0], &[0.0, 10.0], 100).is_err());
        let (chi2, dof, _) = chi2_statistic(&[50, 50], &[50.0, 50.0], 100).expect("valid");
        assert_eq!((chi2, dof), (0.0, 1));
    }

    /// The negative controls: the harness must reject a density that is off by 10%, either in
    /// scale or in shape. Not counted in [`CHI2_TESTS`] (they assert rejection).
    #[test]
    fn harness_rejects_wrong_densities() {
        let grid = Grid::hemisphere(10, 20);
        let mut sample = |s: &mut Sampler| Some(cosine_hemisphere(s.next_2d()));
        // Scale off by 10%.
        let wrong_scale = |w: Vec3A| 1.1 * cosine_hemisphere_pdf(w.z);
        let out = run_chi2(&grid, 200_000, 3, &mut sample, &wrong_scale).expect("runs");
        assert!(out.p_value < 1e-12, "{out:?}");
        // Shape off: cos^1.1 (normalised: integral of cos^k over the hemisphere is
        // 2 pi / (k + 1)), i.e. up to ~10% too low near the horizon.
        let wrong_shape = |w: Vec3A| w.z.max(0.0).powf(1.1) * 2.1 / (2.0 * std::f32::consts::PI);
        let out = run_chi2(&grid, 200_000, 3, &mut sample, &wrong_shape).expect("runs");
        assert!(out.p_value < per_test_threshold(), "{out:?}");
        // And the right one passes.
        let right = |w: Vec3A| cosine_hemisphere_pdf(w.z);
        let out = run_chi2(&grid, 200_000, 3, &mut sample, &right).expect("runs");
        assert!(out.p_value > per_test_threshold(), "{out:?}");
        assert!((out.pdf_integral - 1.0).abs() < 1e-3);
    }

    #[test]
    fn harness_rejects_samples_where_the_density_is_zero() {
        // Uniform sphere samples against a hemisphere density: the lower half expects nothing.
        let grid = Grid::sphere(10, 20);
        let mut sample = |s: &mut Sampler| Some(crate::sampling::uniform_sphere(s.next_2d()));
        let half = |w: Vec3A| {
            if w.z > 0.0 {
                crate::sampling::UNIFORM_HEMISPHERE_PDF
            } else {
                0.0
            }
        };
        assert!(run_chi2(&grid, 10_000, 1, &mut sample, &half).is_err());
    }

    #[test]
    fn grid_coordinates_round_trip() {
        let g = Grid::new(Vec3A::new(0.3, -0.2, 0.9), 2.0, 8, 16);
        for (t, phi) in [(1e-6, 0.1), (0.5, 3.0), (1.5, 6.0), (1.999, 1.0)] {
            let (t2, p2) = g.coords(g.direction(t, phi));
            assert!(
                (t - t2).abs() < 1e-9 * t.max(1.0) && (phi - p2).abs() < 1e-6,
                "{t} {phi} -> {t2} {p2}"
            );
        }
    }
}
