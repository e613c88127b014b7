//! 1,000 full instantiate → initialize → step → terminate → free cycles leak nothing: the live
//! heap (counted by a wrapping global allocator) and the resident set size (/proc/self/statm) stay
//! flat. Alone in its test binary so no other test allocates concurrently.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicIsize, Ordering};

use common::*;
use osiris_fmu::sensors;
use osiris_models::SensorKind;

struct Counting;

static LIVE_BYTES: AtomicIsize = AtomicIsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            LIVE_BYTES.fetch_add(layout.size() as isize, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE_BYTES.fetch_sub(layout.size() as isize, Ordering::Relaxed);
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            LIVE_BYTES.fetch_add(layout.size() as isize, Ordering::Relaxed);
        }
        p
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE_BYTES.fetch_add(
                new_size as isize - layout.size() as isize,
                Ordering::Relaxed,
            );
        }
        p
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// Resident set size, bytes.
fn rss_bytes() -> usize {
    let statm = std::fs::read_to_string("/proc/self/statm").expect("/proc/self/statm");
    let pages: usize = statm.split_whitespace().nth(1).unwrap().parse().unwrap();
    pages * 4096
}

fn cycle(view: &[u8], n: usize, mode: &str) {
    let kind = SensorKind::ALL[n % 3];
    let i = Inst::new(sensors::descriptor(kind));
    assert_eq!(
        i.set_strings(&[osiris_fmu::variables::vr::string::MODE], &[mode]),
        OK
    );
    assert_eq!(i.setup(), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(
        i.get_ints(&osiris_fmu::variables::vr::integer::CONFIG_REQUEST)
            .0,
        OK
    );
    assert_eq!(i.exit(), OK);
    for k in 0..3 {
        i.set_input(view);
        assert_eq!(i.step(f64::from(k) * 0.05, 0.05), OK);
        assert!(i.sensor_data().is_some());
    }
    assert_eq!(i.terminate(), OK);
    drop(i); // fmi2FreeInstance, the log collector and the resources dir
}

/// The tests share the global allocation counter: one at a time.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn a_thousand_instantiate_free_cycles_do_not_grow_memory() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let view = sample_view_bytes(0.5, 3);
    // Warm up lazily initialised statics (GUIDs, allocator pools, thread-locals).
    for n in 0..30 {
        cycle(&view, n, "ideal");
    }
    let live_before = LIVE_BYTES.load(Ordering::Relaxed);
    let rss_before = rss_bytes();
    for n in 0..1000 {
        cycle(&view, n, "ideal");
    }
    let live_after = LIVE_BYTES.load(Ordering::Relaxed);
    let rss_after = rss_bytes();
    let live_growth = live_after - live_before;
    let rss_growth = rss_after as isize - rss_before as isize;
    eprintln!(
        "live heap {live_before} -> {live_after} bytes, RSS {rss_before} -> {rss_after} bytes"
    );
    // 1 KiB of slack over 1,000 cycles: a leak of even 2 bytes per cycle would show.
    assert!(
        live_growth < 1024,
        "live heap grew by {live_growth} bytes over 1000 cycles"
    );
    // RSS is noisier (allocator caching, page granularity): allow 4 MiB.
    assert!(
        rss_growth < 4 << 20,
        "RSS grew by {rss_growth} bytes over 1000 cycles"
    );
}

#[test]
fn physical_models_free_what_they_allocate() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    // Camera, radar and LiDAR instances (n % 3 = 0, 1, 2) with their physical models: scene, BVH,
    // lens ray table, pixel maps, FFT plans, IF cube, point buffers, trackers. Fewer cycles than
    // above: a physical step costs more.
    let view = sample_view_bytes(0.5, 3);
    for n in [0, 1, 2, 1, 2] {
        cycle(&view, n, "physical");
    }
    let live_before = LIVE_BYTES.load(Ordering::Relaxed);
    for n in [0, 1, 2, 0, 1, 2, 1, 2] {
        cycle(&view, n, "physical");
    }
    let live_growth = LIVE_BYTES.load(Ordering::Relaxed) - live_before;
    eprintln!("live heap growth over 8 physical cycles: {live_growth} bytes");
    assert!(
        live_growth < 1024,
        "live heap grew by {live_growth} bytes over 8 physical cycles"
    );
}
