//! Lock-free single-writer / single-reader triple buffer for the latest-state snapshot.
//!
//! Three slots: the writer owns one (back), the reader owns one (front), and the third (middle)
//! is exchanged through one atomic byte holding its index plus a "fresh" bit. Publishing swaps
//! the back slot into the middle; reading swaps the middle into the front when it is fresh.
//! Each slot is only ever accessed by the side that currently owns it, and ownership changes
//! hands through an `AcqRel` swap, which orders the writer's stores before the reader's loads
//! (and the reader's loads before the writer reuses the slot). Neither side ever waits: the
//! real-time writer cannot be blocked by a slow reader, and the reader always sees the newest
//! complete value.

use std::cell::UnsafeCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

const INDEX_MASK: u8 = 0b011;
const FRESH: u8 = 0b100;

struct Shared<T> {
    slots: [UnsafeCell<T>; 3],
    /// Index of the middle slot, with [`FRESH`] set when it holds an unread publication.
    middle: AtomicU8,
}

// SAFETY: a slot is accessed only by the side owning it (see module docs), so sharing the
// container between the two threads is sound whenever the values themselves may move between
// threads.
unsafe impl<T: Send> Sync for Shared<T> {}

/// Creates a connected writer and reader; all three slots start as `initial`.
pub fn triple_buffer<T: Clone + Send>(initial: T) -> (Writer<T>, Reader<T>) {
    let shared = Arc::new(Shared {
        slots: [
            UnsafeCell::new(initial.clone()),
            UnsafeCell::new(initial.clone()),
            UnsafeCell::new(initial),
        ],
        middle: AtomicU8::new(1),
    });
    (
        Writer {
            shared: Arc::clone(&shared),
            back: 0,
        },
        Reader { shared, front: 2 },
    )
}

/// Publishing side (the real-time thread). Never blocks, never allocates.
pub struct Writer<T> {
    shared: Arc<Shared<T>>,
    back: u8,
}

impl<T> Writer<T> {
    /// Overwrites the back slot with `value` (by `clone_from`) and publishes it.
    pub fn publish(&mut self, value: &T)
    where
        T: Clone,
    {
        // SAFETY: the writer exclusively owns slot `back` until the swap below hands it over.
        let slot = unsafe { &mut *self.shared.slots[usize::from(self.back)].get() };
        slot.clone_from(value);
        let previous = self.shared.middle.swap(self.back | FRESH, Ordering::AcqRel);
        self.back = previous & INDEX_MASK;
    }
}

/// Reading side. Never blocks the writer.
pub struct Reader<T> {
    shared: Arc<Shared<T>>,
    front: u8,
}

impl<T> Reader<T> {
    /// The newest published value (the initial value before the first publication).
    pub fn latest(&mut self) -> &T {
        if self.shared.middle.load(Ordering::Relaxed) & FRESH != 0 {
            let previous = self.shared.middle.swap(self.front, Ordering::AcqRel);
            self.front = previous & INDEX_MASK;
        }
        // SAFETY: the reader exclusively owns slot `front` until it swaps it back.
        unsafe { &*self.shared.slots[usize::from(self.front)].get() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reader_sees_initial_then_newest_value() {
        let (mut w, mut r) = triple_buffer(0u32);
        assert_eq!(*r.latest(), 0);
        w.publish(&1);
        w.publish(&2);
        assert_eq!(*r.latest(), 2);
        assert_eq!(*r.latest(), 2);
        w.publish(&3);
        assert_eq!(*r.latest(), 3);
    }

    #[test]
    fn concurrent_reads_are_never_torn_and_never_go_back() {
        // Each value is an array whose elements all equal the publication number: a torn read
        // would mix numbers.
        const N: u64 = 200_000;
        let (mut w, mut r) = triple_buffer([0u64; 64]);
        let writer = std::thread::spawn(move || {
            for k in 1..=N {
                w.publish(&[k; 64]);
            }
        });
        let mut last = 0;
        loop {
            let v = *r.latest();
            assert!(v.iter().all(|x| *x == v[0]), "torn read");
            assert!(v[0] >= last, "went back from {last} to {}", v[0]);
            last = v[0];
            if last == N {
                break;
            }
            if writer.is_finished() && *r.latest() == [N; 64] {
                break;
            }
        }
        writer.join().unwrap();
        assert_eq!(*r.latest(), [N; 64]);
    }
}
