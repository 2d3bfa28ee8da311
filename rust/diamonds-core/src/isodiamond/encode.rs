//! The byte encoding of an isodiamond hierarchy (Weiss & De Floriani §6.1, §7.2: 12 bytes per
//! isodiamond and one per isovertex there).
//!
//! Little-endian: the magic `ISODIAM1`; the target (0 isosurface, 1 interval volume), the model
//! (0 RI, 1 MI) and the number of rungs, one byte each; the grid (3 × u32 points, 3 × f64 origin,
//! 3 × f64 spacing); the level(s) and the rung tolerances as f64. Then the isodiamonds, sorted by
//! central vertex: their count, and per isodiamond the difference of its central vertex's lattice
//! key from the previous one (LEB128: one or two bytes where the surface is dense), one byte for
//! the central vertex's class (3 bits) and the type (2 bits), one byte of split bits. Then the
//! orphan vertices the same way (key difference, class), and the crossings, one byte each. So
//! about 3–4 bytes per isodiamond instead of 12, and the isovertices as the paper's.

use super::{Isodiamonds, Model, Record, Target, MAX_RUNGS};
use crate::volume::Grid;
use crate::{Error, Result};

const MAGIC: &[u8; 8] = b"ISODIAM1";

/// Appends `v` as LEB128.
fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Reads what [`Isodiamonds::to_bytes`] wrote, with a clear error where it ends early.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8]> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(Error::Isodiamonds(format!(
                "the data ends at byte {} (truncated)",
                self.bytes.len()
            )));
        };
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    fn u8(&mut self) -> Result<u8> {
        Ok(self.take(1)?[0])
    }

    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }

    fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    fn varint(&mut self) -> Result<u64> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.u8()?;
            v |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(Error::Isodiamonds(format!(
            "a number longer than 64 bits at byte {}",
            self.at
        )))
    }

    /// A count of items of at least `size` bytes each, refused when the data cannot hold them.
    fn count(&mut self, size: usize) -> Result<usize> {
        let n = self.varint()?;
        if n.saturating_mul(size as u64) > (self.bytes.len() - self.at) as u64 {
            return Err(Error::Isodiamonds(format!(
                "{n} items announced at byte {}, more than the data holds",
                self.at
            )));
        }
        Ok(n as usize)
    }

    /// Keys stored as differences from the previous one.
    fn key(&mut self, previous: &mut u64) -> Result<u64> {
        let k = previous.checked_add(self.varint()?).ok_or_else(|| {
            Error::Isodiamonds(format!("a vertex key overflows at byte {}", self.at))
        })?;
        *previous = k;
        Ok(k)
    }
}

impl Isodiamonds {
    /// The hierarchy as bytes (module [`encode`](self) documentation); its length is the
    /// hierarchy's storage size.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(
            64 + 4 * self.records.len() + 3 * self.orphans.len() + self.crossings.len(),
        );
        out.extend_from_slice(MAGIC);
        let (kind, levels) = match self.target {
            Target::Isosurface(v) => (0u8, vec![v]),
            Target::IntervalVolume(r) => (1u8, r.to_vec()),
        };
        out.push(kind);
        out.push((self.model == Model::Minimal) as u8);
        out.push(self.ladder.len() as u8);
        for d in self.grid.dims {
            out.extend_from_slice(&(d as u32).to_le_bytes());
        }
        for x in self.grid.origin.iter().chain(&self.grid.spacing) {
            out.extend_from_slice(&x.to_le_bytes());
        }
        for x in levels.iter().chain(&self.ladder) {
            out.extend_from_slice(&x.to_le_bytes());
        }
        varint(&mut out, self.records.len() as u64);
        let mut previous = 0;
        for r in &self.records {
            varint(&mut out, r.key - previous);
            previous = r.key;
            out.push(r.class | r.kind << 3);
            out.push(r.split);
        }
        varint(&mut out, self.orphans.len() as u64);
        let mut previous = 0;
        for &(k, class) in &self.orphans {
            varint(&mut out, k - previous);
            previous = k;
            out.push(class);
        }
        varint(&mut out, self.crossings.len() as u64);
        out.extend_from_slice(&self.crossings);
        out
    }

    /// Reads a hierarchy [`Isodiamonds::to_bytes`] wrote; anything else is a clear error.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        let mut r = Reader { bytes, at: 0 };
        if r.take(8).ok() != Some(&MAGIC[..]) {
            return Err(Error::Isodiamonds(
                "not an isodiamond hierarchy (the file does not start with ISODIAM1)".into(),
            ));
        }
        let kind = r.u8()?;
        let model = match r.u8()? {
            0 => Model::Relevant,
            1 => Model::Minimal,
            m => return Err(Error::Isodiamonds(format!("unknown model {m}"))),
        };
        let rungs = r.u8()? as usize;
        if rungs == 0 || rungs > MAX_RUNGS {
            return Err(Error::Isodiamonds(format!("{rungs} rungs")));
        }
        let mut dims = [0usize; 3];
        for d in &mut dims {
            *d = r.u32()? as usize;
        }
        let mut grid = Grid::new(dims);
        for x in grid.origin.iter_mut().chain(grid.spacing.iter_mut()) {
            *x = r.f64()?;
        }
        let target = match kind {
            0 => Target::Isosurface(r.f64()?),
            1 => Target::IntervalVolume([r.f64()?, r.f64()?]),
            k => return Err(Error::Isodiamonds(format!("unknown target {k}"))),
        };
        let ladder = (0..rungs).map(|_| r.f64()).collect::<Result<Vec<_>>>()?;
        let n = r.count(3)?;
        let mut records = Vec::with_capacity(n);
        let mut previous = 0;
        for _ in 0..n {
            let key = r.key(&mut previous)?;
            let byte = r.u8()?;
            let split = r.u8()?;
            records.push(Record {
                key,
                class: byte & 7,
                kind: byte >> 3,
                split,
            });
        }
        let n = r.count(2)?;
        let mut orphans = Vec::with_capacity(n);
        let mut previous = 0;
        for _ in 0..n {
            let key = r.key(&mut previous)?;
            orphans.push((key, r.u8()?));
        }
        let n = r.count(1)?;
        let crossings = r.take(n)?.to_vec();
        if r.at != bytes.len() {
            return Err(Error::Isodiamonds(format!(
                "{} bytes after the end",
                bytes.len() - r.at
            )));
        }
        let h = Self::new(grid, target, model, ladder, records, orphans, crossings)?;
        if h.points.is_empty() && !h.crossing_edges().is_empty() {
            return Err(Error::Isodiamonds("the crossings are missing".into()));
        }
        Ok(h)
    }
}
