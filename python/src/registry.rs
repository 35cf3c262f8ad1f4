//! `raylab.integrators()`: the registry, as `raylab integrators` lists it.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use raylab::integrators::registry::{MediaSupport, ParamKind, REGISTRY};

/// Every integrator: a dict of its `name`, `summary`, `media` (`"none"`, `"scattering"`,
/// `"all"`) and `params`, each a dict of `name`, `kind` (`int`, `float`, `depth`),
/// `default` (a number; `float("inf")` for an unlimited depth), `min`, `max` and `doc`.
#[pyfunction]
pub fn integrators(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let out = PyList::empty(py);
    for e in REGISTRY {
        let entry = PyDict::new(py);
        entry.set_item("name", e.name)?;
        entry.set_item("summary", e.summary)?;
        let media = match e.media {
            MediaSupport::None => "none",
            MediaSupport::Scattering => "scattering",
            MediaSupport::Full => "all",
        };
        entry.set_item("media", media)?;
        let params = PyList::empty(py);
        for p in e.params {
            let param = PyDict::new(py);
            param.set_item("name", p.name)?;
            let kind = p.kind.name();
            param.set_item("kind", kind)?;
            // Whole numbers as ints, so that they print as the command line prints them.
            let number = |v: f64| -> PyResult<Py<PyAny>> {
                Ok(
                    if p.kind != ParamKind::Float && v.is_finite() && v.fract() == 0.0 {
                        (v as i64).into_pyobject(py)?.into_any().unbind()
                    } else {
                        v.into_pyobject(py)?.into_any().unbind()
                    },
                )
            };
            if let ParamKind::Choice(names) = p.kind {
                // A choice by its names: its default and what it takes.
                param.set_item("default", p.default_text())?;
                param.set_item("choices", names.to_vec())?;
            } else {
                param.set_item("default", number(p.default)?)?;
                param.set_item("min", number(p.min)?)?;
                param.set_item("max", number(p.max)?)?;
            }
            param.set_item("doc", p.doc)?;
            params.append(param)?;
        }
        entry.set_item("params", params)?;
        out.append(entry)?;
    }
    Ok(out)
}
