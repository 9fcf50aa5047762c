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
//! by hand). It uses transparent huge pages where the system offers them
//! (mimalloc advises them for its arenas): a first touch of a 4 KiB page
//! costs about 3 us of system time on the virtual machine the benchmarks
//! run on, and 1M blue-noise points on the dragon touch 200,000 pages
//! (0.6 s of system time; 0.3 s with huge pages, and 2.98 s against
//! 3.38 s whole process, 5 runs each interleaved by hand). On an earlier
//! machine huge pages had made the system time swing from 0.6 to 1.5 s
//! from one run to the next; `MIMALLOC_ALLOW_THP=0` in the environment
//! turns them off.

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
