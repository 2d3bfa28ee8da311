//! Progressive transmission (§4): a [`ProgressiveMesh`] as a byte stream, the base mesh first, then
//! one record per vertex split from level 0 up, so that any prefix decodes to a valid level (the last
//! complete split's). Points and tetrahedra are numbered in stream order (the base mesh's, then one
//! new point and the split's new tetrahedra per split); a split names its target point `j`, the
//! tetrahedra that move to the new point `i` (T_moved) and the corners of the new ones (T_new).
//!
//! Both ends keep the tetrahedra around each point ([`Stars`]), so a split names its tetrahedra and
//! points relative to `j`: T_moved as a bit mask over the tetrahedra around `j` (ascending), each
//! tetrahedron of T_new (around the edge `ij`) as the slots of `i` and `j` in its corners and its two
//! other corners as indices among `j`'s neighbours (ascending) — one byte each where absolute
//! numbers took three. A split's new point is written as the bits of its coordinates and values XOR
//! those of its target (neighbours: the leading bytes cancel, which the compressor then finds).
//! Nothing about the mesh is quantised; only the per-level RMS error is stored as `f32` (the maximum
//! is exact, written only when it changes).
//!
//! Layout, little-endian, integers as LEB128 varints: the magic `DPM2`; the numbers of original points
//! and tetrahedra and of splits; the point arrays (name, components, caller's type tag, 4 or 8 bytes
//! per value: 4 when every value is exact as `f32`) and the width of the coordinates (likewise); then
//! the base mesh (its errors as two `f64`, points with their values, tetrahedra as point numbers) and
//! the splits: target `j`, the new point with its values (XOR `j`'s), the T_moved mask (`⌈|star(j)| / 8⌉` bytes),
//! the number of new tetrahedra and for each a byte `slot(i) | slot(j) << 2` and the two neighbour
//! indices, then a byte (1 if the maximum error changed, followed by it as `f64`) and the RMS error
//! as `f32`.

use super::record::{ProgressiveMesh, Replay};
use crate::{Error, Result};
use std::io::{ErrorKind, Read, Write};

const MAGIC: &[u8; 4] = b"DPM2";

/// A point array carried through the stream: `components` values per point, as `f64` (exact for every
/// type up to 32 bits), and the caller's tag of its value type, kept as is.
#[derive(Clone, Debug, PartialEq)]
pub struct PointArray {
    pub name: String,
    pub components: usize,
    pub type_tag: u8,
    pub values: Vec<f64>,
}

/// A level decoded from a stream.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded {
    pub points: Vec<[f64; 3]>,
    /// Tetrahedra as indices into `points`, positively oriented.
    pub tets: Vec<[u32; 4]>,
    /// The point arrays at `points`.
    pub arrays: Vec<PointArray>,
    /// The level reached (0 = base mesh).
    pub level: usize,
    /// The number of splits the stream announces (the original's level).
    pub levels: usize,
    /// The maximum and RMS field error of the level, as recorded by the encoder.
    pub max_field_error: f64,
    pub rms_field_error: f64,
    /// The original's numbers of points and tetrahedra.
    pub original_points: usize,
    pub original_tets: usize,
}

fn io_error(e: std::io::Error) -> Error {
    Error::Stream(e.to_string())
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    loop {
        let byte = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            out.push(byte);
            return;
        }
        out.push(byte | 0x80);
    }
}

/// The tetrahedra of a level in stream numbering with the tetrahedra around each point, kept alike
/// by the encoder and the decoder (a split's record is relative to its target's star).
#[derive(Default)]
struct Stars {
    tets: Vec<[u32; 4]>,
    star: Vec<Vec<u32>>,
}

impl Stars {
    fn add_point(&mut self) {
        self.star.push(Vec::new());
    }

    fn add_tet(&mut self, c: [u32; 4]) {
        let t = self.tets.len() as u32;
        for v in c {
            self.star[v as usize].push(t);
        }
        self.tets.push(c);
    }

    /// The tetrahedra around `j`, ascending.
    fn sorted_star(&self, j: u32) -> Vec<u32> {
        let mut s = self.star[j as usize].clone();
        s.sort_unstable();
        s
    }

    /// The points adjacent to `j`, ascending.
    fn neighbours(&self, j: u32) -> Vec<u32> {
        let mut n: Vec<u32> = self.star[j as usize]
            .iter()
            .flat_map(|&t| self.tets[t as usize])
            .filter(|&v| v != j)
            .collect();
        n.sort_unstable();
        n.dedup();
        n
    }

    /// Moves the tetrahedron `t` from its corner `j` to the point `i`.
    fn move_tet(&mut self, t: u32, j: u32, i: u32) {
        if let Some(c) = self.tets[t as usize].iter_mut().find(|c| **c == j) {
            *c = i;
        }
        self.star[j as usize].retain(|&o| o != t);
        self.star[i as usize].push(t);
    }
}

/// Is every value exact as `f32`?
fn f32_exact(values: impl IntoIterator<Item = f64>) -> bool {
    values.into_iter().all(|v| (v as f32) as f64 == v)
}

/// Writes `v` as the bits of its `f64` (`wide`) or `f32` XOR those of the reference `r` (0 for none):
/// a new point's coordinates and values are close to its target's, so the high bytes, sign, exponent
/// and leading mantissa, mostly cancel and the compressor finds zeros (lossless either way).
fn put_value(out: &mut Vec<u8>, v: f64, r: f64, wide: bool) {
    if wide {
        out.extend_from_slice(&(v.to_bits() ^ r.to_bits()).to_le_bytes());
    } else {
        out.extend_from_slice(&((v as f32).to_bits() ^ (r as f32).to_bits()).to_le_bytes());
    }
}

/// Writes `pm` with its point arrays (one tuple per original point) to `out`; returns the bytes
/// written.
pub fn encode(pm: &ProgressiveMesh, arrays: &[PointArray], out: &mut impl Write) -> Result<u64> {
    let n_points = pm.points.len();
    for a in arrays {
        if a.components == 0 || a.values.len() != a.components * n_points {
            return Err(Error::Parameter(format!(
                "point array '{}' has {} values for {n_points} points of {} components",
                a.name,
                a.values.len(),
                a.components
            )));
        }
    }
    let mut buf = Vec::new();
    buf.extend_from_slice(MAGIC);
    for n in [n_points, pm.tets.len(), pm.levels(), arrays.len()] {
        put_varint(&mut buf, n as u64);
    }
    let wide: Vec<bool> = arrays
        .iter()
        .map(|a| !f32_exact(a.values.iter().copied()))
        .collect();
    for (a, &w) in arrays.iter().zip(&wide) {
        put_varint(&mut buf, a.name.len() as u64);
        buf.extend_from_slice(a.name.as_bytes());
        put_varint(&mut buf, a.components as u64);
        buf.extend_from_slice(&[a.type_tag, if w { 8 } else { 4 }]);
    }
    let wide_points = !f32_exact(pm.points.iter().flatten().copied());
    buf.push(if wide_points { 8 } else { 4 });
    // A point relative to the original point `reference` (a split's target), if any.
    let put_point = |buf: &mut Vec<u8>, v: u32, reference: Option<u32>| {
        let at = |p: &[f64; 3], k: usize| reference.map_or(0.0, |_| p[k]);
        let rp = pm.points[reference.unwrap_or(v) as usize];
        for (k, c) in pm.points[v as usize].into_iter().enumerate() {
            put_value(buf, c, at(&rp, k), wide_points);
        }
        for (a, &w) in arrays.iter().zip(&wide) {
            let (k, rk) = (
                v as usize * a.components,
                reference.unwrap_or(v) as usize * a.components,
            );
            for c in 0..a.components {
                let r = reference.map_or(0.0, |_| a.values[rk + c]);
                put_value(buf, a.values[k + c], r, w);
            }
        }
    };
    let mut point_id = vec![u32::MAX; n_points];
    let mut tet_id = vec![u32::MAX; pm.tets.len()];
    let mut stars = Stars::default();
    let mut replay = Replay::new(pm);
    replay.set_level(pm, 0);
    let base = replay.mesh(n_points);
    let e = pm.error(0);
    buf.extend_from_slice(&e.max_field_error.to_le_bytes());
    buf.extend_from_slice(&e.rms_field_error.to_le_bytes());
    let mut last_max = e.max_field_error;
    put_varint(&mut buf, base.point_ids.len() as u64);
    for &v in &base.point_ids {
        point_id[v as usize] = stars.star.len() as u32;
        stars.add_point();
        put_point(&mut buf, v, None);
    }
    put_varint(&mut buf, base.tets.len() as u64);
    for (t, c) in replay.live_tets() {
        tet_id[t as usize] = stars.tets.len() as u32;
        let c = c.map(|v| point_id[v as usize]);
        for v in c {
            put_varint(&mut buf, v as u64);
        }
        stars.add_tet(c);
    }
    let inconsistent = |level: usize| {
        Error::Stream(format!(
            "split {level} does not match the mesh it applies to"
        ))
    };
    let mut written = 0u64;
    for level in 0..pm.levels() {
        let s = pm.split(level);
        let j = point_id[s.target as usize];
        put_varint(&mut buf, j as u64);
        let i = stars.star.len() as u32;
        point_id[s.vertex as usize] = i;
        stars.add_point();
        put_point(&mut buf, s.vertex, Some(s.target));
        // T_moved as a mask over the star of j.
        let star = stars.sorted_star(j);
        let mut mask = vec![0u8; star.len().div_ceil(8)];
        for &t in &s.moved {
            let k = star
                .binary_search(&tet_id[t as usize])
                .map_err(|_| inconsistent(level))?;
            mask[k / 8] |= 1 << (k % 8);
        }
        buf.extend_from_slice(&mask);
        let neighbours = stars.neighbours(j);
        for &t in &s.moved {
            stars.move_tet(tet_id[t as usize], j, i);
        }
        replay.set_level(pm, level + 1);
        put_varint(&mut buf, s.removed.len() as u64);
        for &t in &s.removed {
            tet_id[t as usize] = stars.tets.len() as u32;
            let c = replay.corners(t).map(|v| point_id[v as usize]);
            let (Some(si), Some(sj)) = (
                c.iter().position(|&v| v == i),
                c.iter().position(|&v| v == j),
            ) else {
                return Err(inconsistent(level));
            };
            buf.push((si | sj << 2) as u8);
            for (k, &v) in c.iter().enumerate() {
                if k != si && k != sj {
                    let n = neighbours
                        .binary_search(&v)
                        .map_err(|_| inconsistent(level))?;
                    put_varint(&mut buf, n as u64);
                }
            }
            stars.add_tet(c);
        }
        let e = pm.error(level + 1);
        if e.max_field_error.to_bits() == last_max.to_bits() {
            buf.push(0);
        } else {
            buf.push(1);
            buf.extend_from_slice(&e.max_field_error.to_le_bytes());
            last_max = e.max_field_error;
        }
        buf.extend_from_slice(&(e.rms_field_error as f32).to_le_bytes());
        if buf.len() > 1 << 20 {
            out.write_all(&buf).map_err(io_error)?;
            written += buf.len() as u64;
            buf.clear();
        }
    }
    out.write_all(&buf).map_err(io_error)?;
    Ok(written + buf.len() as u64)
}

/// Reads a stream written by [`encode`].
struct Reader<R> {
    input: R,
}

/// `Ok(None)` at the end of the input (a truncated stream), `Err` for a read error.
type Step<T> = Result<Option<T>>;

impl<R: Read> Reader<R> {
    fn bytes<const N: usize>(&mut self) -> Step<[u8; N]> {
        let mut b = [0u8; N];
        match self.input.read_exact(&mut b) {
            Ok(()) => Ok(Some(b)),
            Err(e) if e.kind() == ErrorKind::UnexpectedEof => Ok(None),
            Err(e) => Err(io_error(e)),
        }
    }

    fn varint(&mut self) -> Step<u64> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let Some([b]) = self.bytes::<1>()? else {
                return Ok(None);
            };
            v |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return Ok(Some(v));
            }
        }
        Err(Error::Stream("a number is longer than 64 bits".into()))
    }

    /// A value written by [`put_value`] with the reference `r`.
    fn value(&mut self, wide: bool, r: f64) -> Step<f64> {
        Ok(if wide {
            self.bytes::<8>()?
                .map(|b| f64::from_bits(u64::from_le_bytes(b) ^ r.to_bits()))
        } else {
            self.bytes::<4>()?
                .map(|b| f32::from_bits(u32::from_le_bytes(b) ^ (r as f32).to_bits()) as f64)
        })
    }
}

/// Unwraps a step inside a function returning `Step`: the end of the input ends it.
macro_rules! next {
    ($e:expr) => {
        match $e? {
            Some(v) => v,
            None => return Ok(None),
        }
    };
}

/// An index below `bound`, else a stream error naming `what`.
fn index(v: u64, bound: usize, what: &str) -> Result<u32> {
    if v < bound as u64 {
        Ok(v as u32)
    } else {
        Err(Error::Stream(format!(
            "{what} {v} out of range (only {bound} so far)"
        )))
    }
}

/// One vertex split as read: the new point, the tetrahedra moving to it, the new tetrahedra and the
/// level's maximum and RMS field errors.
struct SplitRecord {
    vertex: u32,
    moved: Vec<u32>,
    new: Vec<[u32; 4]>,
    errors: (f64, f64),
}

/// The state of a decoder.
struct Decoder {
    out: Decoded,
    wide: Vec<bool>,
    wide_points: bool,
    /// The current level's tetrahedra and stars (`out.tets` is filled from it at the end).
    stars: Stars,
}

impl Decoder {
    /// Reads a point written relative to the point `reference` (a split's target), if any.
    fn point<R: Read>(&mut self, r: &mut Reader<R>, reference: Option<u32>) -> Step<u32> {
        let mut p = [0.0; 3];
        for (k, c) in p.iter_mut().enumerate() {
            let rc = reference.map_or(0.0, |j| self.out.points[j as usize][k]);
            *c = next!(r.value(self.wide_points, rc));
        }
        let mut values = Vec::new();
        for (a, &w) in self.out.arrays.iter().zip(&self.wide) {
            for c in 0..a.components {
                let rv = reference.map_or(0.0, |j| a.values[j as usize * a.components + c]);
                values.push(next!(r.value(w, rv)));
            }
        }
        let mut k = 0;
        for a in &mut self.out.arrays {
            a.values.extend_from_slice(&values[k..k + a.components]);
            k += a.components;
        }
        self.out.points.push(p);
        self.stars.add_point();
        Ok(Some((self.out.points.len() - 1) as u32))
    }

    fn tet<R: Read>(&mut self, r: &mut Reader<R>) -> Step<[u32; 4]> {
        let mut t = [0u32; 4];
        for c in &mut t {
            *c = index(next!(r.varint()), self.out.points.len(), "point")?;
        }
        Ok(Some(t))
    }

    fn errors<R: Read>(r: &mut Reader<R>) -> Step<(f64, f64)> {
        let max = f64::from_le_bytes(next!(r.bytes::<8>()));
        let rms = f64::from_le_bytes(next!(r.bytes::<8>()));
        Ok(Some((max, rms)))
    }

    /// Reads the base mesh; `None` if the stream ends before it is complete.
    fn base<R: Read>(&mut self, r: &mut Reader<R>) -> Step<()> {
        let (max, rms) = next!(Self::errors(r));
        let points = next!(r.varint());
        if points > self.out.original_points as u64 {
            return Err(Error::Stream(
                "the base mesh has more points than the original".into(),
            ));
        }
        for _ in 0..points {
            next!(self.point(r, None));
        }
        let tets = next!(r.varint());
        if tets > self.out.original_tets as u64 {
            return Err(Error::Stream(
                "the base mesh has more tetrahedra than the original".into(),
            ));
        }
        let mut all = Vec::with_capacity(tets as usize);
        for _ in 0..tets {
            all.push(next!(self.tet(r)));
        }
        for c in all {
            self.stars.add_tet(c);
        }
        (self.out.max_field_error, self.out.rms_field_error) = (max, rms);
        Ok(Some(()))
    }

    /// Reads and applies one split; `None` (nothing applied) if the stream ends inside it.
    fn split<R: Read>(&mut self, r: &mut Reader<R>) -> Step<()> {
        let j = index(next!(r.varint()), self.out.points.len(), "split target")?;
        let mark = (
            self.out.points.len(),
            self.out
                .arrays
                .iter()
                .map(|a| a.values.len())
                .collect::<Vec<_>>(),
        );
        let undo = |d: &mut Decoder| {
            d.out.points.truncate(mark.0);
            d.stars.star.truncate(mark.0);
            for (a, &n) in d.out.arrays.iter_mut().zip(&mark.1) {
                a.values.truncate(n);
            }
        };
        let level = self.out.level;
        let bad = move |what: &str| Error::Stream(format!("split {level}: {what}"));
        let read = |d: &mut Decoder, r: &mut Reader<R>| -> Step<SplitRecord> {
            let vertex = next!(d.point(r, Some(j)));
            let star = d.stars.sorted_star(j);
            let mut moved = Vec::new();
            for byte in 0..star.len().div_ceil(8) {
                let [b] = next!(r.bytes::<1>());
                for bit in 0..8 {
                    if b & (1 << bit) != 0 {
                        let t = star
                            .get(8 * byte + bit)
                            .ok_or_else(|| bad("the moved tetrahedra's mask is too long"))?;
                        moved.push(*t);
                    }
                }
            }
            let neighbours = d.stars.neighbours(j);
            let new_count = next!(r.varint());
            let mut new = Vec::new();
            for _ in 0..new_count {
                let [slots] = next!(r.bytes::<1>());
                let (si, sj) = ((slots & 3) as usize, ((slots >> 2) & 3) as usize);
                if si == sj || slots >> 4 != 0 {
                    return Err(bad("a new tetrahedron's slots are invalid"));
                }
                let mut c = [vertex, vertex, vertex, vertex];
                c[sj] = j;
                for (k, corner) in c.iter_mut().enumerate() {
                    if k != si && k != sj {
                        let n = next!(r.varint());
                        *corner = *usize::try_from(n)
                            .ok()
                            .and_then(|n| neighbours.get(n))
                            .ok_or_else(|| bad("a corner is not a neighbour of the target"))?;
                    }
                }
                new.push(c);
            }
            let [changed] = next!(r.bytes::<1>());
            let max = if changed == 1 {
                f64::from_le_bytes(next!(r.bytes::<8>()))
            } else {
                d.out.max_field_error
            };
            let rms = f32::from_le_bytes(next!(r.bytes::<4>())) as f64;
            Ok(Some(SplitRecord {
                vertex,
                moved,
                new,
                errors: (max, rms),
            }))
        };
        let record = match read(self, r) {
            Ok(Some(record)) => record,
            Ok(None) => {
                undo(self);
                return Ok(None);
            }
            Err(e) => return Err(e),
        };
        let SplitRecord {
            vertex,
            moved,
            new,
            errors: (max, rms),
        } = record;
        for t in moved {
            self.stars.move_tet(t, j, vertex);
        }
        for c in new {
            self.stars.add_tet(c);
        }
        self.out.level += 1;
        (self.out.max_field_error, self.out.rms_field_error) = (max, rms);
        Ok(Some(()))
    }
}

/// Decodes the level `level` (clamped to the stream's last) from a stream written by [`encode`], or
/// from any prefix of one: a stream that ends early gives the last complete level (at least the base
/// mesh).
pub fn decode(input: impl Read, level: usize) -> Result<Decoded> {
    let mut r = Reader { input };
    let truncated = || Error::Stream("the stream ends before its base mesh is complete".into());
    let magic = r.bytes::<4>()?.ok_or_else(truncated)?;
    if &magic != MAGIC {
        return Err(Error::Stream(
            "not a progressive mesh stream (no DPM2 header)".into(),
        ));
    }
    let mut counts = [0usize; 4];
    for c in &mut counts {
        *c = r.varint()?.ok_or_else(truncated)? as usize;
    }
    let [original_points, original_tets, levels, n_arrays] = counts;
    let mut arrays = Vec::new();
    let mut wide = Vec::new();
    for _ in 0..n_arrays.min(1 << 16) {
        let len = r.varint()?.ok_or_else(truncated)? as usize;
        if len > 1 << 16 {
            return Err(Error::Stream("an array name is too long".into()));
        }
        let mut name = vec![0u8; len];
        r.input.read_exact(&mut name).map_err(|_| truncated())?;
        let name = String::from_utf8(name)
            .map_err(|_| Error::Stream("an array name is not UTF-8".into()))?;
        let components = r.varint()?.ok_or_else(truncated)? as usize;
        let [type_tag, width] = r.bytes::<2>()?.ok_or_else(truncated)?;
        if components == 0 || components > 1 << 16 || !matches!(width, 4 | 8) {
            return Err(Error::Stream(format!(
                "array '{name}' has an invalid layout"
            )));
        }
        arrays.push(PointArray {
            name,
            components,
            type_tag,
            values: Vec::new(),
        });
        wide.push(width == 8);
    }
    let [width] = r.bytes::<1>()?.ok_or_else(truncated)?;
    let mut d = Decoder {
        out: Decoded {
            points: Vec::new(),
            tets: Vec::new(),
            arrays,
            level: 0,
            levels,
            max_field_error: 0.0,
            rms_field_error: 0.0,
            original_points,
            original_tets,
        },
        wide,
        wide_points: width == 8,
        stars: Stars::default(),
    };
    d.base(&mut r)?.ok_or_else(truncated)?;
    while d.out.level < level.min(levels) {
        if d.split(&mut r)?.is_none() {
            break;
        }
    }
    d.out.tets = std::mem::take(&mut d.stars.tets);
    Ok(d.out)
}
