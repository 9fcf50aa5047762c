//! Writes by several threads into one buffer at positions no two of them
//! share: the radix sort's passes and ssmulti's results (a permutation of
//! the points) go straight to their places without a serial copy.

use std::marker::PhantomData;

/// A buffer of `len` values that threads write at disjoint positions. It
/// borrows the vector it writes for `'a`, so nothing else can read, move
/// or resize that vector meanwhile; whoever makes one promises that no
/// position is written by two threads.
pub(crate) struct Disjoint<'a, T> {
    ptr: *mut T,
    len: usize,
    _vec: PhantomData<&'a mut Vec<T>>,
}

impl<T> Clone for Disjoint<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Disjoint<'_, T> {}

// SAFETY: the maker's promise (disjoint positions) and the borrow (no
// reads while threads write) are what make sharing the pointer sound;
// `T: Send` values move into the buffer from other threads.
unsafe impl<T: Send> Send for Disjoint<'_, T> {}
unsafe impl<T: Send> Sync for Disjoint<'_, T> {}

impl<'a, T: Copy> Disjoint<'a, T> {
    /// The first `len` slots of `v`'s allocation (`len <= capacity`).
    ///
    /// # Safety
    /// No position is written by two threads.
    pub(crate) unsafe fn new(v: &'a mut Vec<T>, len: usize) -> Disjoint<'a, T> {
        assert!(len <= v.capacity());
        Disjoint {
            ptr: v.as_mut_ptr(),
            len,
            _vec: PhantomData,
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
