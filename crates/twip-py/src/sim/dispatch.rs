//! An enum of controllers: `Controller` by delegation to the variant, and the Python-side
//! `extract` and `with_period` every variant has. The runner is then one monomorphised
//! loop whatever the controller family.

/// `controller_enum!(Enum, NX, NU, Reference, "family"; Variant(PyClass), ...)`.
macro_rules! controller_enum {
    ($enum:ident, $nx:literal, $nu:literal, $reference:ty, $family:literal;
     $($variant:ident($py:ty)),+ $(,)?) => {
        impl $enum {
            /// The core controller inside a Python controller object of this family.
            pub(crate) fn extract(obj: &pyo3::Bound<'_, pyo3::PyAny>) -> pyo3::PyResult<Self> {
                use pyo3::types::{PyAnyMethods, PyTypeMethods};
                $(
                    if let Ok(c) = obj.cast::<$py>() {
                        return Ok(Self::$variant(c.get().inner));
                    }
                )+
                let accepted = [$(<$py as pyo3::PyClass>::NAME),+].join(", ");
                Err(pyo3::exceptions::PyTypeError::new_err(format!(
                    "controller must be a {} twip controller ({accepted}), an object with update(t, y, ref) -> u and period [s], or a callable f(t, y, ref) -> u; got {}",
                    $family,
                    obj.get_type().name().map(|n| n.to_string()).unwrap_or_default()
                )))
            }

            /// The same controller, run every `period` seconds.
            pub(crate) fn with_period(self, period: f64) -> crate::errors::CoreResult<Self> {
                Ok(match self { $(Self::$variant(c) => Self::$variant(c.with_period(period)?),)+ })
            }
        }

        impl twip_core::control::Controller<f64, $nx, $nu> for $enum {
            type Reference = $reference;

            fn period(&self) -> f64 {
                match self { $(Self::$variant(c) => c.period(),)+ }
            }

            fn reset(&mut self) {
                match self { $(Self::$variant(c) => c.reset(),)+ }
            }

            #[inline]
            fn update(
                &mut self,
                t: f64,
                y: &nalgebra::SVector<f64, $nx>,
                r: &$reference,
            ) -> nalgebra::SVector<f64, $nu> {
                match self { $(Self::$variant(c) => c.update(t, y, r),)+ }
            }

            fn internals(&self) -> &[f64] {
                match self { $(Self::$variant(c) => c.internals(),)+ }
            }

            fn internal_names(&self) -> &'static [&'static str] {
                match self { $(Self::$variant(c) => c.internal_names(),)+ }
            }
        }
    };
}

pub(crate) use controller_enum;
