//! Proves that the seed 004 estimator (`AccelDr`) and the GPS-only hold never
//! touch the heap per event: a counting global allocator records allocations
//! made on this test's thread while IMU samples and fixes are pushed.

use navfuse_core::estimators::accel_dr::{AccelDr, AccelDrConfig, GpsHold};
use navfuse_core::{Estimator, Event, GnssFix, ImuSample, Vec3};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
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
fn push_does_not_allocate() {
    let before = allocs();
    let v: Vec<u8> = Vec::with_capacity(64);
    assert!(allocs() > before, "counting allocator is not active");
    drop(v);

    let mut dr = AccelDr::new(AccelDrConfig::rate_scaled());
    let mut lit = AccelDr::new(AccelDrConfig::paper_literal());
    let mut hold = GpsHold::new();
    let (mut lat, lon) = (0.6f64, 2.1f64);
    let before = allocs();
    let mut outputs = 0usize;
    for k in 1..=3000u32 {
        let t = k as f64 * 0.01;
        // 2 m/s² forward then a right turn, readings in FRD.
        let f_b = Vec3::new(2.0, if t > 10.0 { 1.0 } else { 0.0 }, -9.8);
        let imu = Event::Imu(ImuSample {
            t,
            dt: 0.01,
            dtheta_b: Vec3::zeros(),
            dvel_b: f_b * 0.01,
        });
        for e in [&mut dr as &mut dyn Estimator, &mut lit, &mut hold] {
            outputs += e.push(&imu).is_some() as usize;
        }
        if k % 100 == 0 {
            lat += t * 2.0 / 6.4e6;
            let fix = Event::Gnss(GnssFix {
                t,
                lat,
                lon,
                ..Default::default()
            });
            for e in [&mut dr as &mut dyn Estimator, &mut lit, &mut hold] {
                outputs += e.push(&fix).is_some() as usize;
            }
        }
    }
    assert_eq!(allocs(), before, "push allocated");
    assert!(outputs > 8000);
}
