//! The process's memory allocator: the system allocator, except that blocks of 2 MiB and more
//! are mapped straight from the kernel (Linux), with transparent huge pages requested.
//!
//! Why: on the virtual machines this tool runs on, a page fault costs several microseconds, and
//! the system allocator hands out large zeroed blocks by clearing them page by page (always
//! when the alignment is above 16 bytes, as for polars' one-off 8 MiB zero buffer made on the
//! first Parquet write: about 2000 faults, a third of a short run). A fresh mapping is zero
//! without being touched, pages never read cost nothing, and pages that are used arrive 2 MiB
//! at a time where the kernel can provide huge pages.
//!
//! Which blocks are mapped depends only on their layout (size at least [`LARGE`], alignment at
//! most a page), so `dealloc` and `realloc` know how a block was made. `realloc` between two
//! mapped sizes is `mremap` (no copy). The mapped bytes are counted (two atomic operations per
//! mapping, next to a system call): [`mapped_bytes`] gives the current and the peak count, which
//! the tests compare with the jobs' memory estimates.
//!
//! The big arrays of a job (a dataset's stack, its complex128 copy, the generated samples, the
//! full-covariance deviations) are made by [`try_zeros`]: an allocation that fails becomes an
//! [`AllocError`] naming the array and its size, which fails that job alone instead of aborting
//! the process.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Bytes currently mapped by [`LargeMapAlloc`].
static MAPPED: AtomicUsize = AtomicUsize::new(0);
/// Most bytes mapped at once since the start or the last [`reset_peak`].
static PEAK: AtomicUsize = AtomicUsize::new(0);

/// `(current, peak)` bytes in blocks of [`LARGE`] bytes and more that [`LargeMapAlloc`] has
/// mapped (zero where it is not the global allocator, or off Linux).
pub fn mapped_bytes() -> (usize, usize) {
    (MAPPED.load(Ordering::Relaxed), PEAK.load(Ordering::Relaxed))
}

/// Restarts the peak of [`mapped_bytes`] from the bytes mapped now.
pub fn reset_peak() {
    PEAK.store(MAPPED.load(Ordering::Relaxed), Ordering::Relaxed);
}

fn count_mapped(add: usize, sub: usize) {
    if add >= sub {
        let now = MAPPED.fetch_add(add - sub, Ordering::Relaxed) + (add - sub);
        PEAK.fetch_max(now, Ordering::Relaxed);
    } else {
        MAPPED.fetch_sub(sub - add, Ordering::Relaxed);
    }
}

/// An allocation of a big array that the system refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot allocate {what} ({bytes} bytes, {shape:?}): out of memory")]
pub struct AllocError {
    /// What the array is (`the generated samples`).
    pub what: String,
    /// Its shape.
    pub shape: Vec<usize>,
    /// Its bytes (saturated at `u128::MAX`).
    pub bytes: u128,
}

/// A zero-filled array of `shape`, or an [`AllocError`] naming `what` when the memory cannot be
/// had (or the size overflows). The block comes from the global allocator's `alloc_zeroed`, as
/// for `Array::zeros` of a number type: a fresh mapping is zero without being touched.
///
/// # Errors
/// [`AllocError`] when the allocation fails.
pub fn try_zeros<A, Sh>(shape: Sh, what: &str) -> Result<ndarray::Array<A, Sh::Dim>, AllocError>
where
    A: bytemuck::Zeroable,
    Sh: ndarray::ShapeBuilder,
{
    use ndarray::Dimension;
    let shape = shape.into_shape_with_order();
    let dims = shape.raw_dim().slice().to_vec();
    let error = || AllocError {
        what: what.to_string(),
        bytes: dims.iter().fold(std::mem::size_of::<A>() as u128, |b, &d| {
            b.saturating_mul(d as u128)
        }),
        shape: dims.clone(),
    };
    let len = dims
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .ok_or_else(error)?;
    // ndarray also bounds the non-zero axes of an empty array (a forged file's `0 x 2^40 x
    // 2^40`): an error here, not a panic below.
    dims.iter()
        .filter(|&&d| d != 0)
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .filter(|&n| n <= isize::MAX as usize)
        .ok_or_else(error)?;
    let layout = Layout::array::<A>(len).map_err(|_| error())?;
    let data: Vec<A> = if layout.size() == 0 {
        (0..len).map(|_| A::zeroed()).collect()
    } else {
        // SAFETY: the layout has a non-zero size; a non-null block from `alloc_zeroed` of
        // `Layout::array::<A>(len)` is what `Vec::from_raw_parts` takes for capacity `len`, and
        // all-zero bytes are a valid `A` (`Zeroable`).
        unsafe {
            let p = std::alloc::alloc_zeroed(layout).cast::<A>();
            if p.is_null() {
                return Err(error());
            }
            Vec::from_raw_parts(p, len, len)
        }
    };
    Ok(ndarray::Array::from_shape_vec(shape, data).expect("the length is the shape's product"))
}

/// Blocks of this size and more are mapped from the kernel.
pub const LARGE: usize = 2 << 20;

/// Fixes glibc's thresholds for the blocks below [`LARGE`] (which [`LargeMapAlloc`] leaves to
/// it): served from the heaps, never mapped one by one, and kept when freed up to 2 x
/// [`LARGE`] at the top of a heap instead of handed back. glibc starts at 128 KiB for both and
/// raises them only after a large mapped block is freed, so a per-sample buffer of a few
/// hundred KiB on a worker thread was given back and faulted in again for every sample unless
/// some earlier 1 MiB buffer happened to raise them: 14,100 page faults against 1,800 in the
/// Table 4 run, 8 % of its CPU time zeroing pages. Also at most one heap (arena) per CPU,
/// not glibc's eight: a merge decodes job results on the pool's threads (and polars' own) and
/// frees them on its main thread, and the memory each of a dozen arenas kept made the resident
/// size of a merge grow with its jobs (170 MB for 300 tiny jobs, 186-212 MB for 1,200; with
/// one arena per CPU, 167 and 169 MB on the 2-core development VM). Call it at the start of
/// `main` (the binary and the benchmarks do); nothing elsewhere.
pub fn tune_malloc() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        // SAFETY: `mallopt` only sets allocator parameters; it is called before other threads.
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, LARGE as i32);
            libc::mallopt(libc::M_TRIM_THRESHOLD, 2 * LARGE as i32);
            libc::mallopt(libc::M_ARENA_MAX, cpus.clamp(1, 64) as i32);
        }
    }
}

/// Alignment every mapping has (the page size on every Linux target this tool supports).
const PAGE: usize = 4096;

/// The allocator; `#[global_allocator]` of the `isar-clutter` binary, the benchmarks and
/// `tests/alloc.rs` (a library does not choose its users' allocator).
pub struct LargeMapAlloc;

fn mapped(layout: &Layout) -> bool {
    cfg!(target_os = "linux") && layout.size() >= LARGE && layout.align() <= PAGE
}

#[cfg(target_os = "linux")]
unsafe fn map(size: usize) -> *mut u8 {
    // SAFETY: an anonymous private mapping has no preconditions; failure is checked.
    unsafe {
        let p = libc::mmap(
            std::ptr::null_mut(),
            size,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        );
        if p == libc::MAP_FAILED {
            return std::ptr::null_mut();
        }
        // Advice only: where huge pages are unavailable the call fails and nothing changes.
        libc::madvise(p, size, libc::MADV_HUGEPAGE);
        p.cast()
    }
}

#[cfg(not(target_os = "linux"))]
unsafe fn map(_size: usize) -> *mut u8 {
    unreachable!("`mapped` is false off Linux")
}

#[cfg(target_os = "linux")]
unsafe fn unmap(p: *mut u8, size: usize) {
    // SAFETY: `p` and `size` describe a mapping made by `map` (or moved by `remap`).
    unsafe {
        libc::munmap(p.cast(), size);
    }
}

#[cfg(not(target_os = "linux"))]
unsafe fn unmap(_p: *mut u8, _size: usize) {
    unreachable!("`mapped` is false off Linux")
}

#[cfg(target_os = "linux")]
unsafe fn remap(p: *mut u8, old: usize, new: usize) -> *mut u8 {
    // SAFETY: `p` and `old` describe a mapping made by `map`; failure is checked.
    unsafe {
        let q = libc::mremap(p.cast(), old, new, libc::MREMAP_MAYMOVE);
        if q == libc::MAP_FAILED {
            std::ptr::null_mut()
        } else {
            q.cast()
        }
    }
}

#[cfg(not(target_os = "linux"))]
unsafe fn remap(_p: *mut u8, _old: usize, _new: usize) -> *mut u8 {
    unreachable!("`mapped` is false off Linux")
}

// SAFETY: every block is either the system allocator's (and returned to it) or a private
// anonymous mapping of at least the requested size, page aligned (so aligned for any layout
// with alignment up to a page), zero when fresh, and unmapped exactly once; which of the two a
// block is follows from its layout alone, as `GlobalAlloc` passes the same layout back.
unsafe impl GlobalAlloc for LargeMapAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if mapped(&layout) {
            // SAFETY: size is non-zero (at least LARGE).
            let p = unsafe { map(layout.size()) };
            if !p.is_null() {
                count_mapped(layout.size(), 0);
            }
            p
        } else {
            // SAFETY: forwarded with the caller's guarantees.
            unsafe { System.alloc(layout) }
        }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if mapped(&layout) {
            // SAFETY: as in `alloc`; a fresh anonymous mapping reads as zero.
            let p = unsafe { map(layout.size()) };
            if !p.is_null() {
                count_mapped(layout.size(), 0);
            }
            p
        } else {
            // SAFETY: forwarded with the caller's guarantees.
            unsafe { System.alloc_zeroed(layout) }
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if mapped(&layout) {
            count_mapped(0, layout.size());
            // SAFETY: a block of this layout was made by `map`.
            unsafe { unmap(ptr, layout.size()) }
        } else {
            // SAFETY: a block of this layout was made by the system allocator.
            unsafe { System.dealloc(ptr, layout) }
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller guarantees new_size, rounded up to the alignment, does not overflow.
        let new = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        match (mapped(&layout), mapped(&new)) {
            // SAFETY: forwarded with the caller's guarantees.
            (false, false) => unsafe { System.realloc(ptr, layout, new_size) },
            (true, true) => {
                // SAFETY: the block was made by `map` with the old size.
                let q = unsafe { remap(ptr, layout.size(), new_size) };
                if !q.is_null() {
                    count_mapped(new_size, layout.size());
                }
                q
            }
            _ => {
                // SAFETY: `new` is a valid layout; on success the old block is copied
                // (the smaller of the two sizes) and released with its own layout.
                unsafe {
                    let q = self.alloc(new);
                    if !q.is_null() {
                        std::ptr::copy_nonoverlapping(ptr, q, layout.size().min(new_size));
                        self.dealloc(ptr, layout);
                    }
                    q
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_keep_their_contents_across_every_realloc_transition() {
        // Small -> large -> larger -> small, with a pattern checked at every step; large zeroed
        // blocks read as zero.
        let a = LargeMapAlloc;
        let small = Layout::from_size_align(1000, 8).unwrap();
        // SAFETY: layouts are non-zero; each pointer is used within its size and freed once
        // with the layout it was last given.
        unsafe {
            let p = a.alloc(small);
            assert!(!p.is_null());
            for i in 0..1000 {
                *p.add(i) = (i % 251) as u8;
            }
            let p = a.realloc(p, small, 3 << 20);
            let large = Layout::from_size_align(3 << 20, 8).unwrap();
            assert!(!p.is_null() && mapped(&large) == cfg!(target_os = "linux"));
            for i in 0..1000 {
                assert_eq!(*p.add(i), (i % 251) as u8);
            }
            *p.add((3 << 20) - 1) = 7;
            let p = a.realloc(p, large, 9 << 20);
            let larger = Layout::from_size_align(9 << 20, 8).unwrap();
            assert_eq!(*p.add((3 << 20) - 1), 7);
            assert_eq!(*p.add(999), (999 % 251) as u8);
            let p = a.realloc(p, larger, 500);
            for i in 0..500 {
                assert_eq!(*p.add(i), (i % 251) as u8);
            }
            a.dealloc(p, Layout::from_size_align(500, 8).unwrap());

            let z = Layout::from_size_align(8 << 20, 4096).unwrap();
            let q = a.alloc_zeroed(z);
            assert!(!q.is_null() && (q as usize).is_multiple_of(4096));
            assert!((0..8 << 20).step_by(4093).all(|i| *q.add(i) == 0));
            a.dealloc(q, z);
        }
    }
}

#[cfg(test)]
mod try_zeros_tests {
    use super::*;
    use num_complex::Complex64;

    #[test]
    fn zeros_come_back_in_the_shape_asked() {
        let a: ndarray::Array3<Complex64> = try_zeros((3, 4, 5), "a stack").unwrap();
        assert_eq!(a.dim(), (3, 4, 5));
        assert!(a.iter().all(|z| *z == Complex64::new(0.0, 0.0)));
        let empty: ndarray::Array2<f64> = try_zeros((0, 7), "nothing").unwrap();
        assert_eq!(empty.dim(), (0, 7));
    }

    #[test]
    fn an_impossible_allocation_is_an_error_naming_the_array() {
        // 2^50 complex values (16 PiB): no machine has them; the allocator says no.
        let e = try_zeros::<Complex64, _>((1 << 20, 1 << 15, 1 << 15), "the generated samples")
            .unwrap_err();
        assert_eq!(e.bytes, 1 << 54);
        let text = e.to_string();
        assert!(text.contains("the generated samples") && text.contains("18014398509481984"));
        // A size past usize overflows before anything is asked of the allocator.
        let e = try_zeros::<Complex64, _>((1 << 40, 1 << 40, 16), "stack").unwrap_err();
        assert_eq!(e.shape, vec![1 << 40, 1 << 40, 16]);
        // So does an empty array whose other axes ndarray cannot hold.
        let e = try_zeros::<Complex64, _>((0, 1 << 40, 1 << 40), "stack").unwrap_err();
        assert_eq!(e.shape, vec![0, 1 << 40, 1 << 40]);
    }
}
