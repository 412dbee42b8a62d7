//! `Controller` for an enum of controllers: every method forwards to the variant's own.
//! The runner is then one monomorphised loop whatever the controller family.

/// `controller_enum!(Enum, NX, NU, Reference; Variant, ...)` implements
/// `twip_core::control::Controller<f64, NX, NU>` for `Enum` by delegation.
macro_rules! controller_enum {
    ($enum:ident, $nx:literal, $nu:literal, $reference:ty; $($variant:ident),+ $(,)?) => {
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
