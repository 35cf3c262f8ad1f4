//! Parameter checks that every material's constructor shares: a material is valid by
//! construction, whichever loader (RON, a mesh file's materials) asks for it.

use crate::Rgb;

/// `values` all finite, or an error naming `what`.
pub fn finite(what: &str, values: &[f32]) -> Result<(), String> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} must be finite, got {values:?}"))
    }
}

/// A finite, non-negative colour.
pub fn colour(what: &str, c: Rgb) -> Result<Rgb, String> {
    let a = c.to_array();
    finite(what, &a)?;
    if a.iter().any(|c| *c < 0.0) {
        return Err(format!("{what} must not be negative, got {a:?}"));
    }
    Ok(c)
}

/// A reflectance: a colour in `[0, 1]` per channel.
pub fn reflectance(what: &str, c: Rgb) -> Result<Rgb, String> {
    let c = colour(what, c)?;
    if c.max_element() > 1.0 {
        return Err(format!(
            "{what} must be in [0, 1] (a reflectance), got {:?}",
            c.to_array()
        ));
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use crate::bsdf::{Conductor, Dielectric, Lambert, OrenNayar, Phong};
    use crate::Rgb;

    #[test]
    fn constructors_refuse_what_no_material_can_be() {
        let half = Rgb::splat(0.5);
        assert!(Lambert::new(half).is_ok() && Lambert::new(Rgb::splat(1.2)).is_err());
        assert!(Lambert::new(Rgb::new(f32::NAN, 0.1, 0.1))
            .unwrap_err()
            .contains("finite"));
        assert!(OrenNayar::checked(half, 20.0).is_ok());
        assert!(OrenNayar::checked(half, 91.0)
            .unwrap_err()
            .contains("[0, 90]"));
        assert!(Phong::new(half, Rgb::splat(0.4), 10.0).is_ok());
        assert!(Phong::new(half, Rgb::splat(0.6), 10.0)
            .unwrap_err()
            .contains("conserve energy"));
        assert!(Phong::new(half, Rgb::splat(0.4), 1e6).is_err());
        assert!(Conductor::new(None, Rgb::splat(-0.1))
            .unwrap_err()
            .contains("negative"));
        assert!(
            Dielectric::new(1.5, Rgb::ONE, Rgb::ONE).is_ok()
                && Dielectric::new(0.1, Rgb::ONE, Rgb::ONE).is_err()
        );
        assert!(Dielectric::new(f32::INFINITY, Rgb::ONE, Rgb::ONE).is_err());
    }
}
