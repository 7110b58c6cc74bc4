//! A slice the tasks of one parallel loop read and write element by
//! element, where the caller knows no element one task writes is touched
//! by any other task of the loop: a coloured Gauss–Seidel sweep, whose
//! lines of one colour write only their own nodes and read only nodes of
//! other colours. A task's writes then need no hand-off through a
//! scratch buffer and a serial copy after the loop (which on two cores
//! cost a line smoother a fifth of its time: every value crossed from the
//! core that computed it to the one that copied it).

use std::marker::PhantomData;

/// `&mut [T]` shared by the tasks of one loop for disjoint access.
#[derive(Debug)]
pub struct Disjoint<'a, T> {
    ptr: *mut T,
    len: usize,
    _slice: PhantomData<&'a mut [T]>,
}

// SAFETY: `Disjoint` hands out no references, only copies in and out
// through `read` and `write`, whose callers promise that no element is
// written by one thread while another reads or writes it; with that
// promise kept, sharing it between threads is sharing disjoint parts of
// a `&mut [T]`, which is `Send` when `T` is.
#[allow(unsafe_code)]
unsafe impl<T: Send> Sync for Disjoint<'_, T> {}

impl<'a, T: Copy> Disjoint<'a, T> {
    /// Shares `slice` for the lifetime of the loop.
    pub fn new(slice: &'a mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _slice: PhantomData,
        }
    }

    /// Element `i`.
    ///
    /// # Safety
    ///
    /// No other thread writes element `i` during the loop.
    #[allow(unsafe_code)]
    #[inline(always)]
    pub unsafe fn read(&self, i: usize) -> T {
        assert!(i < self.len);
        // SAFETY: in bounds (checked), and not written concurrently (the
        // caller's promise).
        unsafe { self.ptr.add(i).read() }
    }

    /// Its length.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it has no element.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Element `i`, its bounds not checked: for the innermost loops of a
    /// caller that checked every index it reads against [`Self::len`]
    /// once, before the loop (PERF: a check per read was 1.6 % of
    /// sphere-drape-30's instructions, in the line sweep).
    ///
    /// # Safety
    ///
    /// `i < self.len()`, and no other thread writes element `i` during
    /// the loop.
    #[allow(unsafe_code)]
    #[inline(always)]
    pub unsafe fn read_unchecked(&self, i: usize) -> T {
        debug_assert!(i < self.len);
        // SAFETY: in bounds and not written concurrently (the caller's
        // promise).
        unsafe { self.ptr.add(i).read() }
    }

    /// Elements `range` as a slice of their own.
    ///
    /// # Safety
    ///
    /// No other thread reads or writes any of them while the slice lives.
    #[allow(unsafe_code, clippy::mut_from_ref)]
    #[inline(always)]
    pub unsafe fn slice(&self, range: std::ops::Range<usize>) -> &mut [T] {
        assert!(range.start <= range.end && range.end <= self.len);
        // SAFETY: in bounds (checked), and accessed by no one else while
        // the slice lives (the caller's promise).
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(range.start), range.len()) }
    }

    /// Sets element `i` to `value`.
    ///
    /// # Safety
    ///
    /// No other thread reads or writes element `i` during the loop.
    #[allow(unsafe_code)]
    #[inline(always)]
    pub unsafe fn write(&self, i: usize, value: T) {
        assert!(i < self.len);
        // SAFETY: in bounds (checked), and not accessed concurrently (the
        // caller's promise).
        unsafe { self.ptr.add(i).write(value) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tasks writing disjoint elements and reading others' leave the
    /// slice as a serial loop would.
    #[test]
    fn disjoint_writes_from_a_team_land_where_they_should() {
        let n = 10_000;
        let mut v: Vec<u64> = (0..n as u64).collect();
        let shared = Disjoint::new(&mut v);
        super::super::with_threads(2, || {
            super::super::each(0..4usize, |task| {
                for i in (task..n).step_by(4) {
                    // SAFETY: task `t` writes only elements `i ≡ t (mod
                    // 4)`, and reads only those.
                    #[allow(unsafe_code)]
                    unsafe {
                        shared.write(i, shared.read(i) * 2 + 1);
                    }
                }
            });
        });
        assert!(v.iter().enumerate().all(|(i, &x)| x == 2 * i as u64 + 1));
    }
}
