//! Reading VTK XML files: image data (`.vti`, with rectilinear grids `.vtr` through
//! [`read_structured`]), unstructured grids (`.vtu`) and the polygons of poly data (`.vtp`).
//!
//! `vtkio` (0.6.3 and 0.7.0-rc2) cannot read what VTK and ParaView write by default:
//! - `<AppendedData encoding="raw">` (ParaView's default) is rejected by 0.7 ("unknown variant `raw`") and
//!   fed to the XML parser as text by 0.6;
//! - zlib data of more than one compressed block is decoded as a single stream by 0.6, and 0.7 loses the
//!   last block when it is full (`np = 0` in the header);
//! - the metadata of its XML model (extent, origin, spacing, points, cells) is private, and origin and
//!   spacing are `f32`.
//!
//! So the XML structure is read with `quick-xml` (the parser `vtkio` itself uses) and the arrays are
//! decoded by [`Codec`]: ASCII, inline base64, appended raw or base64, uncompressed or compressed in
//! blocks with zlib, LZ4 or LZMA, 32- or 64-bit headers, either byte order.

use crate::{extension, point_count, Array, Error, Result, UniformGrid, Values};
use rayon::prelude::*;
use std::borrow::Cow;
use std::io::Read;
use std::path::Path;

/// Image data with its point data, as read from a `.vti` file.
#[derive(Clone, Debug)]
pub struct Image {
    /// Points, world origin of the first point (extent start included) and spacing.
    pub grid: UniformGrid,
    /// Every point-data array, in file order.
    pub point_data: Vec<Array>,
    /// Names of the cell-data arrays (not decoded; [`read_structured`] decodes them).
    pub cell_arrays: Vec<String>,
    /// The active scalars named by the file (`Scalars="…"`).
    pub active_scalars: Option<String>,
    /// Arrays left out while reading (non-numeric types), for the user.
    pub warnings: Vec<String>,
}

/// An unstructured grid, as read from a `.vtu` file.
#[derive(Clone, Debug, Default)]
pub struct Unstructured {
    pub points: Vec<[f64; 3]>,
    /// The points of every cell, cell after cell.
    pub connectivity: Vec<usize>,
    /// End of each cell in `connectivity`.
    pub offsets: Vec<usize>,
    /// VTK cell types.
    pub types: Vec<u8>,
    pub point_data: Vec<Array>,
    pub cell_data: Vec<Array>,
    pub field_data: Vec<Array>,
}

/// Polygonal data, as read from a `.vtp` file: its polygons (`<Polys>`); files with vertices, lines
/// or strips are refused.
#[derive(Clone, Debug, Default)]
pub struct PolyData {
    pub points: Vec<[f64; 3]>,
    /// The points of every polygon, polygon after polygon.
    pub connectivity: Vec<usize>,
    /// End of each polygon in `connectivity`.
    pub offsets: Vec<usize>,
    pub point_data: Vec<Array>,
    pub cell_data: Vec<Array>,
    pub field_data: Vec<Array>,
}

/// The geometry of a structured data set: a uniform grid, or the coordinates of a rectilinear grid.
#[derive(Clone, Debug, PartialEq)]
pub enum Geometry {
    /// Image data (`.vti`): origin (extent start included) and spacing.
    Uniform(UniformGrid),
    /// Rectilinear grid (`.vtr`): the x, y and z coordinates.
    Rectilinear([Vec<f64>; 3]),
}

/// Image data or a rectilinear grid with its point and cell data (every numeric array decoded).
#[derive(Clone, Debug)]
pub struct Structured {
    pub geometry: Geometry,
    /// Points per axis.
    pub dims: [usize; 3],
    pub point_data: Vec<Array>,
    /// One tuple per cell, x fastest (`(dims[0] - 1) × (dims[1] - 1) × (dims[2] - 1)` of them).
    pub cell_data: Vec<Array>,
    /// Arrays left out while reading (non-numeric types), for the user.
    pub warnings: Vec<String>,
}

/// Reads a `.vti` (VTK XML ImageData) or `.vtr` (VTK XML RectilinearGrid) file with its point and cell
/// data.
pub fn read_structured(path: &Path) -> Result<Structured> {
    let ext = extension(path);
    if ext != "vti" && ext != "vtr" {
        bail!(
            "unsupported input file '{}': expected a .vti (VTK XML image data) or .vtr (VTK XML rectilinear grid) file",
            path.display()
        );
    }
    let bytes = read_bytes(path)?;
    in_file(path, xml_structured(&bytes))
}

/// Reads the file's bytes, naming the file in the error.
fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| Error(format!("cannot read '{}': {e}", path.display())))
}

/// Prefixes errors with the file name.
fn in_file<T>(path: &Path, r: Result<T>) -> Result<T> {
    r.map_err(|e| Error(format!("'{}': {e}", path.display())))
}

/// Reads image data from a `.vti` (VTK XML ImageData) file: its point data, and the names of its cell
/// data.
pub fn read_image(path: &Path) -> Result<Image> {
    if extension(path) != "vti" {
        bail!(
            "unsupported input file '{}': expected a .vti (VTK XML image data) file",
            path.display()
        );
    }
    let bytes = read_bytes(path)?;
    in_file(path, xml_image(&bytes))
}

/// Reads an unstructured grid from a `.vtu` (VTK XML UnstructuredGrid) file.
pub fn read_unstructured(path: &Path) -> Result<Unstructured> {
    if extension(path) != "vtu" {
        bail!(
            "unsupported mesh file '{}': expected a .vtu (VTK XML unstructured grid) file",
            path.display()
        );
    }
    let bytes = read_bytes(path)?;
    in_file(path, xml_unstructured(&bytes))
}

/// Reads the polygons of a `.vtp` (VTK XML PolyData) file.
pub fn read_polydata(path: &Path) -> Result<PolyData> {
    if extension(path) != "vtp" {
        bail!(
            "unsupported surface file '{}': expected a .vtp (VTK XML poly data) file",
            path.display()
        );
    }
    let bytes = read_bytes(path)?;
    in_file(path, xml_polydata(&bytes))
}

// ---------------------------------------------------------------------------------------------------
// VTK XML

/// Attributes of an element, in order.
#[derive(Clone, Debug, Default)]
struct Attrs(Vec<(String, String)>);

impl Attrs {
    fn of(e: &quick_xml::events::BytesStart<'_>) -> Result<Self> {
        let mut out = Vec::new();
        for a in e.attributes() {
            let a = a.map_err(|e| Error(format!("malformed XML attribute: {e}")))?;
            let value = a
                .unescape_value()
                .map_err(|e| Error(format!("malformed XML attribute: {e}")))?;
            out.push((
                String::from_utf8_lossy(a.key.as_ref()).into_owned(),
                value.into_owned(),
            ));
        }
        Ok(Self(out))
    }

    fn get(&self, key: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// Whitespace-separated numbers of attribute `key`, exactly `N` of them.
    fn numbers<T: std::str::FromStr, const N: usize>(&self, key: &str) -> Result<Option<[T; N]>> {
        let Some(v) = self.get(key) else {
            return Ok(None);
        };
        let parsed: Vec<T> = v
            .split_ascii_whitespace()
            .map(|s| s.parse::<T>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| Error(format!("attribute {key}=\"{v}\" is not a list of numbers")))?;
        match <[T; N]>::try_from(parsed) {
            Ok(a) => Ok(Some(a)),
            Err(_) => bail!("attribute {key}=\"{v}\" must have {N} numbers"),
        }
    }
}

/// A `<DataArray>` element: its attributes and inline text.
#[derive(Clone, Debug, Default)]
struct XmlArray {
    attrs: Attrs,
    text: String,
}

/// `<PointData>`, `<CellData>`, `<Points>`, `<Cells>`, … of a piece.
#[derive(Clone, Debug, Default)]
struct Section {
    name: String,
    attrs: Attrs,
    arrays: Vec<XmlArray>,
}

#[derive(Clone, Debug, Default)]
struct XmlPiece {
    attrs: Attrs,
    sections: Vec<Section>,
}

impl XmlPiece {
    fn section(&self, name: &str) -> Option<&Section> {
        self.sections.iter().find(|s| s.name == name)
    }
}

/// The `<AppendedData>` payload (after the `_` marker).
struct Appended<'a> {
    base64: bool,
    bytes: &'a [u8],
    /// Offsets of every appended array, sorted: the end of a base64 array is the next offset.
    offsets: Vec<usize>,
}

/// A parsed VTK XML file.
struct XmlDoc<'a> {
    /// `ImageData`, `UnstructuredGrid`, …
    kind: String,
    dataset: Attrs,
    pieces: Vec<XmlPiece>,
    field_data: Vec<XmlArray>,
    codec: Codec,
    appended: Option<Appended<'a>>,
}

/// How binary arrays are stored: header integer size, byte order, compressor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Codec {
    header64: bool,
    big_endian: bool,
    compressor: Compressor,
}

/// VTK's block compressors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Compressor {
    None,
    Zlib,
    Lz4,
    Lzma,
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fn rfind(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).rposition(|w| w == needle)
}

impl<'a> XmlDoc<'a> {
    fn parse(bytes: &'a [u8]) -> Result<Self> {
        use quick_xml::events::Event;
        // Cut the appended payload off first: raw binary is not XML.
        let (xml, appended) = match find(bytes, b"<AppendedData") {
            None => (bytes, None),
            Some(start) => {
                let gt = start
                    + bytes[start..]
                        .iter()
                        .position(|&b| b == b'>')
                        .ok_or_else(|| Error("unterminated <AppendedData> tag".into()))?;
                let tag = String::from_utf8_lossy(&bytes[start..gt]);
                let base64 = if tag.contains("\"raw\"") {
                    false
                } else if tag.contains("\"base64\"") {
                    true
                } else {
                    bail!("<AppendedData> must have encoding=\"raw\" or encoding=\"base64\"");
                };
                let underscore = gt
                    + bytes[gt..]
                        .iter()
                        .position(|&b| b == b'_')
                        .ok_or_else(|| Error("<AppendedData> lacks its '_' marker".into()))?;
                let data = &bytes[underscore + 1..];
                let end = rfind(data, b"</AppendedData>").unwrap_or(data.len());
                (
                    &bytes[..start],
                    Some(Appended {
                        base64,
                        bytes: &data[..end],
                        offsets: Vec::new(),
                    }),
                )
            }
        };
        let mut reader = quick_xml::Reader::from_reader(xml);
        let mut root = None;
        let mut doc = XmlDoc {
            kind: String::new(),
            dataset: Attrs::default(),
            pieces: Vec::new(),
            field_data: Vec::new(),
            codec: Codec {
                header64: false,
                big_endian: false,
                compressor: Compressor::None,
            },
            appended,
        };
        let mut stack: Vec<String> = Vec::new();
        let bad = |e: quick_xml::Error| Error(format!("malformed XML: {e}"));
        loop {
            let event = reader.read_event().map_err(bad)?;
            let (e, is_empty) = match &event {
                Event::Start(e) => (e, false),
                Event::Empty(e) => (e, true),
                Event::End(_) => {
                    stack.pop();
                    continue;
                }
                Event::Text(t) => {
                    if stack.last().is_some_and(|s| s == "DataArray") {
                        let text = t.unescape().map_err(bad)?;
                        if let Some(a) = doc.current_array(&stack) {
                            a.text.push_str(&text);
                        }
                    }
                    continue;
                }
                Event::Eof => break,
                _ => continue,
            };
            let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
            let attrs = Attrs::of(e)?;
            match (stack.len(), name.as_str()) {
                (0, "VTKFile") => root = Some(attrs),
                (0, other) => bail!("not a VTK XML file (root element <{other}>)"),
                (1, _) => {
                    doc.kind = name.clone();
                    doc.dataset = attrs;
                }
                (_, "Piece") => doc.pieces.push(XmlPiece {
                    attrs,
                    sections: Vec::new(),
                }),
                (_, "FieldData") if !stack.iter().any(|s| s == "Piece") => {}
                (_, "DataArray" | "Array") => {
                    let array = XmlArray {
                        attrs,
                        text: String::new(),
                    };
                    let parent = stack.last().map(String::as_str);
                    if parent == Some("FieldData") && !stack.iter().any(|s| s == "Piece") {
                        doc.field_data.push(array);
                    } else if let Some(s) =
                        doc.pieces.last_mut().and_then(|p| p.sections.last_mut())
                    {
                        s.arrays.push(array);
                    }
                }
                (_, _) if stack.last().is_some_and(|s| s == "Piece") => {
                    if let Some(p) = doc.pieces.last_mut() {
                        p.sections.push(Section {
                            name: name.clone(),
                            attrs,
                            arrays: Vec::new(),
                        })
                    }
                }
                _ => {}
            }
            if !is_empty {
                stack.push(name);
            }
        }
        let root = root.ok_or_else(|| Error("not a VTK XML file (no <VTKFile> element)".into()))?;
        doc.codec = Codec::of(&root)?;
        if let Some(t) = root.get("type") {
            if !doc.kind.is_empty() && t != doc.kind {
                bail!("<VTKFile type=\"{t}\"> holds <{}>", doc.kind);
            }
        }
        if doc.kind.is_empty() {
            bail!("the VTK XML file holds no data set");
        }
        let mut offsets: Vec<usize> = Vec::new();
        for a in doc.all_arrays() {
            if a.attrs.get("format") == Some("appended") {
                offsets.push(offset_of(a)?);
            }
        }
        offsets.sort_unstable();
        offsets.dedup();
        if let Some(app) = &mut doc.appended {
            app.offsets = offsets;
        }
        Ok(doc)
    }

    /// The array whose text is being read (the last one opened).
    fn current_array(&mut self, stack: &[String]) -> Option<&mut XmlArray> {
        if stack.iter().any(|s| s == "Piece") {
            self.pieces
                .last_mut()?
                .sections
                .last_mut()?
                .arrays
                .last_mut()
        } else {
            self.field_data.last_mut()
        }
    }

    fn all_arrays(&self) -> impl Iterator<Item = &XmlArray> {
        self.pieces
            .iter()
            .flat_map(|p| p.sections.iter().flat_map(|s| s.arrays.iter()))
            .chain(self.field_data.iter())
    }

    /// The single piece of the data set.
    fn piece(&self) -> Result<&XmlPiece> {
        match self.pieces.len() {
            1 => Ok(&self.pieces[0]),
            0 => bail!("the {} has no <Piece>", self.kind),
            n => bail!(
                "the {} has {n} pieces; only single-piece files are supported (merge the pieces first)",
                self.kind
            ),
        }
    }

    /// Decodes `array`, which must hold `tuples` tuples.
    fn decode(&self, array: &XmlArray, tuples: usize) -> Result<Array> {
        let attrs = &array.attrs;
        let name = attrs.get("Name").unwrap_or("").to_string();
        let r = (|| {
            let type_name = attrs
                .get("type")
                .ok_or_else(|| Error("no type attribute".into()))?;
            let kind = Kind::of(type_name)?;
            let components: usize = match attrs.get("NumberOfComponents") {
                None => 1,
                Some(c) => c
                    .trim()
                    .parse()
                    .ok()
                    .filter(|&c| c > 0)
                    .ok_or_else(|| Error(format!("invalid NumberOfComponents=\"{c}\"")))?,
            };
            let count = tuples
                .checked_mul(components)
                .ok_or_else(|| Error("too many values".into()))?;
            let expected = count * kind.size();
            let data = match attrs.get("format").unwrap_or("ascii") {
                "ascii" => kind.parse_ascii(&array.text, count)?,
                "binary" => {
                    let stream = base64_decode(array.text.as_bytes())?;
                    kind.decode_bytes(&self.codec.unpack(&stream, expected)?, self.codec)
                }
                "appended" => {
                    let app = self.appended.as_ref().ok_or_else(|| {
                        Error("format=\"appended\" but the file has no <AppendedData>".into())
                    })?;
                    let offset = offset_of(array)?;
                    if offset > app.bytes.len() {
                        bail!(
                            "offset {offset} lies beyond the appended data ({} bytes)",
                            app.bytes.len()
                        );
                    }
                    let stream: Cow<'_, [u8]> = if app.base64 {
                        let end = app
                            .offsets
                            .iter()
                            .copied()
                            .find(|&o| o > offset)
                            .unwrap_or(app.bytes.len())
                            .min(app.bytes.len());
                        Cow::Owned(base64_decode(&app.bytes[offset..end])?)
                    } else {
                        Cow::Borrowed(&app.bytes[offset..])
                    };
                    kind.decode_bytes(&self.codec.unpack(&stream, expected)?, self.codec)
                }
                other => bail!("unknown format=\"{other}\""),
            };
            if data.len() != count {
                bail!(
                    "{} values where {tuples} tuples of {components} components were expected",
                    data.len()
                );
            }
            Ok(Array {
                name: name.clone(),
                components,
                data,
            })
        })();
        r.map_err(|e| Error(format!("data array '{name}': {e}")))
    }

    /// Decodes every array of `section` (absent section: none). Arrays of a type that cannot be
    /// meshed or passed through (strings, bits) are left out with a warning in `warnings`.
    fn decode_section(
        &self,
        section: Option<&Section>,
        tuples: usize,
        warnings: &mut Vec<String>,
    ) -> Result<Vec<Array>> {
        let mut out = Vec::new();
        for a in section.map(|s| &s.arrays[..]).unwrap_or_default() {
            let type_name = a.attrs.get("type").unwrap_or("");
            if Kind::of(type_name).is_err() {
                warnings.push(format!(
                    "array '{}' of type {type_name} left out (not a numeric array)",
                    a.attrs.get("Name").unwrap_or("")
                ));
                continue;
            }
            out.push(self.decode(a, tuples)?);
        }
        Ok(out)
    }
}

fn offset_of(a: &XmlArray) -> Result<usize> {
    let name = a.attrs.get("Name").unwrap_or("");
    a.attrs
        .get("offset")
        .and_then(|o| o.trim().parse().ok())
        .ok_or_else(|| Error(format!("appended data array '{name}' lacks a valid offset")))
}

impl Codec {
    fn of(root: &Attrs) -> Result<Self> {
        let header64 = match root.get("header_type").unwrap_or("UInt32") {
            "UInt32" => false,
            "UInt64" => true,
            other => bail!("unsupported header_type=\"{other}\""),
        };
        let big_endian = match root.get("byte_order").unwrap_or("LittleEndian") {
            "LittleEndian" => false,
            "BigEndian" => true,
            other => bail!("unsupported byte_order=\"{other}\""),
        };
        let compressor = match root.get("compressor").unwrap_or("") {
            "" => Compressor::None,
            "vtkZLibDataCompressor" => Compressor::Zlib,
            "vtkLZ4DataCompressor" => Compressor::Lz4,
            "vtkLZMADataCompressor" => Compressor::Lzma,
            other => bail!("unsupported compressor=\"{other}\""),
        };
        Ok(Self {
            header64,
            big_endian,
            compressor,
        })
    }

    /// Header integer `k` of `stream`.
    fn header(&self, stream: &[u8], k: usize) -> Result<usize> {
        let size = if self.header64 { 8 } else { 4 };
        let Some(b) = stream.get(k * size..(k + 1) * size) else {
            bail!("binary data is truncated (header)");
        };
        let v = match (self.header64, self.big_endian) {
            (false, false) => u32::from_le_bytes(b.try_into().expect("4 bytes")) as u64,
            (false, true) => u32::from_be_bytes(b.try_into().expect("4 bytes")) as u64,
            (true, false) => u64::from_le_bytes(b.try_into().expect("8 bytes")),
            (true, true) => u64::from_be_bytes(b.try_into().expect("8 bytes")),
        };
        usize::try_from(v).map_err(|_| Error("binary header value too large".into()))
    }

    /// The `expected` payload bytes of a binary array that starts at the beginning of `stream`
    /// (VTK's header, then the data, compressed in blocks when a compressor is set).
    fn unpack<'s>(&self, stream: &'s [u8], expected: usize) -> Result<Cow<'s, [u8]>> {
        let hb = if self.header64 { 8 } else { 4 };
        if self.compressor == Compressor::None {
            let n = self.header(stream, 0)?;
            if n != expected {
                bail!("binary header announces {n} bytes, {expected} expected");
            }
            return match stream.get(hb..hb + n) {
                Some(s) => Ok(Cow::Borrowed(s)),
                None => bail!(
                    "binary data is truncated ({} of {n} bytes)",
                    stream.len().saturating_sub(hb)
                ),
            };
        }
        // [nb][nu][np][nc_1 … nc_nb][blocks]: nb blocks of nu bytes, the last np bytes (0: full).
        let nb = self.header(stream, 0)?;
        let nu = self.header(stream, 1)?;
        let np = self.header(stream, 2)?;
        if nb == 0 {
            if expected != 0 {
                bail!("compressed data holds no block, {expected} bytes expected");
            }
            return Ok(Cow::Borrowed(&[]));
        }
        if hb.saturating_mul(3 + nb) > stream.len() {
            bail!("compressed data is truncated (header of {nb} blocks)");
        }
        let last = if np == 0 { nu } else { np };
        let total = nu
            .checked_mul(nb - 1)
            .and_then(|t| t.checked_add(last))
            .filter(|&t| t == expected)
            .ok_or_else(|| {
                Error(format!(
                    "compressed header announces {nb} blocks of {nu} bytes (last {last}), {expected} bytes expected"
                ))
            })?;
        let mut blocks = Vec::with_capacity(nb);
        let mut at = hb * (3 + nb);
        for k in 0..nb {
            let nc = self.header(stream, 3 + k)?;
            let end = at
                .checked_add(nc)
                .filter(|&e| e <= stream.len())
                .ok_or_else(|| Error(format!("compressed block {k} is truncated")))?;
            let size = if k + 1 == nb { last } else { nu };
            blocks.push((&stream[at..end], size));
            at = end;
        }
        let compressor = self.compressor;
        let parts: Vec<Vec<u8>> = blocks
            .par_iter()
            .enumerate()
            .map(|(k, &(block, size))| {
                decompress(compressor, block, size)
                    .map_err(|e| Error(format!("compressed block {k}: {e}")))
            })
            .collect::<Result<_>>()?;
        let mut out = Vec::with_capacity(total);
        for p in parts {
            out.extend_from_slice(&p);
        }
        Ok(Cow::Owned(out))
    }
}

/// Decompresses one block that must inflate to exactly `size` bytes.
fn decompress(compressor: Compressor, block: &[u8], size: usize) -> Result<Vec<u8>> {
    // The header's size is checked against the declared array size only: no room reserved
    // beyond what the block can inflate to (zlib's deflate expands at most 1032:1).
    let mut out = Vec::with_capacity(size.min(block.len().saturating_mul(1032)));
    let result = match compressor {
        Compressor::None => {
            out.extend_from_slice(block);
            Ok(())
        }
        Compressor::Zlib => flate2::read::ZlibDecoder::new(block)
            .take(size as u64 + 1)
            .read_to_end(&mut out)
            .map(|_| ())
            .map_err(|e| e.to_string()),
        // LZ4 allocates the declared size up front; a block inflates at most 255:1.
        Compressor::Lz4 if size > block.len().saturating_mul(255).saturating_add(64) => {
            Err(format!(
                "a block of {} bytes cannot inflate to the {size} bytes announced",
                block.len()
            ))
        }
        Compressor::Lz4 => lz4_flex::block::decompress(block, size)
            .map(|v| out = v)
            .map_err(|e| e.to_string()),
        Compressor::Lzma => lzma_rs::xz_decompress(&mut std::io::BufReader::new(block), &mut out)
            .map_err(|e| e.to_string()),
    };
    if let Err(e) = result {
        bail!("cannot decompress ({compressor:?}): {e}");
    }
    if out.len() != size {
        bail!("inflates to {} bytes, {size} expected", out.len());
    }
    Ok(out)
}

/// Decodes base64 text, ignoring whitespace and accepting concatenated padded pieces (VTK encodes the
/// header and the data of an array separately).
fn base64_decode(text: &[u8]) -> Result<Vec<u8>> {
    fn sextet(c: u8) -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    }
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let (mut quad, mut n, mut pad) = (0u32, 0usize, 0usize);
    for &c in text {
        if c.is_ascii_whitespace() {
            continue;
        }
        if c == b'=' {
            if n < 2 {
                bail!("invalid base64 data (misplaced '=')");
            }
            pad += 1;
            quad <<= 6;
        } else {
            if pad > 0 {
                bail!("invalid base64 data (data after '=')");
            }
            let Some(v) = sextet(c) else {
                bail!("invalid base64 data (character {:?})", c as char);
            };
            quad = quad << 6 | v;
        }
        n += 1;
        if n == 4 {
            let bytes = quad.to_be_bytes();
            out.extend_from_slice(&bytes[1..4 - pad]);
            (quad, n, pad) = (0, 0, 0);
        }
    }
    if n != 0 {
        // Unpadded tail.
        if n == 1 {
            bail!("invalid base64 data (truncated)");
        }
        let bytes = (quad << (6 * (4 - n))).to_be_bytes();
        out.extend_from_slice(&bytes[1..n]);
    }
    Ok(out)
}

/// A VTK value type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

macro_rules! per_kind {
    ($kind:expr, $t:ident, $variant:ident => $body:expr) => {
        match $kind {
            Kind::I8 => {
                type $t = i8;
                let $variant = Values::I8;
                $body
            }
            Kind::U8 => {
                type $t = u8;
                let $variant = Values::U8;
                $body
            }
            Kind::I16 => {
                type $t = i16;
                let $variant = Values::I16;
                $body
            }
            Kind::U16 => {
                type $t = u16;
                let $variant = Values::U16;
                $body
            }
            Kind::I32 => {
                type $t = i32;
                let $variant = Values::I32;
                $body
            }
            Kind::U32 => {
                type $t = u32;
                let $variant = Values::U32;
                $body
            }
            Kind::I64 => {
                type $t = i64;
                let $variant = Values::I64;
                $body
            }
            Kind::U64 => {
                type $t = u64;
                let $variant = Values::U64;
                $body
            }
            Kind::F32 => {
                type $t = f32;
                let $variant = Values::F32;
                $body
            }
            Kind::F64 => {
                type $t = f64;
                let $variant = Values::F64;
                $body
            }
        }
    };
}

impl Kind {
    fn of(name: &str) -> Result<Self> {
        Ok(match name {
            "Int8" | "Char" => Kind::I8,
            "UInt8" | "UnsignedChar" => Kind::U8,
            "Int16" | "Short" => Kind::I16,
            "UInt16" | "UnsignedShort" => Kind::U16,
            "Int32" | "Int" => Kind::I32,
            "UInt32" | "UnsignedInt" => Kind::U32,
            "Int64" | "Long" | "LongLong" | "IdType" => Kind::I64,
            "UInt64" | "UnsignedLong" | "UnsignedLongLong" => Kind::U64,
            "Float32" | "Float" => Kind::F32,
            "Float64" | "Double" => Kind::F64,
            other => bail!("unsupported type=\"{other}\""),
        })
    }

    fn size(self) -> usize {
        per_kind!(self, T, _v => std::mem::size_of::<T>())
    }

    fn decode_bytes(self, bytes: &[u8], codec: Codec) -> Values {
        per_kind!(self, T, variant => {
            const N: usize = std::mem::size_of::<T>();
            let convert = if codec.big_endian { T::from_be_bytes } else { T::from_le_bytes };
            variant(
                bytes
                    .chunks_exact(N)
                    .map(|c| convert(c.try_into().expect("chunk of N bytes")))
                    .collect(),
            )
        })
    }

    fn parse_ascii(self, text: &str, count: usize) -> Result<Values> {
        per_kind!(self, T, variant => {
            // Room for the values the text can hold (each takes a character and a separator),
            // not for the declared count: a small file may declare billions.
            let mut out: Vec<T> = Vec::with_capacity(count.min(text.len().div_ceil(2)));
            for s in text.split_ascii_whitespace() {
                match s.parse::<T>() {
                    Ok(v) => out.push(v),
                    Err(_) => bail!("'{s}' is not a valid {:?} value", self),
                }
            }
            Ok(variant(out))
        })
    }
}

/// Parses a 6-integer extent.
fn extent(attrs: &Attrs, key: &str) -> Result<Option<[i64; 6]>> {
    attrs.numbers::<i64, 6>(key)
}

/// Number of points of an extent, refusing empty extents.
fn extent_dims(e: [i64; 6]) -> Result<[usize; 3]> {
    let mut dims = [0usize; 3];
    for a in 0..3 {
        let n = e[2 * a + 1] - e[2 * a] + 1;
        if n < 1 {
            bail!("empty extent {e:?}");
        }
        dims[a] = n as usize;
    }
    Ok(dims)
}

/// The extent of `piece`: its `Extent`, else the data set's `WholeExtent`.
fn piece_extent(doc: &XmlDoc<'_>, piece: &XmlPiece) -> Result<[i64; 6]> {
    match extent(&piece.attrs, "Extent")? {
        Some(e) => Ok(e),
        None => extent(&doc.dataset, "WholeExtent")?
            .ok_or_else(|| Error(format!("the {} has no WholeExtent", doc.kind))),
    }
}

/// The grid of image data on extent `ext`, its origin moved to the extent's start; refuses a
/// non-identity `Direction`.
fn uniform_grid(doc: &XmlDoc<'_>, ext: [i64; 6]) -> Result<UniformGrid> {
    if let Some(d) = doc.dataset.numbers::<f64, 9>("Direction")? {
        if d != [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] {
            bail!("the image has a non-identity Direction matrix {d:?}; only axis-aligned images are supported");
        }
    }
    let mut origin = doc.dataset.numbers::<f64, 3>("Origin")?.unwrap_or([0.0; 3]);
    let spacing = doc
        .dataset
        .numbers::<f64, 3>("Spacing")?
        .unwrap_or([1.0; 3]);
    for a in 0..3 {
        origin[a] += spacing[a] * ext[2 * a] as f64;
    }
    Ok(UniformGrid {
        dims: extent_dims(ext)?,
        origin,
        spacing,
    })
}

fn xml_image(bytes: &[u8]) -> Result<Image> {
    let doc = XmlDoc::parse(bytes)?;
    if doc.kind != "ImageData" {
        bail!("holds VTK {} data, not ImageData", doc.kind);
    }
    let piece = doc.piece()?;
    let grid = uniform_grid(&doc, piece_extent(&doc, piece)?)?;
    let n = point_count(grid.dims)?;
    let point_section = piece.section("PointData");
    let mut warnings = Vec::new();
    let point_data = doc.decode_section(point_section, n, &mut warnings)?;
    Ok(Image {
        grid,
        point_data,
        cell_arrays: piece
            .section("CellData")
            .map(|s| {
                s.arrays
                    .iter()
                    .map(|a| a.attrs.get("Name").unwrap_or("").to_string())
                    .collect()
            })
            .unwrap_or_default(),
        active_scalars: point_section.and_then(|s| s.attrs.get("Scalars").map(str::to_string)),
        warnings,
    })
}

fn xml_structured(bytes: &[u8]) -> Result<Structured> {
    let doc = XmlDoc::parse(bytes)?;
    if doc.kind != "ImageData" && doc.kind != "RectilinearGrid" {
        bail!(
            "holds VTK {} data, not ImageData or RectilinearGrid",
            doc.kind
        );
    }
    let piece = doc.piece()?;
    let ext = piece_extent(&doc, piece)?;
    let dims = extent_dims(ext)?;
    let geometry = if doc.kind == "ImageData" {
        Geometry::Uniform(uniform_grid(&doc, ext)?)
    } else {
        let section = piece
            .section("Coordinates")
            .ok_or_else(|| Error("the RectilinearGrid has no <Coordinates>".into()))?;
        if section.arrays.len() != 3 {
            bail!(
                "the RectilinearGrid has {} coordinate arrays, 3 expected",
                section.arrays.len()
            );
        }
        let mut coords: [Vec<f64>; 3] = Default::default();
        for (a, c) in coords.iter_mut().enumerate() {
            let array = doc.decode(&section.arrays[a], dims[a])?;
            if array.components != 1 {
                bail!("coordinate array {a} has {} components", array.components);
            }
            *c = (0..dims[a]).map(|i| array.value(i)).collect();
        }
        Geometry::Rectilinear(coords)
    };
    let n = point_count(dims)?;
    let cells = point_count(dims.map(|d| d.saturating_sub(1)))?;
    let mut warnings = Vec::new();
    let point_data = doc.decode_section(piece.section("PointData"), n, &mut warnings)?;
    let cell_data = doc.decode_section(piece.section("CellData"), cells, &mut warnings)?;
    Ok(Structured {
        geometry,
        dims,
        point_data,
        cell_data,
        warnings,
    })
}

/// Converts an array of non-negative integers to indices.
fn indices(a: &Array, what: &str) -> Result<Vec<usize>> {
    let bad = || Error(format!("{what} must be non-negative integers"));
    let conv = |v: i128| usize::try_from(v).map_err(|_| bad());
    match &a.data {
        Values::U8(v) => v.iter().map(|&x| conv(x as i128)).collect(),
        Values::I8(v) => v.iter().map(|&x| conv(x as i128)).collect(),
        Values::U16(v) => v.iter().map(|&x| conv(x as i128)).collect(),
        Values::I16(v) => v.iter().map(|&x| conv(x as i128)).collect(),
        Values::U32(v) => v.iter().map(|&x| conv(x as i128)).collect(),
        Values::I32(v) => v.iter().map(|&x| conv(x as i128)).collect(),
        Values::U64(v) => v.iter().map(|&x| conv(x as i128)).collect(),
        Values::I64(v) => v.iter().map(|&x| conv(x as i128)).collect(),
        _ => Err(bad()),
    }
}

/// A count attribute (`NumberOfPoints`, …) of a piece; `None` when absent.
fn piece_count(piece: &XmlPiece, key: &str) -> Result<Option<usize>> {
    piece
        .attrs
        .get(key)
        .map(|v| {
            v.trim()
                .parse()
                .map_err(|_| Error(format!("<Piece> has an invalid {key}=\"{v}\"")))
        })
        .transpose()
}

/// The `<Points>` of a piece of `n_points` points, as `f64`.
fn xml_points(doc: &XmlDoc<'_>, piece: &XmlPiece, n_points: usize) -> Result<Vec<[f64; 3]>> {
    let points = match piece.section("Points").and_then(|s| s.arrays.first()) {
        Some(a) => doc.decode(a, n_points)?,
        None if n_points == 0 => Array::scalars("Points", Vec::<f64>::new()),
        None => bail!("the {} has no <Points>", doc.kind),
    };
    if points.components != 3 {
        bail!("points have {} components, 3 expected", points.components);
    }
    let (Values::F64(_) | Values::F32(_)) = points.data else {
        bail!(
            "points must be Float32 or Float64, not {}",
            points.type_name()
        );
    };
    Ok((0..n_points)
        .map(|p| std::array::from_fn(|a| points.value(3 * p + a)))
        .collect())
}

/// The `offsets` and `connectivity` arrays of the cell section `name` (`Cells`, `Polys`) holding
/// `n_cells` cells on `n_points` points: `(connectivity, offsets)`.
fn xml_cells(
    doc: &XmlDoc<'_>,
    piece: &XmlPiece,
    name: &str,
    n_cells: usize,
    n_points: usize,
) -> Result<(Vec<usize>, Vec<usize>)> {
    let section = piece.section(name);
    let array = |key: &str| {
        section
            .and_then(|s| s.arrays.iter().find(|a| a.attrs.get("Name") == Some(key)))
            .ok_or_else(|| Error(format!("the {} has no <{name}> array '{key}'", doc.kind)))
    };
    let offsets = indices(&doc.decode(array("offsets")?, n_cells)?, "cell offsets")?;
    if offsets.windows(2).any(|w| w[0] > w[1]) {
        bail!("cell offsets decrease");
    }
    let total = offsets.last().copied().unwrap_or(0);
    let connectivity = indices(&doc.decode(array("connectivity")?, total)?, "connectivity")?;
    if let Some(&bad) = connectivity.iter().find(|&&i| i >= n_points) {
        bail!("connectivity refers to point {bad} of {n_points}");
    }
    Ok((connectivity, offsets))
}

/// The data-set `<FieldData>` arrays (those that cannot be decoded are left out).
fn xml_field_data(doc: &XmlDoc<'_>) -> Vec<Array> {
    doc.field_data
        .iter()
        .filter_map(|a| {
            let tuples = a.attrs.get("NumberOfTuples")?.trim().parse().ok()?;
            doc.decode(a, tuples).ok()
        })
        .collect()
}

fn xml_unstructured(bytes: &[u8]) -> Result<Unstructured> {
    let doc = XmlDoc::parse(bytes)?;
    if doc.kind != "UnstructuredGrid" {
        bail!("holds VTK {} data, not UnstructuredGrid", doc.kind);
    }
    let piece = doc.piece()?;
    let count = |key: &str| -> Result<usize> {
        piece_count(piece, key)?.ok_or_else(|| Error(format!("<Piece> lacks a valid {key}")))
    };
    let (n_points, n_cells) = (count("NumberOfPoints")?, count("NumberOfCells")?);
    let points = xml_points(&doc, piece, n_points)?;
    let (connectivity, offsets) = xml_cells(&doc, piece, "Cells", n_cells, n_points)?;
    let types_xml = piece
        .section("Cells")
        .and_then(|s| {
            s.arrays
                .iter()
                .find(|a| a.attrs.get("Name") == Some("types"))
        })
        .ok_or_else(|| Error("the UnstructuredGrid has no <Cells> array 'types'".into()))?;
    let types: Vec<u8> = indices(&doc.decode(types_xml, n_cells)?, "cell types")?
        .into_iter()
        .map(|t| u8::try_from(t).map_err(|_| Error(format!("invalid cell type {t}"))))
        .collect::<Result<_>>()?;
    Ok(Unstructured {
        points,
        connectivity,
        offsets,
        types,
        point_data: doc.decode_section(piece.section("PointData"), n_points, &mut Vec::new())?,
        cell_data: doc.decode_section(piece.section("CellData"), n_cells, &mut Vec::new())?,
        field_data: xml_field_data(&doc),
    })
}

fn xml_polydata(bytes: &[u8]) -> Result<PolyData> {
    let doc = XmlDoc::parse(bytes)?;
    if doc.kind != "PolyData" {
        bail!("holds VTK {} data, not PolyData", doc.kind);
    }
    let piece = doc.piece()?;
    for (key, what) in [
        ("NumberOfVerts", "vertices"),
        ("NumberOfLines", "lines"),
        ("NumberOfStrips", "triangle strips"),
    ] {
        if let Some(n @ 1..) = piece_count(piece, key)? {
            bail!("the PolyData has {n} {what}; only polygons (<Polys>) are read");
        }
    }
    let n_points = piece_count(piece, "NumberOfPoints")?
        .ok_or_else(|| Error("<Piece> lacks a valid NumberOfPoints".into()))?;
    let n_polys = piece_count(piece, "NumberOfPolys")?.unwrap_or(0);
    let points = xml_points(&doc, piece, n_points)?;
    let (connectivity, offsets) = if n_polys == 0 {
        (Vec::new(), Vec::new())
    } else {
        xml_cells(&doc, piece, "Polys", n_polys, n_points)?
    };
    Ok(PolyData {
        points,
        connectivity,
        offsets,
        point_data: doc.decode_section(piece.section("PointData"), n_points, &mut Vec::new())?,
        cell_data: doc.decode_section(piece.section("CellData"), n_polys, &mut Vec::new())?,
        field_data: xml_field_data(&doc),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_accepts_concatenated_padded_pieces() {
        assert_eq!(base64_decode(b"AQ==").unwrap(), [1]);
        assert_eq!(base64_decode(b"AQI=").unwrap(), [1, 2]);
        assert_eq!(base64_decode(b"AQID").unwrap(), [1, 2, 3]);
        assert_eq!(
            base64_decode(b"AQ==AQI=\n AQID").unwrap(),
            [1, 1, 2, 1, 2, 3]
        );
        assert_eq!(base64_decode(b"AQI").unwrap(), [1, 2]);
        assert!(base64_decode(b"A").is_err());
        assert!(base64_decode(b"A===").is_err());
        assert!(base64_decode(b"AQ*=").is_err());
    }

    #[test]
    fn unpack_refuses_inconsistent_headers() {
        let codec = Codec {
            header64: false,
            big_endian: false,
            compressor: Compressor::Zlib,
        };
        // 1 block of 8 bytes, compressed size 100: truncated.
        let stream = [1u32, 8, 0, 100]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<_>>();
        assert!(codec.unpack(&stream, 8).is_err());
        // A huge block count must not allocate.
        let stream = [u32::MAX, 8, 0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<_>>();
        assert!(codec.unpack(&stream, 8).is_err());
    }
}
