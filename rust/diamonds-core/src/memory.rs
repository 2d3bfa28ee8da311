//! Fallible allocation of the large buffers (hierarchy records, meshes, isosurfaces, the bridge's
//! copies): Rust aborts the process when an infallible allocation fails — inside ParaView, the
//! user's whole session — so these buffers are reserved with `try_reserve_exact` and a failure
//! becomes [`Error::OutOfMemory`], which the filter reports as its error.
//!
//! Any of the many small allocations may still be the one that fails when memory is nearly used up.
//! [`Reserving`], the global allocator of the plugin's Rust code (and of the CLI), keeps an
//! emergency reserve for that case: when the system allocator fails, the reserve is given back and
//! the allocation retried, and [`exhausted`] tells the caller that the work running must end with an
//! out-of-memory error (the bridge checks it when a call returns and at every progress report) —
//! the session survives and the filter reports the error.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicPtr, Ordering};

use crate::{Error, Result};

/// An empty vector with room for `capacity` elements; `what` names the buffer in the error.
pub fn with_capacity<T>(capacity: usize, what: &str) -> Result<Vec<T>> {
    let mut v = Vec::new();
    reserve(&mut v, capacity, what)?;
    Ok(v)
}

/// `len` copies of `value`.
pub fn filled<T: Clone>(len: usize, value: T, what: &str) -> Result<Vec<T>> {
    let mut v = with_capacity(len, what)?;
    v.resize(len, value);
    Ok(v)
}

/// A copy of `values`.
pub fn copied<T: Clone>(values: &[T], what: &str) -> Result<Vec<T>> {
    let mut v = with_capacity(values.len(), what)?;
    v.extend_from_slice(values);
    Ok(v)
}

/// Room for `additional` more elements in `v`; refused once memory is [`exhausted`], so that work
/// that ran out of memory stops at its next large buffer.
pub fn reserve<T>(v: &mut Vec<T>, additional: usize, what: &str) -> Result<()> {
    check(what)?;
    v.try_reserve_exact(additional)
        .map_err(|_| Error::OutOfMemory {
            what: what.to_string(),
            bytes: (additional as u64).saturating_mul(std::mem::size_of::<T>() as u64),
        })
}

/// Bytes of the emergency reserve: enough address space for the work running when memory ran
/// out to reach its next progress report or its end (allocations of that size are rare outside the
/// fallible large buffers above).
pub const RESERVE_BYTES: usize = 128 << 20;

/// The reserve block (null when given back or not taken yet).
static RESERVE: AtomicPtr<u8> = AtomicPtr::new(std::ptr::null_mut());
/// Set when an allocation failed since the last [`arm`].
static EXHAUSTED: AtomicBool = AtomicBool::new(false);

fn reserve_layout() -> Layout {
    Layout::from_size_align(RESERVE_BYTES, 4096).expect("a valid layout")
}

/// The system allocator with an emergency reserve (see the module's documentation). Register it
/// with `#[global_allocator] static ALLOCATOR: diamonds::memory::Reserving = diamonds::memory::Reserving;`.
pub struct Reserving;

impl Reserving {
    /// After a failed allocation: marks memory as exhausted and gives the reserve back; then
    /// `retry` (the allocation) once more if there was a reserve to give back.
    #[cold]
    unsafe fn failed(&self, retry: impl FnOnce() -> *mut u8) -> *mut u8 {
        EXHAUSTED.store(true, Ordering::Release);
        let block = RESERVE.swap(std::ptr::null_mut(), Ordering::AcqRel);
        if block.is_null() {
            return block;
        }
        System.dealloc(block, reserve_layout());
        retry()
    }
}

// SAFETY: every block comes from `System` with the caller's layout and goes back to it.
unsafe impl GlobalAlloc for Reserving {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if p.is_null() {
            self.failed(|| System.alloc(layout))
        } else {
            p
        }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc_zeroed(layout);
        if p.is_null() {
            self.failed(|| System.alloc_zeroed(layout))
        } else {
            p
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = System.realloc(ptr, layout, new_size);
        if p.is_null() {
            self.failed(|| System.realloc(ptr, layout, new_size))
        } else {
            p
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

/// Before a unit of work (a bridge call, a CLI command): takes the emergency reserve if it is not
/// held (untouched address space, no physical memory) and clears [`exhausted`]. Without
/// [`Reserving`] as the global allocator this only clears the flag.
pub fn arm() {
    if RESERVE.load(Ordering::Acquire).is_null() {
        // SAFETY: a non-zero-sized layout; the block is only ever freed by `Reserving::failed`
        // (or below, when another thread stored one first).
        let block = unsafe { System.alloc(reserve_layout()) };
        if !block.is_null() {
            if let Err(other) = RESERVE.compare_exchange(
                std::ptr::null_mut(),
                block,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                debug_assert!(!other.is_null());
                unsafe { System.dealloc(block, reserve_layout()) };
            }
        }
    }
    EXHAUSTED.store(false, Ordering::Release);
}

/// Whether an allocation failed since the last [`arm`]: the work running must stop and report an
/// out-of-memory error (its results may be incomplete).
pub fn exhausted() -> bool {
    EXHAUSTED.load(Ordering::Acquire)
}

/// Fails with [`Error::OutOfMemory`] for `what` when [`exhausted`]: long loops call it between
/// rounds, so that the work stops soon after memory ran out instead of allocating on.
pub fn check(what: &str) -> Result<()> {
    if exhausted() {
        return Err(Error::OutOfMemory {
            what: what.to_string(),
            bytes: 0,
        });
    }
    Ok(())
}

/// Whether the emergency reserve is held.
pub fn reserve_held() -> bool {
    !RESERVE.load(Ordering::Acquire).is_null()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_impossible_allocation_is_an_error() {
        match with_capacity::<u64>(usize::MAX / 4, "a test buffer") {
            Err(e @ Error::OutOfMemory { .. }) => {
                assert!(e.to_string().contains("a test buffer"), "{e}")
            }
            other => panic!("expected OutOfMemory, got {other:?}"),
        }
        assert_eq!(filled(3, 7u8, "x").unwrap(), vec![7, 7, 7]);
        assert_eq!(copied(&[1, 2], "x").unwrap(), vec![1, 2]);
    }
}
