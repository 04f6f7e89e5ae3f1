//! Proves that the per-step Kalman functions never touch the heap: a counting
//! global allocator records allocations made on this test's thread while a
//! 15-state predict + 6-measurement Joseph update loop runs.

use nalgebra::{SMatrix, SVector};
use navfuse_core::kalman::{chi2_quantile, predict, predict_sparse, update_joseph};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    // Const-initialised, no destructor: safe to touch from inside the allocator.
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: delegates every call unchanged to the system allocator.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
        System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocs() -> usize {
    ALLOCS.with(|c| c.get())
}

#[test]
fn predict_and_update_do_not_allocate() {
    // The counter works: a Vec on this thread is seen.
    let before = allocs();
    let v: Vec<u8> = Vec::with_capacity(64);
    assert!(allocs() > before, "counting allocator is not active");
    drop(v);

    let dt = 0.01;
    let mut f = SMatrix::<f64, 15, 15>::identity();
    for i in 0..3 {
        f[(i, i + 3)] = dt;
        f[(3 + i, 6 + (i + 1) % 3)] = 9.8 * dt;
        f[(6 + i, 12 + i)] = -dt;
        f[(3 + i, 9 + i)] = dt;
    }
    let q = SMatrix::<f64, 15, 15>::identity() * 1e-6;
    let mut h = SMatrix::<f64, 6, 15>::zeros();
    for i in 0..6 {
        h[(i, i)] = 1.0;
    }
    let r = SMatrix::<f64, 6, 6>::identity() * 0.25;
    let mut x = SVector::<f64, 15>::zeros();
    let mut p = SMatrix::<f64, 15, 15>::identity();

    let start = allocs();
    let gate = chi2_quantile(6, 0.999);
    let mut accepted = 0;
    for k in 0..1000 {
        if k % 2 == 0 {
            predict(&mut p, &f, &q);
        } else {
            predict_sparse(&mut p, &f, &q);
        }
        if k % 100 == 99 {
            let nu = SVector::<f64, 6>::from_fn(|i, _| ((k + i) % 5) as f64 * 0.1 - 0.2);
            accepted += update_joseph(&mut x, &mut p, &h, &r, &nu, Some(gate)).accepted as usize;
        }
    }
    let used = allocs() - start;
    assert_eq!(used, 0, "{used} heap allocations in the Kalman loop");
    assert_eq!(accepted, 10);
    assert!(p.iter().all(|v| v.is_finite()));
}
