//! A controller written in Python, run by the same core runner as the built-in ones.
//!
//! `UserController` implements the core's `Controller` trait by calling back into Python
//! with the GIL held: `update(t, y, ref) -> u` once per period, `reset()` before the run,
//! `internals() -> dict` after every update when the object has it. The first exception
//! (or a bad `u`) is kept, every later update is skipped, and the runner is told to stop
//! through [`UserController::failed`]; the binding then raises that exception with its
//! traceback. Such runs keep the GIL (no `py.detach`): a Python callback needs it anyway.
use std::cell::Cell;
use std::collections::HashMap;
use std::marker::PhantomData;
use std::rc::Rc;
use std::sync::{Mutex, OnceLock};

use nalgebra::SVector;
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat};
use twip_core::control::Controller;
use twip_core::sim::log::LogRow;

use crate::convert::{reals, Real};
use crate::errors::InvalidParameterError;

/// A Python controller: an object with `update(t, y, ref)` and `period` (optionally
/// `reset()` and `internals()`), or a plain callable `f(t, y, ref)`.
pub struct UserController<R, const NX: usize, const NU: usize> {
    update: Py<PyAny>,
    reset: Option<Py<PyAny>>,
    internals_fn: Option<Py<PyAny>>,
    period: f64,
    names: &'static [&'static str],
    values: Vec<f64>,
    reference_row: Vec<f64>,
    /// The first exception raised by the controller (or about its `u`).
    pub error: Option<PyErr>,
    /// Set with `error`; the runner's `should_stop` reads it.
    pub failed: Rc<Cell<bool>>,
    _reference: PhantomData<R>,
}

/// Is `obj` a controller written in Python (not a twip controller class)?
pub fn is_user_controller(obj: &Bound<'_, PyAny>) -> bool {
    obj.hasattr("update").unwrap_or(false) || obj.is_callable()
}

impl<R: LogRow<f64>, const NX: usize, const NU: usize> UserController<R, NX, NU> {
    /// Wraps `obj`. The period is `control_period` if given, else the object's `period`
    /// attribute, else (a plain callable) `dt`. Calls `reset()` and reads the internals'
    /// names once, so that the log's columns are known before the run.
    pub fn new(obj: &Bound<'_, PyAny>, control_period: Option<f64>, dt: f64, model: &str) -> PyResult<Self> {
        let py = obj.py();
        let has_update = obj.hasattr("update")?;
        let update = if has_update { obj.getattr("update")? } else { obj.clone() };
        if !update.is_callable() {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "controller.update must be callable as update(t, y, ref) -> u for a {model}"
            )));
        }
        let optional = |name: &str| -> PyResult<Option<Py<PyAny>>> {
            if !has_update || !obj.hasattr(name)? {
                return Ok(None);
            }
            let f = obj.getattr(name)?;
            Ok(f.is_callable().then(|| f.unbind()))
        };
        let period = match control_period {
            Some(p) => p,
            None if has_update => {
                let p = obj.getattr("period").map_err(|_| {
                    pyo3::exceptions::PyTypeError::new_err(
                        "controller has update() but no `period` attribute [s]; give it one or pass control_period=",
                    )
                })?;
                p.extract::<Real>().map_err(|_| {
                    InvalidParameterError::new_err(format!("controller.period = {p}: must be a number of seconds"))
                })?.0
            }
            None => dt,
        };
        if !(period.is_finite() && period > 0.0) {
            return Err(InvalidParameterError::new_err(format!(
                "controller period = {period}: must be a positive, finite number of seconds"
            )));
        }
        let mut out = Self {
            update: update.unbind(),
            reset: optional("reset")?,
            internals_fn: optional("internals")?,
            period,
            names: &[],
            values: Vec::new(),
            reference_row: Vec::with_capacity(R::NAMES.len()),
            error: None,
            failed: Rc::new(Cell::new(false)),
            _reference: PhantomData,
        };
        if let Some(reset) = &out.reset {
            reset.call0(py)?;
        }
        if let Some(f) = &out.internals_fn {
            let dict = internals_dict(py, f)?;
            let names: Vec<String> = dict.keys().iter().map(|k| k.extract::<String>()).collect::<PyResult<_>>()?;
            out.names = intern(names);
            out.values = vec![f64::NAN; out.names.len()];
        }
        Ok(out)
    }

    /// The exception to raise after the run, if the controller failed.
    pub fn take_error(&mut self) -> Option<PyErr> {
        self.error.take()
    }

    fn fail(&mut self, e: PyErr) {
        if self.error.is_none() {
            self.error = Some(e);
            self.failed.set(true);
        }
    }

    fn call(&mut self, py: Python<'_>, t: f64, y: &SVector<f64, NX>, reference: &R) -> PyResult<SVector<f64, NU>> {
        self.reference_row.clear();
        reference.push_row(&mut self.reference_row);
        let y = PyArray1::from_slice(py, y.as_slice());
        let r = PyArray1::from_slice(py, &self.reference_row);
        let u = self.update.call1(py, (t, y, r))?;
        let u = input::<NU>(u.bind(py), t)?;
        if let Some(f) = &self.internals_fn {
            let dict = internals_dict(py, f)?;
            if dict.len() != self.names.len() {
                return Err(changed_internals(t, self.names, &dict));
            }
            for (i, name) in self.names.iter().enumerate() {
                let v = dict.get_item(name)?.ok_or_else(|| changed_internals(t, self.names, &dict))?;
                self.values[i] = v.extract::<Real>().map_err(|_| {
                    InvalidParameterError::new_err(format!("controller.internals()['{name}'] = {v} at t = {t} s: not a number"))
                })?.0;
            }
        }
        Ok(u)
    }
}

impl<R: LogRow<f64> + Copy, const NX: usize, const NU: usize> Controller<f64, NX, NU> for UserController<R, NX, NU> {
    type Reference = R;

    fn period(&self) -> f64 {
        self.period
    }

    fn reset(&mut self) {
        if let Some(reset) = &self.reset {
            if let Err(e) = Python::attach(|py| reset.call0(py).map(drop)) {
                self.fail(e);
            }
        }
    }

    fn update(&mut self, t: f64, y: &SVector<f64, NX>, reference: &R) -> SVector<f64, NU> {
        if self.error.is_some() {
            return SVector::zeros();
        }
        match Python::attach(|py| self.call(py, t, y, reference)) {
            Ok(u) => u,
            Err(e) => {
                self.fail(e);
                SVector::zeros()
            }
        }
    }

    fn internals(&self) -> &[f64] {
        &self.values
    }

    fn internal_names(&self) -> &'static [&'static str] {
        self.names
    }
}

/// `f()` as a dict of names to numbers.
fn internals_dict<'py>(py: Python<'py>, f: &Py<PyAny>) -> PyResult<Bound<'py, PyDict>> {
    let out = f.call0(py)?;
    out.bind(py).cast::<PyDict>().cloned().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "controller.internals() must return a dict of name -> float, got {}",
            out.bind(py).get_type().name().map(|n| n.to_string()).unwrap_or_default()
        ))
    })
}

fn changed_internals(t: f64, names: &[&str], dict: &Bound<'_, PyDict>) -> PyErr {
    let now: Vec<String> = dict.keys().iter().map(|k| k.to_string()).collect();
    InvalidParameterError::new_err(format!(
        "controller.internals() at t = {t} s has keys [{}], but it had [{}] before the run: the keys must stay the same",
        now.join(", "),
        names.join(", ")
    ))
}

/// The controller's `u` as NU finite numbers: a float (NU = 1) or any array or sequence
/// holding exactly NU numbers.
fn input<const NU: usize>(u: &Bound<'_, PyAny>, t: f64) -> PyResult<SVector<f64, NU>> {
    let mut out = SVector::<f64, NU>::zeros();
    if NU == 1 && u.is_instance_of::<PyFloat>() {
        out[0] = u.extract::<f64>()?;
    } else if let Ok(a) = u.cast::<numpy::PyArrayDyn<f64>>() {
        let a = a.readonly();
        if a.len() != NU {
            return Err(bad_shape::<NU>(t, &format!("u = {u} (an array of shape {:?})", a.shape())));
        }
        for (o, v) in out.iter_mut().zip(a.as_array().iter()) {
            *o = *v;
        }
    } else if let Ok(Real(v)) = u.extract::<Real>() {
        if NU != 1 {
            return Err(bad_shape::<NU>(t, &format!("u = {v} (one number)")));
        }
        out[0] = v;
    } else if let Ok(v) = u.extract::<Vec<Real>>().map(reals) {
        if v.len() != NU {
            return Err(bad_shape::<NU>(t, &format!("u = {v:?} ({} numbers)", v.len())));
        }
        out.copy_from_slice(&v);
    } else {
        let kind = u.get_type().name().map(|n| n.to_string()).unwrap_or_default();
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "controller returned u = {u} ({kind}) at t = {t} s: expected {}",
            expected::<NU>()
        )));
    }
    if out.iter().any(|v| !v.is_finite()) {
        return Err(crate::errors::NonFiniteError::new_err(format!(
            "controller returned u = {:?} at t = {t} s: every input must be finite",
            out.as_slice()
        )));
    }
    Ok(out)
}

fn expected<const NU: usize>() -> &'static str {
    if NU == 1 {
        "a float or one value (the lumped motor current [A] of a SlopeModel)"
    } else {
        "two values [u_r, u_l] (wheel torques [N m] of a PlanarModel)"
    }
}

fn bad_shape<const NU: usize>(t: f64, got: &str) -> PyErr {
    crate::errors::ShapeError::new_err(format!("controller returned {got} at t = {t} s: expected {}", expected::<NU>()))
}

/// Internal names live as long as the process (the trait asks for `'static`): each
/// distinct list is leaked once and shared by every later run that uses it.
fn intern(names: Vec<String>) -> &'static [&'static str] {
    static TABLE: OnceLock<Mutex<HashMap<Vec<String>, &'static [&'static str]>>> = OnceLock::new();
    let mut table = TABLE.get_or_init(Default::default).lock().unwrap_or_else(|e| e.into_inner());
    if let Some(found) = table.get(&names) {
        return found;
    }
    let leaked: Vec<&'static str> = names.iter().map(|s| &*Box::leak(s.clone().into_boxed_str())).collect();
    let leaked: &'static [&'static str] = Box::leak(leaked.into_boxed_slice());
    table.insert(names, leaked);
    leaked
}
