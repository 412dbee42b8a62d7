//! The width of a sweep block and its data layout: one array per quantity (structure of
//! arrays), loops over lanes that the compiler vectorises. Each lane computes with
//! `model::lane::Fused`.

/// Samples advanced together: 16 f64 = two AVX-512 registers, four AVX2 ones.
pub const LANES: usize = 16;

/// One value per lane.
pub type Lanes = [f64; LANES];
