//! Parameter checks that every material's constructor shares: a material is valid by
//! construction, whichever loader (RON, a mesh file's materials) asks for it.

use crate::Spectrum;

/// `values` all finite, or an error naming `what`.
pub fn finite(what: &str, values: &[f32]) -> Result<(), String> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} must be finite, got {values:?}"))
    }
}

/// A finite, non-negative colour.
pub fn colour(what: &str, c: Spectrum) -> Result<Spectrum, String> {
    let a = crate::spectrum::rgb_of(c).to_array();
    finite(what, &a)?;
    if a.iter().any(|c| *c < 0.0) {
        return Err(format!("{what} must not be negative, got {a:?}"));
    }
    Ok(c)
}

/// A reflectance: a colour in `[0, 1]` per channel.
pub fn reflectance(what: &str, c: Spectrum) -> Result<Spectrum, String> {
    let c = colour(what, c)?;
    if c.max_element() > 1.0 {
        return Err(format!(
            "{what} must be in [0, 1] (a reflectance), got {:?}",
            crate::spectrum::rgb_of(c).to_array()
        ));
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use crate::bsdf::{Conductor, Dielectric, Lambert, OrenNayar, Phong};
    use crate::Spectrum;

    #[test]
    fn constructors_refuse_what_no_material_can_be() {
        let half = Spectrum::splat(0.5);
        assert!(Lambert::new(half).is_ok() && Lambert::new(Spectrum::splat(1.2)).is_err());
        assert!(Lambert::new(crate::spectrum::rgb(f32::NAN, 0.1, 0.1))
            .unwrap_err()
            .contains("finite"));
        assert!(OrenNayar::checked(half, 20.0).is_ok());
        assert!(OrenNayar::checked(half, 91.0)
            .unwrap_err()
            .contains("[0, 90]"));
        assert!(Phong::new(half, Spectrum::splat(0.4), 10.0).is_ok());
        assert!(Phong::new(half, Spectrum::splat(0.6), 10.0)
            .unwrap_err()
            .contains("conserve energy"));
        assert!(Phong::new(half, Spectrum::splat(0.4), 1e6).is_err());
        assert!(Conductor::new(None, Spectrum::splat(-0.1))
            .unwrap_err()
            .contains("negative"));
        assert!(
            Dielectric::new(1.5, Spectrum::ONE, Spectrum::ONE).is_ok()
                && Dielectric::new(0.1, Spectrum::ONE, Spectrum::ONE).is_err()
        );
        assert!(Dielectric::new(f32::INFINITY, Spectrum::ONE, Spectrum::ONE).is_err());
    }
}
