//! `raylab.load` and `Scene`: a scene kept loaded in the engine's incremental world, rendered
//! by the command line's render job, and edited without reading its file again.

use crate::images::{arrays_of, Arrays};
use anyhow::Context;
use pyo3::exceptions::{PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use raylab::accel::AccelKind;
use raylab::formats::access::SceneFiles;
use raylab::formats::import::write_ron;
use raylab::formats::schema::SceneFile;
use raylab::integrators::sampler::SamplerKind;
use raylab::render::job::{Job, Request, Target};
use raylab::render::{Accumulation, RenderStats};
use raylab::scene::edit::SceneState;
use raylab::scene::load::read_scene_file_with_origins;
use raylab::scene::references::stable_hash;
use raylab::scene::{ImportOptions, SceneInputs};
use serde_json::Value;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// A scene loaded from a file (RON, Mitsuba 3 XML, pbrt-v4), its description and its world.
#[pyclass(module = "raylab._native")]
pub struct Scene {
    /// The world, and the render scene built from it (rebuilt only where edits reach).
    state: SceneState,
    /// The description the world was made from, edits included.
    file: SceneFile,
    /// What the scene reads its files through, and how it was read.
    files: SceneFiles,
    options: ImportOptions,
    /// What the load noted (approximations, the files' notes), which edits keep.
    load_notes: Vec<String>,
    /// The scene's identity as it was read (its files then, `-D`, `--approximate`).
    identity: u64,
}

/// Loads the scene at `path`, as `raylab render` does: Mitsuba `<default>`s set by
/// `defines` (`-D NAME=VALUE`), `approximate` as `--approximate`, `search` as `-a DIR`,
/// `allow` as `--allow-path`.
#[pyfunction]
#[pyo3(signature = (path, defines=Vec::new(), approximate=false, search=Vec::new(), allow=Vec::new()))]
pub fn load(
    py: Python<'_>,
    path: PathBuf,
    defines: Vec<(String, String)>,
    approximate: bool,
    search: Vec<PathBuf>,
    allow: Vec<PathBuf>,
) -> PyResult<Scene> {
    let options = ImportOptions {
        defines,
        approximate,
        search,
    };
    py.detach(|| -> anyhow::Result<Scene> {
        let files = SceneFiles::new(&path, &options.readable(&allow));
        let (file, approximated, origins) = read_scene_file_with_origins(&files, &options)?;
        let mut state =
            SceneState::new(file.clone(), &path, files.clone()).map_err(|e| origins.place(e))?;
        let mut load_notes = approximated;
        load_notes.extend(files.take_notes());
        state.loaded.warnings.extend(load_notes.iter().cloned());
        let mut inputs = SceneInputs::of(&files, &options);
        let identity = inputs
            .identity()
            .with_context(|| format!("{}: cannot read scene file", path.display()))?;
        inputs.known = Some(identity);
        state.loaded.inputs = inputs;
        Ok(Scene {
            state,
            file,
            files,
            options: options.clone(),
            load_notes,
            identity,
        })
    })
    .map_err(crate::error)
}

#[pymethods]
impl Scene {
    /// The scene file's path.
    #[getter]
    fn path(&self) -> PathBuf {
        self.state.loaded.path.clone()
    }

    /// What the load noted: approximations (`approximate=True`), unused meshes, ...
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.state.loaded.warnings.clone()
    }

    /// The camera's image size, `(width, height)`.
    #[getter]
    fn size(&self) -> (u32, u32) {
        (
            self.state.loaded.camera.width,
            self.state.loaded.camera.height,
        )
    }

    /// The scene's own integrator, samples per pixel and seed (`render` in the file).
    #[getter]
    fn defaults<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = &self.state.loaded.render;
        let d = PyDict::new(py);
        d.set_item("integrator", &r.integrator)?;
        d.set_item("spp", r.spp)?;
        d.set_item("seed", r.seed)?;
        Ok(d)
    }

    /// The names of the scene's materials, in file order.
    #[getter]
    fn materials(&self) -> Vec<String> {
        self.file
            .materials
            .0
            .iter()
            .map(|(n, _)| n.clone())
            .collect()
    }

    /// The names of the scene's named entities, in file order.
    #[getter]
    fn entities(&self) -> Vec<String> {
        self.file
            .entities
            .iter()
            .filter_map(|e| e.name.clone())
            .collect()
    }

    /// The scene as it stands now, edits included, as a RON scene file.
    fn to_ron(&self) -> PyResult<String> {
        let header = format!(
            "// {}, as edited from Python\n",
            self.state.loaded.path.display()
        );
        write_ron(&self.file, &header).map_err(PyValueError::new_err)
    }

    /// Renders the scene; see `raylab.Scene.render` for the arguments. Returns the image
    /// and its variance (or None), and the statistics.
    #[pyo3(signature = (integrator=None, spp=None, time=None, seed=None, size=None, threads=None, params=Vec::new(), sampler=None, spectral=None, callback=None))]
    #[allow(clippy::too_many_arguments)]
    fn _render<'py>(
        &mut self,
        py: Python<'py>,
        integrator: Option<String>,
        spp: Option<u32>,
        time: Option<f64>,
        seed: Option<u64>,
        size: Option<(u32, u32)>,
        threads: Option<usize>,
        params: Vec<(String, String)>,
        sampler: Option<String>,
        spectral: Option<bool>,
        callback: Option<Py<PyAny>>,
    ) -> PyResult<(Arrays<'py>, Bound<'py, PyDict>)> {
        if spp == Some(0) {
            return Err(PyValueError::new_err("spp must be at least 1"));
        }
        let time = match time {
            None => None,
            Some(t) if t.is_finite() && t > 0.0 && t <= 1e9 => Some(Duration::from_secs_f64(t)),
            Some(t) => {
                return Err(PyValueError::new_err(format!(
                    "time must be a positive number of seconds, at most 1e9, not {t}"
                )))
            }
        };
        let sampler = sampler
            .map(|name| SamplerKind::parse(&name))
            .transpose()
            .map_err(PyValueError::new_err)?;
        if threads == Some(0) {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        if let Some((w, h)) = size {
            raylab::scene::describe::check_size(w, h)
                .map_err(|e| PyValueError::new_err(format!("size: {e}")))?;
        }
        let request = Request {
            integrator,
            params,
            scene_params: true,
            size,
            target: spp.map_or(Target::Scene, Target::Spp),
            time,
            seed,
            filter: None,
            sampler,
            spectral,
            threads,
            accel: AccelKind::default(),
            progress: false,
            shard: None,
        };
        let state = &mut self.state;
        // A Python exception from the callback or a signal (Ctrl-C) found between passes:
        // the render stops at that pass boundary and raises it.
        let raised: std::sync::Mutex<Option<PyErr>> = std::sync::Mutex::new(None);
        let stopping = AtomicBool::new(false);
        let rendered = py.detach(|| -> anyhow::Result<(Accumulation, RenderStats)> {
            let (built, _) = state.render_scene(request.accel, request.threads)?;
            let mut job = Job::new(&state.loaded, &request)?;
            let mut acc = job.accumulation();
            let target = job.settings.spp;
            let stop = || stopping.load(Ordering::Relaxed);
            let mut after_pass = |_: &Accumulation, stats: &RenderStats| -> anyhow::Result<()> {
                let outcome = Python::attach(|py| -> PyResult<()> {
                    py.check_signals()?;
                    if let Some(f) = &callback {
                        let info = PyDict::new(py);
                        info.set_item("spp", stats.spp_done)?;
                        info.set_item("target", target)?;
                        info.set_item("elapsed", stats.elapsed.as_secs_f64())?;
                        info.set_item("samples", stats.samples)?;
                        f.call1(py, (info,))?;
                    }
                    Ok(())
                });
                if let Err(e) = outcome {
                    *raised.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                    stopping.store(true, Ordering::Relaxed);
                }
                Ok(())
            };
            let stats = job.run(&built, &mut acc, &stop, &mut after_pass)?;
            Ok((acc, stats))
        });
        if let Some(e) = raised.into_inner().unwrap_or_else(|p| p.into_inner()) {
            return Err(e);
        }
        let (acc, stats) = rendered.map_err(crate::error)?;
        if acc.passes() == 0 {
            return Err(crate::error(anyhow::anyhow!(
                "stopped before the first pass finished: no image"
            )));
        }
        let info = PyDict::new(py);
        info.set_item("spp", acc.spp_done)?;
        info.set_item("elapsed", stats.elapsed.as_secs_f64())?;
        info.set_item("samples", stats.samples)?;
        info.set_item("rays", stats.rays.total())?;
        info.set_item("threads", stats.threads)?;
        info.set_item(
            "time_budget_spent",
            stats.stopped == Some(raylab::render::StopReason::TimeBudget),
        )?;
        Ok((arrays_of(py, &acc.film()), info))
    }

    /// Runs the comparison `raylab compare ARGS...` runs (`args` without the command's
    /// name; the scene among them names this one in messages) on this scene as it stands,
    /// edits included; see `raylab.compare`. Returns its report as `metrics.json` holds it.
    fn _compare(&mut self, py: Python<'_>, args: Vec<String>) -> PyResult<String> {
        let opts = raylab::cli::compare_options_from_args(&args).map_err(crate::error)?;
        let loaded = &self.state.loaded;
        let report = py
            .detach(|| raylab::compare::run_loaded(&opts, loaded))
            .map_err(crate::error)?;
        serde_json::to_string(&report).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// Sets fields of material `name` (a JSON object of the RON fields, e.g.
    /// `{"albedo": [0.8, 0.2, 0.2]}`), keeping the others.
    fn _set_material(&mut self, py: Python<'_>, name: &str, fields: &str) -> PyResult<()> {
        let fields = parse_fields(fields)?;
        let mut file = self.file.clone();
        let Some((_, desc)) = file.materials.0.iter_mut().find(|(n, _)| n == name) else {
            return Err(PyKeyError::new_err(format!(
                "no material `{name}`; the scene's materials: {}",
                self.materials().join(", ")
            )));
        };
        *desc = patched(desc, |v| merge_into_variant(v, fields))
            .map_err(|e| PyValueError::new_err(format!("material `{name}`: {e}")))?;
        self.apply(py, file)
    }

    /// Sets fields of entity `name`'s transform (`translate`, `rotate`, `scale`), keeping
    /// the others; or its `matrix`, which replaces them all.
    fn _set_transform(&mut self, py: Python<'_>, name: &str, fields: &str) -> PyResult<()> {
        let fields = parse_fields(fields)?;
        let mut file = self.file.clone();
        let entity = self.entity_mut(&mut file, name)?;
        let bad = |e: String| PyValueError::new_err(format!("entity `{name}`'s transform: {e}"));
        entity.transform = if fields.contains_key("matrix") {
            if let Some(part) = fields.keys().find(|k| *k != "matrix") {
                return Err(bad(format!("give `matrix` alone (it replaces `{part}`)")));
            }
            serde_json::from_value(Value::Object(fields)).map_err(|e| bad(e.to_string()))?
        } else if entity.transform.matrix.is_some() {
            return Err(bad(
                "the entity is placed by a matrix (as imported scenes place theirs): give `matrix`, a row-major 3x4 list".into(),
            ));
        } else {
            patched(&entity.transform, |v| merge(v, fields)).map_err(bad)?
        };
        self.apply(py, file)
    }

    /// Sets fields of entity `name`'s emitter (e.g. `{"radiance": [5, 5, 5]}`), keeping the
    /// others.
    fn _set_emitter(&mut self, py: Python<'_>, name: &str, fields: &str) -> PyResult<()> {
        let fields = parse_fields(fields)?;
        let mut file = self.file.clone();
        let entity = self.entity_mut(&mut file, name)?;
        let Some(emitter) = &mut entity.emitter else {
            return Err(PyValueError::new_err(format!(
                "entity `{name}` has no emitter"
            )));
        };
        *emitter = patched(emitter, |v| merge_into_variant(v, fields))
            .map_err(|e| PyValueError::new_err(format!("entity `{name}`'s emitter: {e}")))?;
        self.apply(py, file)
    }
}

impl Scene {
    /// The entity named `name` of `file`.
    fn entity_mut<'f>(
        &self,
        file: &'f mut SceneFile,
        name: &str,
    ) -> PyResult<&'f mut raylab::formats::schema::EntityDesc> {
        let names = self.entities();
        file.entities
            .iter_mut()
            .find(|e| e.name.as_deref() == Some(name))
            .ok_or_else(|| {
                PyKeyError::new_err(format!(
                    "no entity `{name}`; the scene's named entities: {}",
                    names.join(", ")
                ))
            })
    }

    /// Makes the world what `file` describes through the incremental path `--watch` takes
    /// (only what changed is rebuilt, at the next render); on an error nothing changes.
    fn apply(&mut self, py: Python<'_>, file: SceneFile) -> PyResult<()> {
        let state = &mut self.state;
        let next = file.clone();
        py.detach(|| state.apply(next)).map_err(crate::error)?;
        // The scene as it stands: what it has read (an edit may read a new texture), the
        // load's notes beside the edit's, and an identity the edit moved.
        let text = write_ron(&file, "").map_err(PyValueError::new_err)?;
        let loaded = &mut self.state.loaded;
        loaded.warnings.extend(self.load_notes.iter().cloned());
        loaded.inputs = SceneInputs {
            known: Some(stable_hash(&[
                &self.identity.to_le_bytes(),
                b"edited",
                text.as_bytes(),
            ])),
            ..SceneInputs::of(&self.files, &self.options)
        };
        self.file = file;
        Ok(())
    }
}

/// A JSON object of fields.
fn parse_fields(text: &str) -> PyResult<serde_json::Map<String, Value>> {
    match serde_json::from_str(text) {
        Ok(Value::Object(map)) => Ok(map),
        Ok(other) => Err(PyValueError::new_err(format!(
            "expected fields by name, not {other}"
        ))),
        Err(e) => Err(PyValueError::new_err(e.to_string())),
    }
}

/// `value` passed through its JSON form and `edit`.
fn patched<T: serde::Serialize + serde::de::DeserializeOwned>(
    value: &T,
    edit: impl FnOnce(&mut Value) -> Result<(), String>,
) -> Result<T, String> {
    let mut v = serde_json::to_value(value).map_err(|e| e.to_string())?;
    edit(&mut v)?;
    serde_json::from_value(v).map_err(|e| e.to_string())
}

/// `fields` set on an object.
fn merge(value: &mut Value, fields: serde_json::Map<String, Value>) -> Result<(), String> {
    let Value::Object(map) = value else {
        return Err(format!("{value} has no fields"));
    };
    map.extend(fields);
    Ok(())
}

/// `fields` set on an enum's variant (`{"Variant": {...}}`, or a unit variant's name).
fn merge_into_variant(
    value: &mut Value,
    fields: serde_json::Map<String, Value>,
) -> Result<(), String> {
    match value {
        Value::Object(outer) if outer.len() == 1 => {
            let inner = outer.values_mut().next().expect("one entry");
            merge(inner, fields)
        }
        // A unit variant (`Null`) takes no fields; setting none is a no-op.
        Value::String(_) if fields.is_empty() => Ok(()),
        Value::String(variant) => Err(format!("a `{variant}` has no fields to set")),
        other => Err(format!("{other} has no fields")),
    }
}
