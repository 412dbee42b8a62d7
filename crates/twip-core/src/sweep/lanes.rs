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

/// `observe(live)`, but with `live` the constant "every lane" when every lane is live (a
/// block whose robots all still run, the common case): in that copy of `observe` the
/// compiler drops the selects that keep an ended lane's tallies and the masks made from
/// `bool`s for them (a tally's own per-lane choices, as a settling time's, stay). The same
/// bits; on the AVX2 EPYC (`avx2`, 6 pairs against the build before):
/// LQR lanes 1.077x, fuzzy 1.054x, Gaussian sets 1.062x, circle-smc 1.036x; the thesis-like
/// rig 0.984x and the 3-DOF one 0.985x, within their pairs' spread (docs/performance.md).
#[inline(always)]
pub(crate) fn where_live(live: &[bool; LANES], mut observe: impl FnMut(&[bool; LANES])) {
    if live.iter().all(|&l| l) {
        observe(&[true; LANES]);
    } else {
        observe(live);
    }
}

/// `fast`'s step where every `live` lane says it holds (`fast` writes the step's own check per
/// lane into `holds`, a [`mask`]), else `slow`'s: a fast step that a loop over lanes cannot
/// branch on per lane, checked after it. On masks, not `bool`s: with `bool` flags, the check's
/// lines held 10.6 % of the `avx512` LQR kernel's samples (bytes packed into mask bits one lane
/// at a time); on masks the `avx512` LQR lanes ran 1.081x, the fuzzy lanes 1.045x, circle-pid
/// 1.00x (an AVX-512 EPYC, `sweep_throughput`, 6 alternated pairs). Both write the step into
/// `step`, the loop's own array: handed on in a tuple with its checks, then an `Option`, then
/// returned, it was copied up to three times a step, by `memcpy` calls in the `avx2` copy (5-6 %
/// of its LQR lanes' profile). `fast` and `slow` are `#[inline(always)]` closures (or `slow`
/// calls a copy's own function): left to the compiler, the 3-DOF step's `fast` was built out
/// of line without the kernel copy's instructions (a call per multiply-add; circle-pid's lanes
/// at 0.06x), and so was the planar kernels' and the envs' `slow` (`nm`: their closures had
/// symbols of their own).
#[inline(always)]
pub(crate) fn fast_where_every_live<T>(live: &[bool; LANES], step: &mut T, fast: impl FnOnce(&mut T, &mut [u64; LANES]), slow: impl FnOnce(&mut T)) {
    let mut holds = [u64::MAX; LANES];
    fast(step, &mut holds);
    let mut all = u64::MAX;
    for l in 0..LANES {
        all &= holds[l] | !mask(live[l]);
    }
    if all != u64::MAX {
        slow(step);
    }
}
