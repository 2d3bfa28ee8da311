//! Pieces of a partitioned extraction run at once in one process, one thread each, exchanging as
//! ranks do ([`Exchange`]): for the tests of the shared extractions (Adaptive Isosurface's and
//! the interval volume's).

use super::bound::VIOLATIONS;
use super::Exchange;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Barrier, Mutex};

/// The shared end of the pieces' exchange.
struct Threads {
    barrier: Barrier,
    slots: Mutex<Vec<Vec<u8>>>,
    /// Exchanges in which a piece sent violations (112 bytes each, beyond the tag and an 8-byte
    /// count per isovalue).
    sent: AtomicUsize,
}

/// One piece's end of [`Threads`].
pub(crate) struct Member<'t> {
    me: usize,
    threads: &'t Threads,
}

impl Exchange for Member<'_> {
    fn all_gather(&self, bytes: Vec<u8>) -> crate::Result<Vec<Vec<u8>>> {
        let t = self.threads;
        let violations = bytes.first() == Some(&VIOLATIONS) && bytes.len() > 112;
        t.sent.fetch_add(usize::from(violations), Ordering::Relaxed);
        t.slots.lock().unwrap()[self.me] = bytes;
        t.barrier.wait();
        let all = t.slots.lock().unwrap().clone();
        t.barrier.wait();
        Ok(all)
    }
}

/// Runs `piece(me, exchange)` for `me` in `0..n` at once, one thread each; returns their results
/// and how many times a piece sent violations.
pub(crate) fn run_pieces<R: Send>(
    n: usize,
    piece: impl Fn(usize, &Member<'_>) -> R + Sync,
) -> (Vec<R>, usize) {
    let threads = Threads {
        barrier: Barrier::new(n),
        slots: Mutex::new(vec![Vec::new(); n]),
        sent: AtomicUsize::new(0),
    };
    let results = std::thread::scope(|scope| {
        let runs: Vec<_> = (0..n)
            .map(|me| {
                let (threads, piece) = (&threads, &piece);
                scope.spawn(move || piece(me, &Member { me, threads }))
            })
            .collect();
        runs.into_iter().map(|r| r.join().unwrap()).collect()
    });
    (results, threads.sent.into_inner())
}
