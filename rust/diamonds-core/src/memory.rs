//! Fallible allocation of the large buffers (hierarchy records, meshes, isosurfaces, the bridge's
//! copies): Rust aborts the process when an infallible allocation fails — inside ParaView, the
//! user's whole session — so these buffers are reserved with `try_reserve_exact` and a failure
//! becomes [`Error::OutOfMemory`], which the filter reports as its error.
//!
//! Any of the many small allocations may still be the one that fails when memory is nearly used up.
//! [`Reserving`], the global allocator of the plugin's Rust code (the bridge registers it), keeps an
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
    v.try_reserve_exact(additional).map_err(|_| {
        REFUSED.store(true, Ordering::Release);
        Error::OutOfMemory {
            what: what.to_string(),
            bytes: (additional as u64).saturating_mul(std::mem::size_of::<T>() as u64),
        }
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
/// Set when [`reserve`] could not have a large buffer since the last [`arm`].
static REFUSED: AtomicBool = AtomicBool::new(false);

fn reserve_layout() -> Layout {
    Layout::from_size_align(RESERVE_BYTES, 4096).expect("a valid layout")
}

/// The system allocator with an emergency reserve (see the module's documentation). Register it
/// with `#[global_allocator] static ALLOCATOR: diamonds::memory::Reserving = diamonds::memory::Reserving;`.
///
/// Blocks of [`MAPPED_BYTES`] or more (the hierarchy's records, the refinement's per-depth lists,
/// the mesh's counts and ids) are mapped from the kernel and unmapped when freed ([`mapped`]),
/// not taken from glibc: glibc maps such blocks too, but each free of one raises its threshold
/// for mapping (up to 32 MiB) and for trimming (up to 64 MiB), so the next ones come from the
/// heaps of the threads that ask for them, rayon's workers, and stay resident after they are
/// freed (`malloc_trim` does not give back the top of a thread's heap). Measured: Adaptive
/// Tetrahedra's first execution on bonsai 256³ at Tolerance 8 kept 498 MiB resident for an
/// output of 406 MiB, 454 MiB with large blocks mapped here.
pub struct Reserving;

/// Size from which [`Reserving`] maps a block from the kernel.
pub const MAPPED_BYTES: usize = 1 << 20;

/// Is a block of `layout` mapped from the kernel ([`MAPPED_BYTES`] or more, page-aligned at most)?
#[inline]
fn is_mapped(layout: Layout) -> bool {
    cfg!(target_os = "linux") && layout.size() >= MAPPED_BYTES && layout.align() <= 4096
}

/// Blocks mapped from the kernel (anonymous private mappings, zeroed), for [`Reserving`].
#[cfg(target_os = "linux")]
mod mapped {
    /// A new block of `size` bytes, or null.
    pub(super) unsafe fn alloc(size: usize) -> *mut u8 {
        let p = libc::mmap(
            std::ptr::null_mut(),
            size,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        );
        if p == libc::MAP_FAILED {
            std::ptr::null_mut()
        } else {
            p.cast()
        }
    }

    /// The block `p` of `old` bytes resized to `new` bytes (moved if need be), or null (`p` kept).
    pub(super) unsafe fn realloc(p: *mut u8, old: usize, new: usize) -> *mut u8 {
        let q = libc::mremap(p.cast(), old, new, libc::MREMAP_MAYMOVE);
        if q == libc::MAP_FAILED {
            std::ptr::null_mut()
        } else {
            q.cast()
        }
    }

    /// Unmaps the block `p` of `size` bytes.
    pub(super) unsafe fn dealloc(p: *mut u8, size: usize) {
        libc::munmap(p.cast(), size);
    }
}

/// Elsewhere every block comes from the system allocator ([`is_mapped`] is false).
#[cfg(not(target_os = "linux"))]
mod mapped {
    pub(super) unsafe fn alloc(_: usize) -> *mut u8 {
        unreachable!()
    }
    pub(super) unsafe fn realloc(_: *mut u8, _: usize, _: usize) -> *mut u8 {
        unreachable!()
    }
    pub(super) unsafe fn dealloc(_: *mut u8, _: usize) {
        unreachable!()
    }
}

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

    /// A block of `layout`, or null.
    unsafe fn try_alloc(layout: Layout, zeroed: bool) -> *mut u8 {
        if is_mapped(layout) {
            mapped::alloc(layout.size()) // zeroed by the kernel
        } else if zeroed {
            System.alloc_zeroed(layout)
        } else {
            System.alloc(layout)
        }
    }

    /// `ptr` (a block of `layout`) resized to `new_size` bytes, or null (`ptr` kept).
    unsafe fn try_realloc(ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let new = Layout::from_size_align_unchecked(new_size, layout.align());
        match (is_mapped(layout), is_mapped(new)) {
            (false, false) => System.realloc(ptr, layout, new_size),
            (true, true) => mapped::realloc(ptr, layout.size(), new_size),
            _ => {
                // Across the size that decides where blocks live: a new block and a copy.
                let p = Self::try_alloc(new, false);
                if !p.is_null() {
                    std::ptr::copy_nonoverlapping(ptr, p, layout.size().min(new_size));
                    Self::free(ptr, layout);
                }
                p
            }
        }
    }

    /// Frees `ptr`, a block of `layout`.
    unsafe fn free(ptr: *mut u8, layout: Layout) {
        if is_mapped(layout) {
            mapped::dealloc(ptr, layout.size())
        } else {
            System.dealloc(ptr, layout)
        }
    }
}

// SAFETY: a block of [`MAPPED_BYTES`] or more (page-aligned at most) is a mapping of its own,
// resized by `mremap` and unmapped by its layout's size; every other block comes from `System` with
// the caller's layout and goes back to it. A block's size decides which, at every call alike
// (`realloc` across that size copies into a block of the other kind).
unsafe impl GlobalAlloc for Reserving {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = Self::try_alloc(layout, false);
        if p.is_null() {
            self.failed(|| Self::try_alloc(layout, false))
        } else {
            p
        }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = Self::try_alloc(layout, true);
        if p.is_null() {
            self.failed(|| Self::try_alloc(layout, true))
        } else {
            p
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = Self::try_realloc(ptr, layout, new_size);
        if p.is_null() {
            self.failed(|| Self::try_realloc(ptr, layout, new_size))
        } else {
            p
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        Self::free(ptr, layout)
    }
}

/// Before a unit of work (a bridge call): takes the emergency reserve if it is not
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
    REFUSED.store(false, Ordering::Release);
}

/// Whether an allocation failed since the last [`arm`]: the work running must stop and report an
/// out-of-memory error (its results may be incomplete).
pub fn exhausted() -> bool {
    EXHAUSTED.load(Ordering::Acquire)
}

/// Whether memory ran short since the last [`arm`]: an allocation failed ([`exhausted`]) or a
/// large buffer was refused ([`Error::OutOfMemory`] from [`reserve`]). A unit of work that failed
/// then may succeed later, once memory is free, so its failure is not one to remember.
pub fn ran_short() -> bool {
    exhausted() || REFUSED.load(Ordering::Acquire)
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
        assert!(ran_short(), "a refused buffer is memory running short");
        assert_eq!(filled(3, 7u8, "x").unwrap(), vec![7, 7, 7]);
        assert_eq!(copied(&[1, 2], "x").unwrap(), vec![1, 2]);
    }

    #[test]
    fn blocks_keep_their_bytes_across_the_mapped_size() {
        // Small -> mapped (a copy), mapped -> mapped (mremap, moved or not), mapped -> small (a
        // copy): every byte kept up to the smaller size; mapped blocks zeroed and aligned.
        let layout = |size, align| Layout::from_size_align(size, align).unwrap();
        let byte = |i: usize| (i * 7 % 251) as u8;
        let sizes = [
            1000,
            3 * MAPPED_BYTES + 5,
            5 * MAPPED_BYTES,
            MAPPED_BYTES - 1,
            200,
        ];
        unsafe {
            let mut p = Reserving.alloc(layout(sizes[0], 16));
            assert!(!p.is_null());
            let mut filled = 0;
            for pair in sizes.windows(2) {
                let (old, new) = (pair[0], pair[1]);
                for i in filled..old {
                    *p.add(i) = byte(i);
                }
                filled = old;
                p = Reserving.realloc(p, layout(old, 16), new);
                assert!(
                    !p.is_null() && (p as usize).is_multiple_of(16),
                    "{old} -> {new}"
                );
                filled = filled.min(new);
                assert!((0..filled).all(|i| *p.add(i) == byte(i)), "{old} -> {new}");
            }
            Reserving.dealloc(p, layout(sizes[sizes.len() - 1], 16));
            let big = layout(2 * MAPPED_BYTES, 4096);
            let z = Reserving.alloc_zeroed(big);
            assert!(!z.is_null() && (z as usize).is_multiple_of(4096));
            assert!((0..big.size()).all(|i| *z.add(i) == 0));
            Reserving.dealloc(z, big);
        }
    }
}
