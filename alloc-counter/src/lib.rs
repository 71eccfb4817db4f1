//! A counting global allocator for tests that prove a hot path never touches the heap.
//!
//! Install it once per test binary and measure a closure:
//!
//! ```ignore
//! #[global_allocator]
//! static ALLOCATOR: alloc_counter::CountingAllocator = alloc_counter::CountingAllocator;
//!
//! let allocations = alloc_counter::count_allocations(|| hot_path());
//! assert_eq!(allocations, 0);
//! ```
//!
//! Counts are kept per thread, so tests running in parallel do not see each other's
//! allocations.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

thread_local! {
    static ALLOCATIONS_ON_THIS_THREAD: Cell<u64> = const { Cell::new(0) };
}

/// Global allocator that forwards to the system allocator and counts allocations per thread.
pub struct CountingAllocator;

fn record_allocation() {
    // `try_with` because the thread-local may already be torn down while a thread exits.
    let _ = ALLOCATIONS_ON_THIS_THREAD.try_with(|count| count.set(count.get() + 1));
}

// SAFETY: every method forwards to `System`, which upholds the `GlobalAlloc` contract; the
// counter is a thread-local `Cell` that never allocates.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        record_allocation();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        record_allocation();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        record_allocation();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Number of heap allocations (including reallocations) made so far on the calling thread.
pub fn allocations_on_this_thread() -> u64 {
    ALLOCATIONS_ON_THIS_THREAD.with(Cell::get)
}

/// Runs `work` and returns how many heap allocations it made on the calling thread.
///
/// Only meaningful in a test binary that installs [`CountingAllocator`] as its global
/// allocator; otherwise it always returns 0.
pub fn count_allocations<R>(work: impl FnOnce() -> R) -> u64 {
    let before = allocations_on_this_thread();
    let result = work();
    let after = allocations_on_this_thread();
    drop(result);
    after - before
}

#[cfg(test)]
mod tests {
    use super::*;

    #[global_allocator]
    static ALLOCATOR: CountingAllocator = CountingAllocator;

    #[test]
    fn counts_a_vector_allocation() {
        let allocations = count_allocations(|| vec![1_u8; 64]);
        assert_eq!(allocations, 1);
    }

    #[test]
    fn stack_work_does_not_count() {
        let allocations = count_allocations(|| {
            let values = [1.0_f64; 16];
            values.iter().sum::<f64>()
        });
        assert_eq!(allocations, 0);
    }
}
