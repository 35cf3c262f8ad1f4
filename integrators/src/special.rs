//! Special functions of statistics, for the tests that judge renders: `ln Γ`, `erfc`, the
//! regularized incomplete beta function, and the two-sided p-values of the normal and of
//! Student's t built on them. Used by the chi-square tests of the sampling routines
//! (`testing::chi2`) and by the engine's per-pixel z-test of images.

use std::f64::consts::PI;

/// `ln(Gamma(x))` for `x > 0` (Lanczos, g = 7, n = 9; ~15 digits).
pub fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// `erfc(x)` for `x >= 0` (Numerical Recipes' Chebyshev fit, relative error below 1.2e-7).
pub fn erfc(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.5 * x);
    let poly = -x * x - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    t * poly.exp()
}

/// Two-sided p-value of a standard normal statistic.
pub fn p_value(z: f64) -> f64 {
    erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// The continued fraction of the incomplete beta function (modified Lentz).
fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let guard = |v: f64| if v.abs() < TINY { TINY } else { v };
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 / guard(1.0 - qab * x / qap);
    let mut h = d;
    for m in 1..=500 {
        let m = m as f64;
        let aa = m * (b - m) * x / ((qam + 2.0 * m) * (a + 2.0 * m));
        d = 1.0 / guard(1.0 + aa * d);
        c = guard(1.0 + aa / c);
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + 2.0 * m) * (qap + 2.0 * m));
        d = 1.0 / guard(1.0 + aa * d);
        c = guard(1.0 + aa / c);
        let step = d * c;
        h *= step;
        if (step - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// The regularized incomplete beta function `I_x(a, b)`.
pub fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_fraction(b, a, 1.0 - x) / b
    }
}

/// Two-sided p-value of Student's t with `dof` degrees of freedom (the normal's when `dof`
/// is infinite or very large).
pub fn p_value_t(t: f64, dof: f64) -> f64 {
    if !dof.is_finite() || dof > 1e6 {
        return p_value(t);
    }
    let dof = dof.max(1.0);
    incomplete_beta(0.5 * dof, 0.5, dof / (dof + t * t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn p_values_of_the_normal_and_students_t() {
        assert!((p_value(1.959964) - 0.05).abs() < 1e-6);
        assert!((p_value(-2.575829) - 0.01).abs() < 1e-6);
        assert!((p_value(0.0) - 1.0).abs() < 1e-6);
        // Student's t tables: t(0.975) for 1, 5 and 24 degrees of freedom, t(0.995) for 10.
        for (t, dof, p) in [
            (12.706, 1.0, 0.05),
            (2.571, 5.0, 0.05),
            (2.064, 24.0, 0.05),
            (3.169, 10.0, 0.01),
        ] {
            assert!(
                (p_value_t(t, dof) - p).abs() < 2e-4 * p / 0.01,
                "t {t}, {dof} dof"
            );
        }
        assert!((p_value_t(2.575829, f64::INFINITY) - 0.01).abs() < 1e-6);
        assert!((p_value_t(0.0, 7.0) - 1.0).abs() < 1e-12);
        // Far tails, where a Šidák level lies: t = 9 with 24 degrees of freedom is 3.69e-9
        // two-sided (by numerical integration of the density).
        let far = p_value_t(9.0, 24.0);
        assert!((far / 3.6906e-9 - 1.0).abs() < 0.01, "{far}");
        // ln Γ at integers and at one half.
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
    }
}
