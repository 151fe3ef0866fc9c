//! The binary's allocator (`isar_clutter::alloc::LargeMapAlloc`) as a global allocator: vectors
//! that grow across the 2 MiB threshold (realloc by `mremap`), shrink back under it, large
//! zeroed arrays, and an analysis on mapped blocks against its slow oracle.

mod common;

#[global_allocator]
static GLOBAL: isar_clutter::alloc::LargeMapAlloc = isar_clutter::alloc::LargeMapAlloc;

#[test]
fn vectors_grow_and_shrink_across_the_threshold() {
    let mut v: Vec<u64> = Vec::new();
    for i in 0..2_000_000u64 {
        v.push(i);
    }
    assert!(v.iter().enumerate().all(|(i, &x)| x == i as u64));
    v.truncate(10);
    v.shrink_to_fit();
    assert_eq!(v, (0..10).collect::<Vec<_>>());
    let z = vec![0.0f64; 1 << 20];
    assert!(z.iter().all(|&x| x == 0.0));
    let boxed: Box<[u8]> = vec![3u8; 5 << 20].into_boxed_slice();
    assert!(boxed.iter().all(|&b| b == 3));
}

#[test]
fn an_analysis_on_large_buffers_matches_its_oracle() {
    // 300 x 48 x 48 complex128 (11 MB): the stack and its copies are mapped blocks.
    let stack = common::random_stack(21, 300, 48, 48);
    let a = isar_clutter::stats::analysis::analyse(stack.view(), 2).unwrap();
    for lm in &a.levels {
        let (corr, _) = isar_clutter::stats::oracle::direct_level(&stack, lm.level);
        for d in isar_clutter::stats::analysis::Direction::ALL {
            let diff = common::max_diff(lm.correlation(d), &corr[d as usize]);
            assert!(diff < common::REORDER_TOL, "level {} {d}: {diff}", lm.level);
        }
    }
}
