//! Caller-owned storage for a Rust value behind the C ABI: `N` 8-byte words the C compiler
//! sizes and aligns, holding a tag word and the value. The tag tells an initialised state
//! from garbage (and one kind of state from another).
use core::mem::{align_of, size_of};

use crate::{TwipStatus, TWIP_ERR_NOT_INITIALISED, TWIP_ERR_NULL};

#[repr(C)]
struct Slot<V> {
    tag: u64,
    value: V,
}

/// Whether a `V` fits in `words` 8-byte words with its tag (checked at compile time by
/// the `const` assertions of each state type).
pub(crate) const fn fits<V>(words: usize) -> bool {
    size_of::<Slot<V>>() <= 8 * words && align_of::<Slot<V>>() <= 8
}

/// Writes `value` with `tag` into the words at `words`.
///
/// # Safety
/// `words` is NULL or points to writable storage of a size `fits::<V>` accepts.
pub(crate) unsafe fn put<V>(words: *mut u64, tag: u64, value: V) -> TwipStatus {
    if words.is_null() {
        return TWIP_ERR_NULL;
    }
    words.cast::<Slot<V>>().write(Slot { tag, value });
    crate::TWIP_OK
}

/// Marks the words at `words` as not initialised (after a failed init).
///
/// # Safety
/// As [`put`].
pub(crate) unsafe fn clear(words: *mut u64) {
    if !words.is_null() {
        words.write(0);
    }
}

/// The value in the words at `words`, if they hold one with `tag`.
///
/// # Safety
/// `words` is NULL or points to storage of a size `fits::<V>` accepts, which holds a
/// `Slot<V>` whenever its first word equals `tag`.
pub(crate) unsafe fn get<'a, V>(words: *mut u64, tag: u64) -> Result<&'a mut V, TwipStatus> {
    if words.is_null() {
        return Err(TWIP_ERR_NULL);
    }
    if words.read() != tag {
        return Err(TWIP_ERR_NOT_INITIALISED);
    }
    Ok(&mut (*words.cast::<Slot<V>>()).value)
}
