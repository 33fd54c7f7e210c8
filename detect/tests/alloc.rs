//! The hot path allocates nothing once warmed up: counted with a global allocator.

mod common;
use common::*;
use lumen_detect::{ContactKind, Detector, Method, Scene};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;
static ALLOCS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(p, l, n) }
    }
}

#[global_allocator]
static A: Counting = Counting;

#[test]
fn no_allocation_per_frame_after_warm_up() {
    for (method, nearest) in [(Method::Signed, false), (Method::Signed, true), (Method::Thesis, false)] {
        // Every kind of pair at once, the rod moving, touching and leaving the wall.
        let colon = arc(80, 150.0, 2.0, 20.0, 24);
        let other = line([0.0, 60.0, 30.0], [100.0, 60.0, 30.0], 12, 3.0);
        let scope_at = |f: usize| {
            let y = 12.0 + 12.0 * (f as f32 * 0.2).sin();
            line([10.0 + f as f32, y, 0.0], [120.0 + f as f32, y + 20.0, 25.0], 30, 4.0)
        };
        let scene_at = |f: usize| {
            Scene::new()
                .tube("colon", colon.clone())
                .rod("scope", scope_at(f))
                .rod("other", other.clone())
                .pair("scope", "colon", ContactKind::Interior)
                .pair("scope", "colon", ContactKind::Exterior)
                .pair("scope", "other", ContactKind::Exterior)
                .pair("scope", "scope", ContactKind::SelfContact)
                .precision(4)
                .method(method)
                .nearest(nearest)
        };
        let mut d = Detector::new(&scene_at(0).spec().validate().unwrap());
        let states: Vec<Vec<f32>> = (0..40).map(|f| scene_at(f).state()).collect();
        // Warm up on the frame with the most contacts so every buffer reaches its size.
        for s in &states {
            d.detect(s).unwrap();
        }
        let mut total = 0;
        let before = ALLOCS.load(Ordering::Relaxed);
        for s in &states {
            total += d.detect(s).unwrap().len();
        }
        let after = ALLOCS.load(Ordering::Relaxed);
        assert!(total > 100, "{method:?} (nearest {nearest}): the scene must produce contacts ({total})");
        assert_eq!(after - before, 0, "{method:?} (nearest {nearest}): allocations in 40 warmed-up frames");
    }
}
