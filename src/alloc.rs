//! The allocator the binaries use (mimalloc, with the default feature
//! `mimalloc`). A library leaves the global allocator to the program that
//! links it: each binary sets it with [`global_allocator!`](crate::global_allocator).
//!
//! The stages are batch processes that allocate and free vectors of tens
//! or hundreds of megabytes, one after another (blue-noise candidates,
//! their grid, their pairs, then the relaxation's lists). glibc maps every
//! allocation over 32 MiB afresh and unmaps it when freed, so the kernel
//! faults in and zeroes each one's pages again; mimalloc reuses memory it
//! has mapped, and [`keep_freed_memory`] tells it never to give memory
//! back before the process ends. It uses transparent huge pages where the
//! system offers them, which makes first touching memory cheaper
//! (`MIMALLOC_ALLOW_THP=0` in the environment turns them off). The
//! measurements are in `benches/results/HISTORY.md`, "The allocator".

#[cfg(feature = "mimalloc")]
pub use mimalloc::MiMalloc;

/// Sets the binary's global allocator to mimalloc (nothing without the
/// feature `mimalloc`): one line at the top of every binary.
#[macro_export]
macro_rules! global_allocator {
    () => {
        #[cfg(feature = "mimalloc")]
        #[global_allocator]
        static GLOBAL: $crate::alloc::MiMalloc = $crate::alloc::MiMalloc;
    };
}

/// mimalloc 3's `mi_option_purge_delay` (`mimalloc.h`, `mi_option_e`:
/// libmimalloc-sys names only the options of earlier versions).
#[cfg(feature = "mimalloc")]
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// Tells the allocator to keep what is freed for later allocations
/// until the process ends, instead of giving it back to the system after
/// a delay (every binary calls this first, through `cli::main_of`): a
/// batch stage's peak is what it holds anyway.
pub fn keep_freed_memory() {
    #[cfg(feature = "mimalloc")]
    // SAFETY: setting an option is a plain store into mimalloc's option
    // table; -1 is the documented "no purging at all".
    unsafe {
        libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1);
    }
}

/// Runs `f` keeping what is freed for later allocations, as
/// [`keep_freed_memory`], then gives the allocator back its delay before
/// returning memory: for a program that runs a stage and goes on (the
/// Python module, with mimalloc as its allocator).
pub fn keeping_freed_memory<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(feature = "mimalloc")]
    // SAFETY: reading an option is a plain load from mimalloc's table.
    let before = unsafe { libmimalloc_sys::mi_option_get(MI_OPTION_PURGE_DELAY) };
    keep_freed_memory();
    let r = f();
    #[cfg(feature = "mimalloc")]
    // SAFETY: setting an option is a plain store into mimalloc's table.
    unsafe {
        libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, before);
    }
    r
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
        // For the length of a stage only: the delay set before comes back.
        let get = || {
            // SAFETY: reading an option.
            unsafe { libmimalloc_sys::mi_option_get(MI_OPTION_PURGE_DELAY) }
        };
        // SAFETY: setting an option (this test alone touches this one).
        unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, 1000) };
        assert_eq!(keeping_freed_memory(get), -1);
        assert_eq!(get(), 1000);
    }
}
