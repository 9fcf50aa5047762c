//! The global allocator (with the default feature `mimalloc`).
//!
//! The stages are batch processes that allocate and free vectors of tens
//! or hundreds of megabytes, one after another (a million blue-noise
//! points go through three million candidates, their grid, their pairs,
//! then the relaxation's lists). glibc maps every allocation over 32 MiB
//! afresh and unmaps it when freed, so the kernel faults in and zeroes
//! each one's pages again: `scatter --blue` of 1M points on the bunny
//! spent 0.9 s in the kernel against 3.4 s of its own (0.5-0.6 s with
//! mimalloc). mimalloc reuses memory it has
//! mapped, and [`keep_freed_memory`] tells it never to give memory back
//! before the process ends: 1M points took 2.34 s on the bunny and 3.01 s
//! on the dragon, against 2.58 and 3.25 s with glibc (medians of 6 runs
//! by hand). It is built without transparent huge pages: with them the
//! medians were lower (2.17 and 2.92 s), but the system time of a run
//! on the dragon went from 0.6 to 1.5 s and back from one run to the
//! next, where without them it stayed at 0.5-0.7 s.

#[cfg(feature = "mimalloc")]
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// mimalloc 3's `mi_option_purge_delay` (`mimalloc.h`, `mi_option_e`:
/// libmimalloc-sys names only the options of earlier versions).
#[cfg(feature = "mimalloc")]
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// Tells the allocator to keep what is freed for later allocations
/// until the process ends, instead of giving it back to the system after
/// a delay (every binary calls this first, through `cli::main_of`; a
/// batch stage's peak is what it holds anyway: 826 MB against glibc's
/// 753 MB for 1M blue-noise points).
pub fn keep_freed_memory() {
    #[cfg(feature = "mimalloc")]
    // SAFETY: setting an option is a plain store into mimalloc's option
    // table; -1 is the documented "no purging at all".
    unsafe {
        libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1);
    }
}

#[cfg(all(test, feature = "mimalloc"))]
mod tests {
    use super::*;

    #[test]
    fn the_purge_delay_option_is_the_one_set() {
        // SAFETY: reading an option.
        let before = unsafe { libmimalloc_sys::mi_option_get(MI_OPTION_PURGE_DELAY) };
        // mimalloc 3's default delay, 1,000 ms (or -1 if set already).
        assert!(before == 1000 || before == -1, "{before}");
        keep_freed_memory();
        // SAFETY: reading options.
        let (purge, numa) = unsafe {
            (
                libmimalloc_sys::mi_option_get(MI_OPTION_PURGE_DELAY),
                libmimalloc_sys::mi_option_get(libmimalloc_sys::mi_option_use_numa_nodes),
            )
        };
        assert_eq!(purge, -1);
        // The option after it keeps its default: the index is not off by one.
        assert_eq!(numa, 0);
    }
}
