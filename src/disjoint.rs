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
// SAFETY: as for `Send`: threads sharing a `&Disjoint` only write, each
// to positions no other thread writes.
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

/// The parts one after another, copied by as many threads as there are
/// parts to share: a serial concatenation of a large result would leave
/// the other threads idle while it copies (and faults in) every byte.
pub(crate) fn concat<T: Send>(parts: Vec<Vec<T>>) -> Vec<T> {
    use rayon::prelude::*;
    let total: usize = parts.iter().map(Vec::len).sum();
    let mut out: Vec<T> = Vec::with_capacity(total);
    let mut rest = &mut out.spare_capacity_mut()[..total];
    let mut dst = Vec::with_capacity(parts.len());
    for p in &parts {
        let (a, b) = rest.split_at_mut(p.len());
        dst.push(a);
        rest = b;
    }
    dst.into_par_iter().zip(parts).for_each(|(d, s)| {
        for (d, s) in d.iter_mut().zip(s) {
            d.write(s);
        }
    });
    // SAFETY: the slices written above tile the first `total` slots, and
    // each was written in full (its length is its part's): the values
    // moved there from the parts, which are gone.
    unsafe { out.set_len(total) };
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn concat_keeps_order_and_every_value() {
        let parts: Vec<Vec<u32>> = (0..100u32)
            .map(|i| (0..i % 7).map(|j| i * 10 + j).collect())
            .collect();
        let want: Vec<u32> = parts.iter().flatten().copied().collect();
        assert_eq!(super::concat(parts), want);
        assert!(super::concat::<u8>(Vec::new()).is_empty());
    }
}
