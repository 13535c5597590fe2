//! External-memory cache for `A_r` (`reverse-photon-mapping.md` §6.5): reverse photons spill to
//! one file in a temporary directory, in coherent pages, and come back chunk by chunk.
//!
//! The paper keeps `A_r` and `A_w` on disk behind an 8-way software cache of 1 MiB blocks, relying
//! on the coherent order of the kd-tree build and of the searches. Here the coherence is made when
//! writing: every reverse photon goes to one of `8^L` spatial buckets (the top `3L` bits of its
//! Morton code in the scene's bounds), each bucket fills an in-memory page of [`Spill::page`]
//! reverse photons, and a full page is appended to the file (32 bytes per reverse photon, little
//! endian). Reading visits the buckets in Morton order and each bucket's pages in write order, so a
//! chunk is a compact region of space — the reverse photon map built over it is searched only by
//! the photons near it. `A_w` never reaches the disk: the completion (§5.2) is done per chunk,
//! right after its density estimation, so `A_w` exists for one chunk at a time.
//!
//! Any partition of `A_r` into chunks gives the same sums per gather ray (each is searched against
//! all photons), so a spilled render equals an in-memory one up to the order of the per-pixel sums.
//! The directory is removed when the [`Spill`] is dropped, and by the program's signal handler
//! ([`crate::io::temporaries`]); I/O errors name the file.

use super::reverse::ReversePhoton;
use crate::error::{Error, Result};
use glam::Vec3;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Bytes of one reverse photon on disk.
const RECORD: usize = 32;
/// The paper's block: 2^20 bytes = 32 768 reverse photons.
pub const MAX_PAGE: usize = (1 << 20) / RECORD;
/// Deepest bucket level: 8^3 = 512 buckets.
const MAX_LEVEL: u32 = 3;

/// `A_r` on disk.
pub struct Spill {
    _dir: crate::io::temporaries::TempDir,
    path: PathBuf,
    file: File,
    /// Reverse photons per page.
    page: usize,
    level: u32,
    lo: Vec3,
    scale: Vec3,
    /// Per bucket: the page being filled.
    buffers: Vec<Vec<ReversePhoton>>,
    /// Per bucket: (file offset, reverse photons) of its written pages.
    pages: Vec<Vec<(u64, u32)>>,
    end: u64,
    len: u64,
}

impl Spill {
    /// A spill file in a new temporary directory inside `dir`, for about `expected` reverse photons
    /// in the box `bounds`, read back in chunks of about `chunk`, with at most `buffer_bytes` of
    /// page buffers in memory.
    pub fn new(dir: &Path, bounds: (Vec3, Vec3), expected: u64, chunk: usize, buffer_bytes: u64) -> Result<Spill> {
        // registered for removal on SIGINT/SIGTERM/SIGHUP; a dead process's is removed by the next
        let tmp = crate::io::temporaries::create_dir(dir, "raysplat-spill-", "")?;
        let path = tmp.path().join("a_r.bin");
        let file = File::options().read(true).write(true).create_new(true).open(&path).map_err(|e| Error::io(&path, e))?;
        // Enough buckets that one holds about one chunk.
        let mut level = 0;
        while level < MAX_LEVEL && expected > (chunk.max(1) as u64) << (3 * level) {
            level += 1;
        }
        let buckets = 1usize << (3 * level);
        let page = ((buffer_bytes / (buckets * RECORD) as u64) as usize).clamp(16, MAX_PAGE);
        let (lo, hi) = bounds;
        let cells = (1u32 << level) as f32;
        let scale = Vec3::splat(cells) / (hi - lo).max(Vec3::splat(1e-30));
        Ok(Spill {
            _dir: tmp,
            path,
            file,
            page,
            level,
            lo,
            scale,
            buffers: vec![Vec::new(); buckets],
            pages: vec![Vec::new(); buckets],
            end: 0,
            len: 0,
        })
    }

    /// The temporary directory holding the spill file (removed when the spill is dropped).
    pub fn dir(&self) -> &Path {
        self._dir.path()
    }

    /// Reverse photons per page.
    pub fn page(&self) -> usize {
        self.page
    }

    /// Spatial buckets.
    pub fn buckets(&self) -> usize {
        self.buffers.len()
    }

    /// Reverse photons written.
    pub fn len(&self) -> u64 {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bytes on disk.
    pub fn file_bytes(&self) -> u64 {
        self.end
    }

    /// Memory of the page buffers, when full.
    pub fn buffer_bytes(&self) -> u64 {
        (self.buffers.len() * self.page * RECORD) as u64
    }

    fn bucket(&self, p: Vec3) -> usize {
        let n = (1u32 << self.level) - 1;
        let c = ((p - self.lo) * self.scale).clamp(Vec3::ZERO, Vec3::splat(n as f32));
        let (x, y, z) = (c.x as u32, c.y as u32, c.z as u32);
        let mut code = 0usize;
        for b in (0..self.level).rev() {
            code = code << 3 | (((x >> b) & 1) | ((y >> b) & 1) << 1 | ((z >> b) & 1) << 2) as usize;
        }
        code
    }

    /// Add reverse photons (kept in this order within their bucket).
    pub fn push(&mut self, rps: &[ReversePhoton]) -> Result<()> {
        for rp in rps {
            let b = self.bucket(rp.pos());
            if self.buffers[b].capacity() == 0 {
                self.buffers[b].reserve_exact(self.page);
            }
            self.buffers[b].push(*rp);
            if self.buffers[b].len() == self.page {
                self.flush(b)?;
            }
        }
        self.len += rps.len() as u64;
        Ok(())
    }

    fn flush(&mut self, b: usize) -> Result<()> {
        let buf = &self.buffers[b];
        if buf.is_empty() {
            return Ok(());
        }
        let mut bytes = Vec::with_capacity(buf.len() * RECORD);
        for rp in buf {
            bytes.extend_from_slice(&encode(rp));
        }
        self.file.seek(SeekFrom::Start(self.end)).and_then(|_| self.file.write_all(&bytes)).map_err(|e| Error::io(&self.path, e))?;
        self.pages[b].push((self.end, buf.len() as u32));
        self.end += bytes.len() as u64;
        self.buffers[b].clear();
        Ok(())
    }

    /// Write the partly filled pages and free the buffers.
    pub fn finish(&mut self) -> Result<()> {
        for b in 0..self.buffers.len() {
            self.flush(b)?;
            self.buffers[b] = Vec::new();
        }
        Ok(())
    }

    /// Hand all reverse photons back in chunks of at most `chunk` (buckets in Morton order, pages in
    /// write order), reading one chunk at a time. Call [`finish`](Self::finish) first.
    pub fn for_each_chunk(&mut self, chunk: usize, mut f: impl FnMut(&mut Vec<ReversePhoton>) -> Result<()>) -> Result<()> {
        let chunk = chunk.max(1);
        let mut out: Vec<ReversePhoton> = Vec::with_capacity(chunk);
        let mut bytes = vec![0u8; self.page * RECORD];
        let pages: Vec<(u64, u32)> = self.pages.iter().flatten().copied().collect();
        for (offset, count) in pages {
            let n = count as usize;
            let buf = &mut bytes[..n * RECORD];
            self.file.seek(SeekFrom::Start(offset)).and_then(|_| self.file.read_exact(buf)).map_err(|e| Error::io(&self.path, e))?;
            for rec in buf.chunks_exact(RECORD) {
                out.push(decode(rec));
                if out.len() == chunk {
                    f(&mut out)?;
                    out.clear();
                }
            }
        }
        if !out.is_empty() {
            f(&mut out)?;
        }
        Ok(())
    }
}

fn encode(rp: &ReversePhoton) -> [u8; RECORD] {
    let mut b = [0u8; RECORD];
    for (i, v) in rp.p.iter().chain(&rp.weight).enumerate() {
        b[4 * i..4 * i + 4].copy_from_slice(&v.to_le_bytes());
    }
    b[24..26].copy_from_slice(&rp.n.to_le_bytes());
    b[26..28].copy_from_slice(&rp.wi.to_le_bytes());
    b[28..32].copy_from_slice(&rp.pixel.to_le_bytes());
    b
}

fn decode(b: &[u8]) -> ReversePhoton {
    let f = |i: usize| f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]);
    ReversePhoton {
        p: [f(0), f(1), f(2)],
        weight: [f(3), f(4), f(5)],
        n: u16::from_le_bytes([b[24], b[25]]),
        wi: u16::from_le_bytes([b[26], b[27]]),
        pixel: u32::from_le_bytes([b[28], b[29], b[30], b[31]]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn random(n: usize) -> Vec<ReversePhoton> {
        let mut rng = Rng::new(3, 0);
        (0..n)
            .map(|i| ReversePhoton {
                p: [rng.next_f32() * 4.0 - 2.0, rng.next_f32(), rng.next_f32() * 3.0],
                weight: [rng.next_f32(), -rng.next_f32(), 1e-30],
                n: (rng.next_u32() & 0xffff) as u16,
                wi: (rng.next_u32() & 0xffff) as u16,
                pixel: i as u32,
            })
            .collect()
    }

    /// Every reverse photon comes back exactly once, bit for bit, bucket by bucket (spatially
    /// coherent chunks), and the directory is removed afterwards.
    #[test]
    fn spilled_reverse_photons_come_back_exactly_once_in_buckets() {
        let parent = tempfile::tempdir().unwrap();
        let rps = random(20_000);
        let bounds = (Vec3::new(-2.0, 0.0, 0.0), Vec3::new(2.0, 1.0, 3.0));
        let mut s = Spill::new(parent.path(), bounds, rps.len() as u64, 1000, 64 << 10).unwrap();
        assert!(s.buckets() > 1 && s.page() >= 16);
        for part in rps.chunks(777) {
            s.push(part).unwrap();
        }
        s.finish().unwrap();
        assert_eq!(s.len(), rps.len() as u64);
        assert_eq!(s.file_bytes(), rps.len() as u64 * 32);
        let mut back = Vec::new();
        let mut buckets_seen = Vec::new();
        s.for_each_chunk(1000, |c| {
            assert!(c.len() <= 1000);
            for rp in c.iter() {
                let b = s_bucket(bounds, 1 << s_level(rps.len(), 1000), rp.pos());
                if buckets_seen.last() != Some(&b) {
                    buckets_seen.push(b);
                }
            }
            back.extend_from_slice(c);
            Ok(())
        })
        .unwrap();
        // Buckets arrive in order, each in one run.
        assert!(buckets_seen.windows(2).all(|w| w[0] < w[1]), "buckets out of order");
        back.sort_by_key(|rp| rp.pixel);
        assert_eq!(back, rps);
        let dir = s._dir.path().to_path_buf();
        assert!(dir.exists());
        drop(s);
        assert!(!dir.exists(), "spill directory left behind");
    }

    fn s_level(n: usize, chunk: usize) -> u32 {
        let mut level = 0;
        while level < MAX_LEVEL && n as u64 > (chunk as u64) << (3 * level) {
            level += 1;
        }
        level
    }

    /// The bucket's Morton index, recomputed independently.
    fn s_bucket(bounds: (Vec3, Vec3), cells: u32, p: Vec3) -> usize {
        let c = ((p - bounds.0) * (Vec3::splat(cells as f32) / (bounds.1 - bounds.0))).clamp(Vec3::ZERO, Vec3::splat(cells as f32 - 1.0));
        let (x, y, z) = (c.x as usize, c.y as usize, c.z as usize);
        let mut code = 0;
        for b in 0..16 {
            code |= ((x >> b) & 1) << (3 * b) | ((y >> b) & 1) << (3 * b + 1) | ((z >> b) & 1) << (3 * b + 2);
        }
        code
    }

    #[test]
    fn an_unwritable_directory_is_an_error_naming_it() {
        let e = Spill::new(Path::new("/nonexistent/raysplat"), (Vec3::ZERO, Vec3::ONE), 10, 10, 1 << 20).err().unwrap();
        assert!(e.to_string().contains("/nonexistent/raysplat"), "{e}");
    }
}
