//! The light sampler: picks an emitter in proportion to its power, or to weights the scene
//! gives (uniform over emitting entities, as Mitsuba 3).

use super::Light;

/// All emitters of a scene with a power-proportional selection distribution.
#[derive(Clone, Debug, Default)]
pub struct LightTable {
    lights: Vec<Light>,
    pmf: Vec<f32>,
    cdf: Vec<f32>,
    environment: Option<u32>,
}

impl LightTable {
    /// Builds the table; selection is proportional to [`Light::power`] (uniform if every
    /// power is zero). At most one environment light: if there are several, the first one is
    /// the one [`LightTable::environment`] reports.
    pub fn new(lights: Vec<Light>, scene_radius: f32) -> LightTable {
        let powers = Self::powers(&lights, scene_radius);
        Self::with_weights(lights, powers)
    }

    /// Each light's [`Light::power`], 0 where it is not a finite positive number.
    pub fn powers(lights: &[Light], scene_radius: f32) -> Vec<f64> {
        lights
            .iter()
            .map(|l| {
                let p = l.power(scene_radius);
                if p.is_finite() && p > 0.0 {
                    p
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// Builds the table with selection proportional to `weights` (one per light, finite and
    /// not negative; uniform if they are all zero).
    pub fn with_weights(lights: Vec<Light>, powers: Vec<f64>) -> LightTable {
        debug_assert_eq!(lights.len(), powers.len());
        let total: f64 = powers.iter().sum();
        let pmf: Vec<f32> = if total > 0.0 && total.is_finite() {
            powers.iter().map(|&p| (p / total) as f32).collect()
        } else {
            vec![1.0 / lights.len().max(1) as f32; lights.len()]
        };
        // Running sum in f64; a light with zero probability gets the same cdf value as its
        // predecessor, so the search below can never land on it. Everything from the last
        // light with a non-zero probability on is pinned to exactly 1.
        let mut cdf = Vec::with_capacity(pmf.len());
        let norm = sum_or_one(&pmf);
        let mut sum = 0.0f64;
        for &p in &pmf {
            sum += p as f64;
            cdf.push((sum / norm) as f32);
        }
        if let Some(last) = pmf.iter().rposition(|&p| p > 0.0) {
            for c in &mut cdf[last..] {
                *c = 1.0;
            }
        }
        let environment = lights
            .iter()
            .position(Light::is_environment)
            .and_then(|i| u32::try_from(i).ok());
        LightTable {
            lights,
            pmf,
            cdf,
            environment,
        }
    }

    /// The emitters, in the order their indices refer to.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Number of emitters.
    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// True if the scene has no emitters.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Light `index`. Panics if `index` is out of range (indices come from the table itself).
    pub fn get(&self, index: u32) -> &Light {
        &self.lights[index as usize]
    }

    /// Picks a light with `u` in `[0, 1)`: its index and selection probability. `None` if the
    /// table is empty; never returns a light whose probability is zero.
    pub fn sample(&self, u: f32) -> Option<(u32, f32)> {
        if self.lights.is_empty() {
            return None;
        }
        // Clamp into [0, 1) (NaN -> 0): the cdf reaches exactly 1 at the last light with a
        // non-zero probability, so the search stops there at the latest.
        let u = if u > 0.0 {
            u.min(1.0 - f32::EPSILON / 2.0)
        } else {
            0.0
        };
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.lights.len() - 1);
        Some((i as u32, self.pmf[i]))
    }

    /// Probability that [`LightTable::sample`] picks light `index`.
    pub fn pmf(&self, index: u32) -> f32 {
        self.pmf[index as usize]
    }

    /// Index of the environment light, if the scene has one.
    pub fn environment(&self) -> Option<u32> {
        self.environment
    }
}

/// Sum of the (f32) probabilities in f64, or 1 when it is not positive.
fn sum_or_one(pmf: &[f32]) -> f64 {
    let s: f64 = pmf.iter().map(|&p| p as f64).sum();
    if s > 0.0 {
        s
    } else {
        1.0
    }
}
