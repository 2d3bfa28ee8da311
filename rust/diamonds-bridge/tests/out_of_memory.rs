//! A failed allocation ends a bridge call with an error instead of aborting the process. In a test
//! binary of its own: the emergency reserve and the exhausted flag are process-wide, so other tests
//! running at the same time would see them.

use diamonds::memory::{exhausted, reserve_held, Reserving};
use diamonds_bridge::{guard, ran_out_of_memory};
use std::alloc::{GlobalAlloc, Layout};

#[test]
fn a_failed_allocation_fails_the_call_and_the_next_call_rearms() {
    // The allocator alone: an allocation no system can satisfy fails even after the reserve is
    // given back, and is remembered.
    diamonds::memory::arm();
    assert!(reserve_held() && !exhausted());
    let huge = Layout::from_size_align(isize::MAX as usize / 2, 8).unwrap();
    assert!(unsafe { Reserving.alloc(huge) }.is_null());
    assert!(exhausted() && !reserve_held());
    let small = Layout::from_size_align(64, 8).unwrap();
    let p = unsafe { Reserving.alloc_zeroed(small) };
    assert!(!p.is_null(), "ordinary allocations still work");
    unsafe { Reserving.dealloc(p, small) };

    // Through a bridge call: a failed allocation inside it (here a fallible one; an infallible one
    // would go on with the reserve given back) makes the call fail with an out-of-memory message,
    // even though its body returned a result...
    let r: Result<bool, String> = guard("testing memory", || {
        let mut v = Vec::<u8>::new();
        Ok(v.try_reserve(isize::MAX as usize / 2).is_err())
    });
    let msg = r.unwrap_err();
    assert!(
        msg.starts_with("out of memory while testing memory"),
        "{msg}"
    );
    assert!(!reserve_held() && ran_out_of_memory());
    // ...and the next call takes the reserve again and runs normally.
    assert_eq!(
        guard("testing memory again", || Ok(vec![1u8; 1000].len())),
        Ok(1000)
    );
    assert!(reserve_held() && !exhausted() && !ran_out_of_memory());
    // A buffer the core cannot even ask for (its size overflows) fails the call with the core's
    // message, and memory is known to have run short although no allocation failed.
    let r: Result<(), String> = guard("testing a refused buffer", || {
        diamonds::memory::with_capacity::<u64>(usize::MAX / 4, "a test buffer")
            .map(drop)
            .map_err(|e| e.to_string())
    });
    assert!(r
        .unwrap_err()
        .starts_with("not enough memory for a test buffer"));
    assert!(ran_out_of_memory() && !exhausted());
    // Any other failure is not memory running short.
    let r: Result<(), String> = guard("testing a failure", || Err("bad input".into()));
    assert_eq!(r, Err("bad input".into()));
    assert!(!ran_out_of_memory());
    // A large buffer the core reserves fallibly is refused while memory is exhausted.
    let r: Result<(), String> = guard("testing the core's buffers", || {
        assert!(unsafe { Reserving.alloc(huge) }.is_null());
        diamonds::memory::with_capacity::<u64>(10, "a test buffer")
            .map(drop)
            .map_err(|e| e.to_string())
    });
    assert!(r
        .unwrap_err()
        .starts_with("out of memory while testing the core's buffers"));
}
