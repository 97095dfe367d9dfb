//! Ranks as threads of one process ([`run`]): each rank gets a [`Threads`]
//! handle; messages go through a shared mailbox keyed by (sender,
//! receiver, call number). The same algorithms run over it as over MPI, so
//! the tests check a decomposition at 1–4 ranks in the ordinary test build.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Condvar, Mutex};

use super::Comm;

/// Messages in flight: (from, to, call) → numbers.
#[derive(Default)]
struct Hub {
    mail: Mutex<HashMap<(usize, usize, u64), Vec<f64>>>,
    arrived: Condvar,
}

/// One rank's handle.
pub struct Threads<'h> {
    rank: usize,
    size: usize,
    hub: &'h Hub,
    /// Collective calls made so far (every rank makes the same ones).
    calls: AtomicU64,
}

/// Runs `f` on `size` ranks, one thread each, and returns their results in
/// rank order.
///
/// # Panics
/// When a rank panics (the others may then wait forever: tests only).
pub fn run<T: Send>(size: usize, f: impl Fn(&Threads<'_>) -> T + Sync) -> Vec<T> {
    let hub = Hub::default();
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..size)
            .map(|rank| {
                let (hub, f) = (&hub, &f);
                s.spawn(move || {
                    f(&Threads {
                        rank,
                        size,
                        hub,
                        calls: AtomicU64::new(0),
                    })
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a rank panicked"))
            .collect()
    })
}

impl Threads<'_> {
    /// Posts `sends`, then takes the messages of `from`, in order.
    fn post_and_take(&self, sends: &[(usize, Vec<f64>)], from: &[usize]) -> Vec<Vec<f64>> {
        let call = self.calls.fetch_add(1, Ordering::Relaxed);
        let mut mail = self.hub.mail.lock().expect("mailbox");
        for (to, data) in sends {
            mail.insert((self.rank, *to, call), data.clone());
        }
        self.hub.arrived.notify_all();
        let mut out = Vec::with_capacity(from.len());
        for &r in from {
            loop {
                if let Some(data) = mail.remove(&(r, self.rank, call)) {
                    out.push(data);
                    break;
                }
                mail = self.hub.arrived.wait(mail).expect("mailbox");
            }
        }
        out
    }
}

impl Comm for Threads<'_> {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn all_gather(&self, values: &[f64]) -> Vec<Vec<f64>> {
        let others: Vec<usize> = (0..self.size).filter(|&r| r != self.rank).collect();
        let sends: Vec<(usize, Vec<f64>)> = others.iter().map(|&r| (r, values.to_vec())).collect();
        let mut got = self.post_and_take(&sends, &others).into_iter();
        (0..self.size)
            .map(|r| match r == self.rank {
                true => values.to_vec(),
                false => got.next().expect("one message per rank"),
            })
            .collect()
    }

    fn exchange(&self, sends: &[(usize, Vec<f64>)], recvs: &[(usize, usize)]) -> Vec<Vec<f64>> {
        let from: Vec<usize> = recvs.iter().map(|&(r, _)| r).collect();
        let got = self.post_and_take(sends, &from);
        for (data, &(r, len)) in got.iter().zip(recvs) {
            assert_eq!(data.len(), len, "rank {r} sent another length");
        }
        got
    }
}
