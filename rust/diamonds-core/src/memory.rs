//! Fallible allocation of the large buffers (hierarchy records, meshes, isosurfaces, the bridge's
//! copies): Rust aborts the process when an infallible allocation fails — inside ParaView, the
//! user's whole session — so these buffers are reserved with `try_reserve_exact` and a failure
//! becomes [`Error::OutOfMemory`], which the filter reports as its error.

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

/// Room for `additional` more elements in `v`.
pub fn reserve<T>(v: &mut Vec<T>, additional: usize, what: &str) -> Result<()> {
    v.try_reserve_exact(additional)
        .map_err(|_| Error::OutOfMemory {
            what: what.to_string(),
            bytes: (additional as u64).saturating_mul(std::mem::size_of::<T>() as u64),
        })
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
