//! The width of a sweep block and its data layout: one array per quantity (structure of
//! arrays), loops over lanes that the compiler vectorises. Each lane computes with
//! `model::lane::Fused`.

/// Samples advanced together: 16 f64 = two AVX-512 registers, four AVX2 ones. Chosen by
/// measurement for every copy (docs/performance.md, "Lanes per CPU"): 4 lanes halved the AVX2
/// copy, 8 cost the AVX-512 copy's LQR kernel 45 %, and 8 on AVX2 or 32 on either copy moved
/// no workload beyond the machine's noise (8 on a real AVX2 CPU too: within 2-3 % in
/// instructions and in paired CPU time).
pub const LANES: usize = 16;

/// One value per lane.
pub type Lanes = [f64; LANES];

/// All ones where `b` holds, else zero: a lane's flag as a 64-bit mask, with which a loop over
/// the lanes selects an f64's bits without a branch (the compiler's vector masks), where `bool`
/// arrays were tested and selected with gathers and scalar moves.
#[inline(always)]
pub(crate) fn mask(b: bool) -> u64 {
    (b as u64).wrapping_neg()
}
