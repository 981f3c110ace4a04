//! Software prefetching for the trainers' memory-bound loops (hash-table lookups, splat
//! records read in depth order): a hint asking the cache for an element's lines some
//! iterations before the element is read, so that many misses are in flight at once instead
//! of each stalling the work behind it. A hint only: results never depend on it.

/// Asks the cache for `items[index]` (both ends of an element larger than 8 bytes, in case it
/// straddles two lines); does nothing past the end of the slice or on targets without a
/// prefetch instruction here.
#[inline(always)]
pub fn prefetch<T>(items: &[T], index: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(item) = items.get(index) {
        let first = (item as *const T).cast::<i8>();
        let last = first.wrapping_add(std::mem::size_of::<T>().saturating_sub(1));
        #[allow(unsafe_code)]
        // SAFETY: `_mm_prefetch` needs SSE, which every x86-64 CPU has (it is in the target's
        // baseline); a prefetch reads nothing the program sees and cannot fault, and both
        // addresses lie inside `items[index]` anyway.
        unsafe {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            _mm_prefetch::<_MM_HINT_T0>(first);
            if std::mem::size_of::<T>() > 8 {
                _mm_prefetch::<_MM_HINT_T0>(last);
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (items, index);
}
