//! Writes by several threads into one buffer at positions no two of them
//! share: the radix sort's passes and ssmulti's results (a permutation of
//! the points) go straight to their places without a serial copy.

/// A buffer of `len` values that threads write at disjoint positions.
/// Whoever makes one promises that no position is written by two threads
/// and that nothing reads the buffer until the writing threads are
/// joined.
pub(crate) struct Disjoint<T> {
    ptr: *mut T,
    len: usize,
}

impl<T> Clone for Disjoint<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Disjoint<T> {}

// SAFETY: the maker's promise above (disjoint positions, no reads while
// threads write) is what makes sharing the pointer sound; `T: Send`
// values move into the buffer from other threads.
unsafe impl<T: Send> Send for Disjoint<T> {}
unsafe impl<T: Send> Sync for Disjoint<T> {}

impl<T: Copy> Disjoint<T> {
    /// The first `len` slots of `v`'s allocation (`len <= capacity`).
    ///
    /// # Safety
    /// Until the writers are joined: `v` is neither read, moved nor
    /// resized, and no position is written by two threads.
    pub(crate) unsafe fn new(v: &mut Vec<T>, len: usize) -> Disjoint<T> {
        assert!(len <= v.capacity());
        Disjoint {
            ptr: v.as_mut_ptr(),
            len,
        }
    }

    #[inline(always)]
    pub(crate) fn write(self, i: usize, x: T) {
        assert!(i < self.len, "disjoint write out of range");
        // SAFETY: in bounds (checked); the maker guarantees that no other
        // thread writes position `i` and that nobody reads it meanwhile.
        unsafe { self.ptr.add(i).write(x) }
    }
}
