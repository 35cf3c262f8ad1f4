//! The registry of integrators: a static list of entries (name, summary, parameters with
//! defaults, constructor). Adding an integrator is one file and one line in [`REGISTRY`].

use crate::Integrator;
use std::fmt;

/// How a parameter's value is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    /// A whole number.
    Int,
    /// A real number.
    Float,
    /// A path depth: a whole number, or `unlimited` (also `inf`).
    Depth,
    /// One of a list of names; the value is its place in the list.
    Choice(&'static [&'static str]),
}

impl ParamKind {
    /// The kind's name, as listings and the page show it.
    pub fn name(self) -> &'static str {
        match self {
            ParamKind::Int => "int",
            ParamKind::Float => "float",
            ParamKind::Depth => "depth",
            ParamKind::Choice(_) => "choice",
        }
    }
}

/// One parameter of an integrator.
#[derive(Clone, Copy, Debug)]
pub struct ParamSpec {
    pub name: &'static str,
    pub kind: ParamKind,
    /// Default value; `f64::INFINITY` means unlimited for [`ParamKind::Depth`].
    pub default: f64,
    pub min: f64,
    pub max: f64,
    pub doc: &'static str,
}

/// `max-depth` as every integrator that bounds its paths declares it (unlimited by default;
/// adjust one field with the `with_` methods).
pub const MAX_DEPTH: ParamSpec = ParamSpec {
    name: "max-depth",
    kind: ParamKind::Depth,
    default: f64::INFINITY,
    min: 0.0,
    max: f64::INFINITY,
    doc: "scattering events per path (unlimited = unbiased)",
};

/// The names [`LIGHT_SELECTION`] takes: the scene's choice, then the light table's.
pub const LIGHT_SELECTIONS: &[&str] = &["scene", "uniform", "power", "bvh"];

/// `light-selection` as every integrator that samples lights for a shading point declares
/// it: the scene's choice (`render.light_selection`, power unless it says) by default.
pub const LIGHT_SELECTION: ParamSpec = ParamSpec {
    name: "light-selection",
    kind: ParamKind::Choice(LIGHT_SELECTIONS),
    default: 0.0,
    min: 0.0,
    max: (LIGHT_SELECTIONS.len() - 1) as f64,
    doc: "how a light sample picks its light: scene (the scene's choice), uniform, power, or bvh (a light BVH)",
};

/// `rr-depth` as every integrator that plays Russian roulette declares it.
pub const RR_DEPTH: ParamSpec = ParamSpec {
    name: "rr-depth",
    kind: ParamKind::Int,
    default: 3.0,
    min: 0.0,
    max: 1e6,
    doc: "scattering events before Russian roulette starts",
};

/// A photon count, as the photon-mapping integrators declare it.
pub const PHOTONS: ParamSpec = ParamSpec {
    name: "photons",
    kind: ParamKind::Int,
    default: 100_000.0,
    min: 1.0,
    max: 1e9,
    doc: "photons traced per pass",
};

/// A gather radius in scene units, 0 for one chosen from the scene's size, as the
/// photon-mapping integrators declare it.
pub const GATHER_RADIUS: ParamSpec = ParamSpec {
    name: "radius",
    kind: ParamKind::Float,
    default: 0.0,
    min: 0.0,
    max: 1e7,
    doc: "gather radius, scene units (0 = 1% of the bounding-box diagonal)",
};

impl ParamSpec {
    /// The same parameter under another name.
    pub const fn with_name(self, name: &'static str) -> ParamSpec {
        ParamSpec { name, ..self }
    }

    /// The same parameter with another smallest value.
    pub const fn with_min(self, min: f64) -> ParamSpec {
        ParamSpec { min, ..self }
    }

    /// The same parameter with another default.
    pub const fn with_default(self, default: f64) -> ParamSpec {
        ParamSpec { default, ..self }
    }

    /// The same parameter with another largest value.
    pub const fn with_max(self, max: f64) -> ParamSpec {
        ParamSpec { max, ..self }
    }

    /// The same parameter with another description.
    pub const fn with_doc(self, doc: &'static str) -> ParamSpec {
        ParamSpec { doc, ..self }
    }

    /// The default as a user would type it.
    pub fn default_text(&self) -> String {
        format_value(self.kind, self.default)
    }

    fn parse(&self, text: &str) -> Result<f64, String> {
        let t = text.trim();
        if let ParamKind::Choice(names) = self.kind {
            return names
                .iter()
                .position(|n| *n == t)
                .map(|i| i as f64)
                .ok_or_else(|| format!("`{t}` is not one of {}", names.join(", ")));
        }
        let value = if self.kind == ParamKind::Depth
            && matches!(
                t.to_ascii_lowercase().as_str(),
                "unlimited" | "inf" | "infinite"
            ) {
            f64::INFINITY
        } else {
            t.parse::<f64>()
                .map_err(|_| format!("`{t}` is not a number"))?
        };
        if value.is_nan() || (value.is_infinite() && self.kind != ParamKind::Depth) {
            return Err(format!("`{t}` is not a finite number"));
        }
        if self.kind != ParamKind::Float && value.is_finite() && value.fract() != 0.0 {
            return Err(format!("`{t}` is not a whole number"));
        }
        if value < self.min || value > self.max {
            return Err(format!(
                "{} is out of range [{}, {}]",
                t,
                format_value(self.kind, self.min),
                format_value(self.kind, self.max)
            ));
        }
        Ok(value)
    }
}

fn format_value(kind: ParamKind, v: f64) -> String {
    if let ParamKind::Choice(names) = kind {
        return names.get(v as usize).copied().unwrap_or("?").to_string();
    }
    if v.is_infinite() && kind == ParamKind::Depth {
        "unlimited".to_string()
    } else if kind == ParamKind::Float && v != 0.0 && (v * 1e6).fract() != 0.0 {
        // Nine significant digits at most (2/3 prints as 0.666666667).
        let digits = (8 - v.abs().log10().floor() as i32).clamp(0, 17) as usize;
        let text = format!("{v:.digits$}");
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v}")
    }
}

/// Resolved parameter values (every parameter of the entry, defaults filled in).
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    values: Vec<(&'static str, f64)>,
}

impl Params {
    /// The value of `name`. Panics on a name the entry does not declare: that is a bug in the
    /// integrator, not bad input (input is checked by [`IntegratorEntry::resolve`]).
    pub fn get(&self, name: &str) -> f64 {
        self.values
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| *v)
            .unwrap_or_else(|| panic!("integrator reads undeclared parameter `{name}`"))
    }

    /// A whole-number parameter.
    pub fn get_u32(&self, name: &str) -> u32 {
        self.get(name) as u32
    }

    /// A choice parameter: the place of its name in the list.
    pub fn get_choice(&self, name: &str) -> usize {
        self.get(name) as usize
    }

    /// [`LIGHT_SELECTION`]'s value: `None` for the scene's choice.
    pub fn get_light_selection(&self) -> Option<crate::light::LightSelection> {
        let name = LIGHT_SELECTIONS[self.get_choice(LIGHT_SELECTION.name)];
        crate::light::LightSelection::parse(name).ok()
    }

    /// A parameter's value as a user would type it.
    pub fn text(&self, spec: &ParamSpec) -> String {
        format_value(spec.kind, self.get(spec.name))
    }

    /// A depth parameter; `u32::MAX` stands for unlimited.
    pub fn get_depth(&self, name: &str) -> u32 {
        let v = self.get(name);
        if v.is_infinite() {
            u32::MAX
        } else {
            v as u32
        }
    }

    /// `name=value` pairs, for reports.
    pub fn describe(&self, specs: &[ParamSpec]) -> String {
        specs
            .iter()
            .map(|s| format!("{}={}", s.name, format_value(s.kind, self.get(s.name))))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// One integrator in the registry.
pub struct IntegratorEntry {
    pub name: &'static str,
    pub summary: &'static str,
    pub params: &'static [ParamSpec],
    pub build: fn(&Params) -> Box<dyn Integrator>,
    /// What it must give on the testing kit's analytic scenes (`None`: debug views, and
    /// integrators whose estimates are not independent between passes, tested on their own).
    pub analytic: Option<Analytic>,
    /// Which participating media it renders; it refuses a scene with others rather than
    /// render them as vacuum (or dark).
    pub media: MediaSupport,
    /// How it carries wavelengths in spectral mode (`--spectral`).
    pub spectral: SpectralSupport,
}

/// How an integrator carries wavelengths in spectral mode. Every integrator renders
/// spectrally; they differ in which paths share a set of wavelengths.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectralSupport {
    /// Each camera sample its own, drawn by the render loop (light subpaths of the sample
    /// carry the same).
    PerSample,
    /// One set per pass, shared by every path of the pass (photons and the camera paths that
    /// gather them; only the hero where a material disperses).
    PerPass,
    /// Each Markov-chain proposal its own, drawn from its primary samples.
    PerProposal,
    /// A view of the scene, not light: RGB in either mode.
    Spectrum,
}

impl SpectralSupport {
    /// What `raylab integrators` says of it.
    pub fn describe(self) -> &'static str {
        match self {
            SpectralSupport::PerSample => "spectral (--spectral): wavelengths per camera sample",
            SpectralSupport::PerPass => "spectral (--spectral): wavelengths per pass, shared by its photons and camera paths",
            SpectralSupport::PerProposal => "spectral (--spectral): wavelengths per proposal, from its primary samples",
            SpectralSupport::Spectrum => "RGB in either mode (a view, not light)",
        }
    }
}

/// Which participating media an integrator renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MediaSupport {
    /// None: surfaces in vacuum only.
    None,
    /// Media that absorb and scatter, not media that emit (its paths from the lights do not
    /// start in a glowing medium).
    Scattering,
    /// Every medium, emitting ones too.
    Full,
}

impl MediaSupport {
    /// Whether it renders media at all.
    pub fn any(self) -> bool {
        self != MediaSupport::None
    }
}

/// What an integrator gives, with `params`, on the testing kit's analytic scenes: each
/// expectation is the exact answer, or the truncated series its depth limit leaves (`None`
/// where the scene says nothing about it). `integrator/analytic_tests.rs` checks every entry
/// that declares one.
#[derive(Clone, Copy, Debug)]
pub struct Analytic {
    pub params: &'static [(&'static str, &'static str)],
    /// Inside a closed sphere of albedo 0.5 emitting 1 (`furnace_sphere(0.5, 1)`):
    /// `sum_{k <= depth} 0.5^k`, 2 when unbounded.
    pub furnace: Option<Expect>,
    /// A point light of intensity pi in a unit sphere of albedo 0.5 (`point_in_sphere(0.5)`):
    /// 0.5 of direct light, 0.25 more per bounce, 1 in all.
    pub point_in_sphere: Option<Expect>,
    /// A convex ball of albedo 0.6 under a sky of 2 (`sphere_under_sky(0.6, 2)`): 1.2.
    pub sphere_under_sky: Option<Expect>,
}

/// An expected mean radiance, checked by a t-test over `passes` passes of `per_pass` probe
/// rays (enough for the standard error to reveal a 5% bias).
#[derive(Clone, Copy, Debug)]
pub struct Expect {
    pub value: f32,
    pub passes: u32,
    pub per_pass: u32,
}

/// `Some(Expect { value, passes, per_pass })`.
pub const fn expect(value: f32, passes: u32, per_pass: u32) -> Option<Expect> {
    Some(Expect {
        value,
        passes,
        per_pass,
    })
}

/// What is wrong with an integrator name or parameter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ParamError {
    UnknownIntegrator {
        name: String,
    },
    UnknownParam {
        integrator: &'static str,
        name: String,
        valid: Vec<&'static str>,
    },
    BadValue {
        integrator: &'static str,
        name: String,
        reason: String,
    },
    /// Values each in range whose combination no machine can run.
    TooCostly {
        integrator: &'static str,
        reason: String,
    },
}

/// The most rays a camera sample may cast: at ten million rays a second, a minute and a half
/// per sample and thread. More is a configuration that never finishes a pass.
pub const MAX_RAYS_PER_SAMPLE: f64 = 1e9;

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamError::UnknownIntegrator { name } => write!(
                f,
                "unknown integrator `{name}`; valid integrators: {}",
                REGISTRY
                    .iter()
                    .map(|e| e.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            ParamError::UnknownParam {
                integrator,
                name,
                valid,
            } => {
                if valid.is_empty() {
                    write!(
                        f,
                        "integrator `{integrator}` takes no parameters, got `{name}`"
                    )
                } else {
                    write!(
                        f,
                        "integrator `{integrator}` has no parameter `{name}`; valid parameters: {}",
                        valid.join(", ")
                    )
                }
            }
            ParamError::BadValue {
                integrator,
                name,
                reason,
            } => {
                write!(
                    f,
                    "parameter `{name}` of integrator `{integrator}`: {reason}"
                )
            }
            ParamError::TooCostly { integrator, reason } => {
                write!(f, "integrator `{integrator}`: {reason}")
            }
        }
    }
}

impl std::error::Error for ParamError {}

impl IntegratorEntry {
    /// Checks `given` (name, value text) against the declared parameters and fills defaults.
    /// Later values override earlier ones, so scene defaults can precede command-line values.
    pub fn resolve(&self, given: &[(String, String)]) -> Result<Params, ParamError> {
        let mut values: Vec<(&'static str, f64)> =
            self.params.iter().map(|p| (p.name, p.default)).collect();
        for (name, text) in given {
            let idx = self
                .params
                .iter()
                .position(|p| p.name == name)
                .ok_or_else(|| ParamError::UnknownParam {
                    integrator: self.name,
                    name: name.clone(),
                    valid: self.params.iter().map(|p| p.name).collect(),
                })?;
            values[idx].1 =
                self.params[idx]
                    .parse(text)
                    .map_err(|reason| ParamError::BadValue {
                        integrator: self.name,
                        name: name.clone(),
                        reason,
                    })?;
        }
        Ok(Params { values })
    }

    /// Resolves the parameters and builds the integrator.
    pub fn instantiate(
        &self,
        given: &[(String, String)],
    ) -> Result<Box<dyn Integrator>, ParamError> {
        self.build_checked(&self.resolve(given)?)
    }

    /// Builds the integrator from resolved parameters, refusing a combination that cannot
    /// finish a pass (see [`MAX_RAYS_PER_SAMPLE`]).
    pub fn build_checked(&self, params: &Params) -> Result<Box<dyn Integrator>, ParamError> {
        let integrator = (self.build)(params);
        let rays = integrator.demand().rays_per_sample;
        if rays > MAX_RAYS_PER_SAMPLE {
            return Err(ParamError::TooCostly {
                integrator: self.name,
                reason: format!(
                    "these parameters cast about {rays:.1e} rays per camera sample, more than the {MAX_RAYS_PER_SAMPLE:.0e} a pass can finish; lower them"
                ),
            });
        }
        Ok(integrator)
    }
}

/// Every integrator raylab offers, in the order `raylab integrators` lists them.
pub static REGISTRY: &[IntegratorEntry] = &[
    super::whitted::ENTRY,
    super::fixed_depth::ENTRY,
    super::russian_roulette::ENTRY,
    super::path::ENTRY,
    super::wavefront::ENTRY,
    super::wavefront::RUSSIAN_ROULETTE_ENTRY,
    super::direct::ENTRY,
    super::restir::ENTRY,
    super::light_tracer::ENTRY,
    super::bdpt::ENTRY,
    super::bpm::ENTRY,
    super::vcm::ENTRY,
    super::photon::ENTRY,
    super::sppm::ENTRY,
    super::sppm_pixel::ENTRY,
    super::pssmlt::ENTRY,
    super::mmlt::ENTRY,
    super::vpl::ENTRY,
    super::guided::ENTRY,
    super::volpath::ENTRY,
    super::normals_view::ENTRY,
    super::albedo_view::ENTRY,
    super::depth_view::ENTRY,
];

/// Looks an integrator up by name.
pub fn find(name: &str) -> Result<&'static IntegratorEntry, ParamError> {
    REGISTRY
        .iter()
        .find(|e| e.name == name)
        .ok_or_else(|| ParamError::UnknownIntegrator {
            name: name.to_string(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn given(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
        pairs
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect()
    }

    #[test]
    fn sixteen_light_transport_integrators_besides_the_debug_views() {
        // Mitsuba 0.6, the peer with the most, has about 14.
        let transport = REGISTRY
            .iter()
            .filter(|e| !e.summary.starts_with("debug view"))
            .count();
        assert!(transport >= 16, "{transport} light-transport integrators");
        assert_eq!(REGISTRY.len() - transport, 3);
    }

    #[test]
    fn names_are_unique_and_every_entry_builds_with_defaults() {
        for (i, e) in REGISTRY.iter().enumerate() {
            assert!(
                REGISTRY[i + 1..].iter().all(|o| o.name != e.name),
                "duplicate {}",
                e.name
            );
            assert!(!e.summary.is_empty());
            e.instantiate(&[]).unwrap();
            for p in e.params {
                assert!(
                    p.default >= p.min && p.default <= p.max,
                    "{}.{}",
                    e.name,
                    p.name
                );
            }
        }
    }

    #[test]
    fn unknown_names_list_the_valid_ones() {
        let err = find("pathh").err().unwrap().to_string();
        assert!(
            err.contains("unknown integrator `pathh`") && err.contains("path"),
            "{err}"
        );
        let path = find("path").unwrap();
        let err = path
            .resolve(&given(&[("maxdepth", "3")]))
            .unwrap_err()
            .to_string();
        assert!(err.contains("max-depth"), "{err}");
    }

    #[test]
    fn values_are_checked_and_later_values_win() {
        let path = find("path").unwrap();
        let p = path
            .resolve(&given(&[("max-depth", "3"), ("max-depth", "5")]))
            .unwrap();
        assert_eq!(p.get_depth("max-depth"), 5);
        let p = path.resolve(&given(&[("max-depth", "unlimited")])).unwrap();
        assert_eq!(p.get_depth("max-depth"), u32::MAX);
        assert!(path.resolve(&given(&[("max-depth", "2.5")])).is_err());
        assert!(path.resolve(&given(&[("max-depth", "-1")])).is_err());
        assert!(path.resolve(&given(&[("max-depth", "NaN")])).is_err());
        assert!(path.resolve(&given(&[("rr-depth", "x")])).is_err());
    }
}
