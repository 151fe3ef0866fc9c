//! Streaming generated samples into a `.npy` while the next ones are generated: two blocks in
//! turn (the caller's rayon pool fills one while a writer thread writes the other), the file
//! opened with `O_DIRECT` where the file system allows it, so that the bytes go from the
//! blocks to the device without being copied into the page cache.
//!
//! Why direct I/O: on the development VM, copying a new file's bytes into the page cache runs
//! at about 0.4 GB/s once the guest's free memory has been handed back to the host (every
//! fresh page costs the host a fault), 1.7 s for 20,000 samples of 64 x 64, more than
//! generating them; `O_DIRECT` writes the same 640 MiB in 0.45 s and costs the guest's CPU
//! nothing (BENCHMARKS.md). Direct writes need offsets, lengths and memory aligned to 4 KiB:
//! each block starts with the bytes of the previous block that did not fill a 4 KiB page (the
//! first with the `.npy` header), only whole pages are written, and the last partial page is
//! written after `O_DIRECT` is turned off. Where the file system refuses `O_DIRECT`
//! (`EINVAL`), or with `buffered`, the same blocks are written through the page cache.

use anyhow::{Context, Result};
use num_complex::Complex32;
use std::fs::File;
use std::io::{Seek, Write};
use std::path::Path;

/// Bytes per page of direct I/O: offsets, lengths and memory are multiples of it.
const PAGE: usize = 4096;

/// A page of memory aligned for direct I/O.
#[derive(Clone, Copy)]
#[repr(C, align(4096))]
struct Page([u8; PAGE]);

// SAFETY: a page is plain bytes, any bit pattern is valid and there is no padding.
unsafe impl bytemuck::Zeroable for Page {}
// SAFETY: as above; `Page` is `Copy` and `'static`.
unsafe impl bytemuck::Pod for Page {}

/// A block: page-aligned memory holding the bytes carried over from the previous block (the
/// part of a page it did not fill; the first block: the header), then samples.
struct Block {
    pages: Vec<Page>,
}

impl Block {
    fn new(bytes: usize) -> Result<Self> {
        // Zeroed by the allocator (a fresh mapping for big blocks), not touched here.
        let pages = crate::alloc::try_zeros::<Page, _>(
            bytes.div_ceil(PAGE),
            "a block of generated samples",
        )?;
        Ok(Block {
            pages: pages.into_raw_vec_and_offset().0,
        })
    }

    fn bytes(&mut self) -> &mut [u8] {
        bytemuck::cast_slice_mut(&mut self.pages)
    }
}

/// How the file is written: through the page cache, or directly (then `O_DIRECT` is set).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WriteMode {
    /// `O_DIRECT` where the file system allows it, else buffered.
    Direct,
    /// Through the page cache.
    Buffered,
}

/// Writes `header` then `samples` samples of `plane` complex64 values into `tmp` (a new file),
/// `chunk` samples per block; `generate(first, out)` fills samples `first ..` into `out`
/// (whole samples) and `progress` hears the number generated so far. Returns the mode used.
///
/// # Errors
/// If a block does not fit in memory, or the file cannot be created or written.
pub fn write_samples(
    tmp: &Path,
    header: &[u8],
    (samples, plane, chunk): (usize, usize, usize),
    mode: WriteMode,
    generate: impl Fn(usize, &mut [Complex32]) + Sync,
    progress: impl Fn(usize),
) -> Result<WriteMode> {
    let (mut file, direct) = open(tmp, mode)?;
    let chunk = chunk.max(1).min(samples.max(1));
    let sample_bytes = plane * 8;
    // Room for a carried-over partial page (or the header) before the samples.
    let block_bytes = PAGE.max(header.len() + 8) + chunk * sample_bytes;
    let blocks = samples.div_ceil(chunk).clamp(1, 2);
    let (to_writer, written) = std::sync::mpsc::sync_channel::<(Block, usize, bool)>(1);
    let (to_generator, free) = std::sync::mpsc::channel::<Block>();
    for _ in 0..blocks {
        to_generator
            .send(Block::new(block_bytes)?)
            .expect("the receiver is alive");
    }
    let align = if direct { PAGE } else { 1 };
    std::thread::scope(|scope| -> Result<()> {
        let writer = scope.spawn(move || -> Result<()> {
            for (mut block, len, last) in written {
                let whole = len / align * align;
                let bytes = &block.bytes()[..whole];
                let start = file.stream_position()?;
                match file.write_all(bytes) {
                    // A file system that takes the flag but refuses the writes: the rest of the
                    // bytes through the page cache, from where the refused write stopped.
                    Err(e) if direct && e.raw_os_error() == Some(libc::EINVAL) => {
                        let written = (file.stream_position()? - start) as usize;
                        set_direct(&file, false)?;
                        file.write_all(&bytes[written..])?;
                    }
                    other => other?,
                }
                if last && whole < len {
                    set_direct(&file, false)?;
                    file.write_all(&block.bytes()[whole..len])?;
                }
                // The generator may have stopped (an error): nothing to return the block to.
                let _ = to_generator.send(block);
            }
            Ok(())
        });
        let mut done = 0;
        let mut carried: Vec<u8> = header.to_vec();
        while let Ok(mut block) = free.recv() {
            let count = chunk.min(samples - done);
            let lead = carried.len();
            block.bytes()[..lead].copy_from_slice(&carried);
            let len = lead + count * sample_bytes;
            let values: &mut [Complex32] = bytemuck::cast_slice_mut(&mut block.bytes()[lead..len]);
            generate(done, values);
            done += count;
            let last = done == samples;
            let whole = len / align * align;
            carried.clear();
            if !last {
                carried.extend_from_slice(&block.bytes()[whole..len]);
            }
            if to_writer.send((block, len, last)).is_err() {
                break;
            }
            progress(done);
            if last {
                break;
            }
        }
        drop(to_writer);
        writer.join().expect("the writer does not panic")
    })
    .with_context(|| format!("cannot write {}", tmp.display()))?;
    Ok(if direct {
        WriteMode::Direct
    } else {
        WriteMode::Buffered
    })
}

/// Creates `path`, with `O_DIRECT` if `mode` asks for it and the file system allows it.
fn open(path: &Path, mode: WriteMode) -> Result<(File, bool)> {
    let create = || {
        File::options()
            .write(true)
            .create_new(true)
            .open(path)
            .with_context(|| format!("cannot create {}", path.display()))
    };
    let file = create()?;
    if mode == WriteMode::Direct && set_direct(&file, true).is_ok() {
        return Ok((file, true));
    }
    Ok((file, false))
}

/// Turns `O_DIRECT` on or off for an open file.
///
/// # Errors
/// If the file system refuses it (e.g. `EINVAL` on tmpfs), or on platforms without it.
fn set_direct(file: &File, on: bool) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        let fd = file.as_raw_fd();
        // SAFETY: `fd` is an open descriptor owned by `file` for the duration of the calls.
        let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
        if flags < 0 {
            return Err(std::io::Error::last_os_error());
        }
        let flags = if on {
            flags | libc::O_DIRECT
        } else {
            flags & !libc::O_DIRECT
        };
        // SAFETY: as above.
        if unsafe { libc::fcntl(fd, libc::F_SETFL, flags) } < 0 {
            return Err(std::io::Error::last_os_error());
        }
        Ok(())
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = (file, on);
        Err(std::io::Error::from(std::io::ErrorKind::Unsupported))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every size around the page boundaries gives the same bytes in both modes: the header,
    /// then each sample's values in order (here sample s, value v = s * 1000 + v).
    #[test]
    fn direct_and_buffered_files_hold_the_same_bytes() {
        let dir = std::env::temp_dir().join(format!("isar-stream-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let header = vec![7u8; 128];
        for (samples, plane, chunk) in [
            (1, 1, 1),
            (5, 3, 2),
            (37, 512, 8),
            (9, 4096, 4),
            (3, 100, 10),
        ] {
            let want: Vec<u8> = header
                .iter()
                .copied()
                .chain((0..samples * plane).flat_map(|i| {
                    let v = Complex32::new(i as f32, -(i as f32));
                    bytemuck::bytes_of(&v).to_vec()
                }))
                .collect();
            for mode in [WriteMode::Direct, WriteMode::Buffered] {
                let path = dir.join(format!("s{samples}-{plane}-{chunk}-{mode:?}.npy"));
                let _ = std::fs::remove_file(&path);
                write_samples(
                    &path,
                    &header,
                    (samples, plane, chunk),
                    mode,
                    |first, out| {
                        for (i, v) in out.iter_mut().enumerate() {
                            let x = (first * plane + i) as f32;
                            *v = Complex32::new(x, -x);
                        }
                    },
                    |_| {},
                )
                .unwrap();
                assert_eq!(
                    std::fs::read(&path).unwrap(),
                    want,
                    "{samples} x {plane} / {chunk} {mode:?}"
                );
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
