//! One declaration per settings class: `settings_class!` turns a list of fields into the
//! getters, `to_dict`, `from_dict`, `replace`, and `__repr__`, so a field is written once.
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pyo3::IntoPyObjectExt;

/// `k=v, ...` of a dict, in its order, with each value's repr.
pub fn kwargs_repr(d: &Bound<'_, PyDict>) -> PyResult<String> {
    let mut parts = Vec::new();
    for (k, v) in d.iter() {
        parts.push(format!("{}={}", k.str()?, v.repr()?));
    }
    Ok(parts.join(", "))
}

/// `cls(**current)` with the fields in `changes` overridden: the constructor validates
/// (a field of the wrong type is named, after `what`).
pub fn replaced<'py, T: pyo3::PyClass>(
    what: &str,
    slf: &Bound<'py, T>,
    current: Bound<'py, PyDict>,
    changes: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    if let Some(c) = changes {
        current.update(c.as_mapping())?;
    }
    slf.as_any().get_type().call((), Some(&current)).map_err(|e| crate::errors::naming_argument(slf.py(), what, e))
}

/// What `__reduce__` returns: the callable that rebuilds the object, and its arguments.
pub type Reduced<'py, Args> = (Bound<'py, PyAny>, Args);

/// `(type(x).from_dict, (settings,))`: how a settings class pickles, so that unpickling
/// goes through the constructor's validation like any other `from_dict`.
pub fn reduced<'py, T: pyo3::PyClass>(
    slf: &Bound<'py, T>,
    settings: Bound<'py, PyDict>,
) -> PyResult<Reduced<'py, (Bound<'py, PyDict>,)>> {
    Ok((slf.as_any().get_type().getattr("from_dict")?, (settings,)))
}

/// Named numbers, given to Python as a dict in their order (gain tables and the like).
pub struct NamedFloats(pub &'static [&'static str], pub Vec<f64>);

impl<'py> IntoPyObject<'py> for NamedFloats {
    type Target = PyDict;
    type Output = Bound<'py, PyDict>;
    type Error = PyErr;

    fn into_pyobject(self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in self.0.iter().zip(self.1) {
            d.set_item(k, v)?;
        }
        Ok(d)
    }
}

/// Converts a getter's value for Python (the macro's getters return `Bound<PyAny>`).
pub fn to_py<'py, V: IntoPyObject<'py>>(py: Python<'py>, v: V) -> PyResult<Bound<'py, PyAny>> {
    v.into_bound_py_any(py)
}

/// Declares a frozen pyclass's fields once.
///
/// `settings { name: Type = |s| expr; ... }` are the constructor's keyword arguments: each
/// gets a getter and goes into `to_dict()`, so `from_dict(x.to_dict())`, `replace(**changes)`
/// (which calls the constructor, so every change is validated), `__repr__` and pickling
/// (`__reduce__`: `from_dict(to_dict())`) follow. A getter must give back exactly what the
/// constructor was given (floats bit for bit), so that the copy behaves as the original.
/// `derived { ... }` are read-only getters computed from them (not in `to_dict`).
/// Needs pyo3's `multiple-pymethods`: the class keeps its own `#[pymethods]` block.
macro_rules! settings_class {
    (
        $ty:ty, $name:literal,
        settings { $( $(#[doc = $doc:literal])* $field:ident : $fty:ty = $get:expr; )* }
        $( derived { $( $(#[doc = $ddoc:literal])* $dfield:ident : $dty:ty = $dget:expr; )* } )?
    ) => {
        #[pyo3::pymethods]
        impl $ty {
            $(
                $(#[doc = $doc])*
                #[getter]
                fn $field<'py>(&self, py: pyo3::Python<'py>) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                    let get: fn(&Self) -> $fty = $get;
                    $crate::settings::to_py(py, get(self))
                }
            )*
            $($(
                $(#[doc = $ddoc])*
                #[getter]
                fn $dfield<'py>(&self, py: pyo3::Python<'py>) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                    let get: fn(&Self) -> $dty = $dget;
                    $crate::settings::to_py(py, get(self))
                }
            )*)?

            /// The settings as the constructor's keyword arguments:
            /// `type(x).from_dict(x.to_dict()) == x`.
            // A Python method takes `&self`, whether or not the Rust type is `Copy`.
            #[allow(clippy::wrong_self_convention)]
            fn to_dict<'py>(&self, py: pyo3::Python<'py>) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::types::PyDict>> {
                let d = pyo3::types::PyDict::new(py);
                $( d.set_item(stringify!($field), self.$field(py)?)?; )*
                Ok(d)
            }

            /// The settings `to_dict()` gave (missing keys take the constructor's defaults).
            #[classmethod]
            fn from_dict<'py>(
                cls: &pyo3::Bound<'py, pyo3::types::PyType>,
                settings: &pyo3::Bound<'py, pyo3::types::PyDict>,
            ) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                use pyo3::types::PyAnyMethods;
                cls.as_any()
                    .call((), Some(settings))
                    .map_err(|e| $crate::errors::naming_argument(cls.py(), concat!($name, ".from_dict"), e))
            }

            /// A copy with some settings changed (validated as the constructor does).
            #[pyo3(signature = (**changes))]
            fn replace<'py>(
                slf: &pyo3::Bound<'py, Self>,
                changes: Option<&pyo3::Bound<'py, pyo3::types::PyDict>>,
            ) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                $crate::settings::replaced(concat!($name, ".replace"), slf, slf.get().to_dict(slf.py())?, changes)
            }

            /// Pickled (and copied) as `from_dict(to_dict())`.
            fn __reduce__<'py>(
                slf: &pyo3::Bound<'py, Self>,
            ) -> pyo3::PyResult<$crate::settings::Reduced<'py, (pyo3::Bound<'py, pyo3::types::PyDict>,)>> {
                $crate::settings::reduced(slf, slf.get().to_dict(slf.py())?)
            }

            fn __repr__(&self, py: pyo3::Python<'_>) -> pyo3::PyResult<String> {
                Ok(format!("{}({})", $name, $crate::settings::kwargs_repr(&self.to_dict(py)?)?))
            }

        }
    };
}
pub(crate) use settings_class;
