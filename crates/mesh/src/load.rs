//! Mesh input: OBJ, STL (ASCII and binary) and PLY (ASCII, binary little- and big-endian),
//! validated and cleaned into a [`TriMesh`].
//!
//! Entry points:
//! - [`load_mesh`]: a file to a [`LoadedMesh`] (the mesh and a [`LoadReport`] of what was
//!   cleaned). The format comes from the extension (`.obj`, `.stl`, `.ply`, any case), or from
//!   the content when the extension is unknown.
//!
//! Coordinates stay in the file's units. Polygons are split into triangles (a fan, or level by level for
//! large ones: [`crate::triangulate`]); duplicate vertices are
//! welded; degenerate triangles are dropped and counted (see [`crate::validate`]). Whether the
//! mesh is closed is a separate check, [`TriMesh::check_closed`], for the callers that need it.

use std::fmt;
use std::io::Cursor;
use std::path::Path;

use crate::validate::{clean_polygons, RawPolygons};
use crate::{MeshError, TriMesh};

/// A file format this crate reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ (only `v` and `f` matter).
    Obj,
    /// ASCII STL (`solid ... endsolid`).
    StlAscii,
    /// Binary STL (80-byte header, triangle count, 50 bytes per triangle).
    StlBinary,
    /// ASCII PLY.
    PlyAscii,
    /// Binary little-endian PLY.
    PlyBinaryLittleEndian,
    /// Binary big-endian PLY.
    PlyBinaryBigEndian,
}

impl fmt::Display for MeshFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            MeshFormat::Obj => "OBJ",
            MeshFormat::StlAscii => "ASCII STL",
            MeshFormat::StlBinary => "binary STL",
            MeshFormat::PlyAscii => "ASCII PLY",
            MeshFormat::PlyBinaryLittleEndian => "binary little-endian PLY",
            MeshFormat::PlyBinaryBigEndian => "binary big-endian PLY",
        })
    }
}

/// What loading found and changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoadReport {
    /// The format the file was read as.
    pub format: MeshFormat,
    /// Vertices stored in the file (for STL: 3 per triangle, as stored).
    pub file_vertices: usize,
    /// Faces (polygons) stored in the file.
    pub file_faces: usize,
    /// Triangles dropped as degenerate (a repeated vertex, or zero area).
    pub degenerate_dropped: usize,
    /// Vertices merged into an earlier vertex at exactly the same position.
    pub duplicates_welded: usize,
    /// Vertices removed because no triangle uses them.
    pub unreferenced_removed: usize,
}

/// A loaded mesh and the report of its cleaning.
#[derive(Clone, Debug)]
pub struct LoadedMesh {
    /// The validated mesh (file units).
    pub mesh: TriMesh,
    /// What loading found and changed.
    pub report: LoadReport,
}

/// Loads and validates a mesh file (see the module docs).
///
/// Errors (one line, naming the file): unreadable file, unknown format, a file that does not
/// follow its format (truncated, wrong counts), no face, NaN or infinite coordinates,
/// out-of-range indices, faces of fewer than 3 vertices, or only degenerate triangles.
pub fn load_mesh(path: &Path) -> Result<LoadedMesh, MeshError> {
    let bytes = crate::input::read_input(path, crate::input::MAX_MESH_BYTES).map_err(|error| {
        MeshError::Read {
            path: path.to_path_buf(),
            error,
        }
    })?;
    load_mesh_bytes(&bytes, path)
}

/// Like [`load_mesh`] on the contents `bytes` of a file; `path` gives the format (by its
/// extension, else by the content) and names the file in errors.
pub fn load_mesh_bytes(bytes: &[u8], path: &Path) -> Result<LoadedMesh, MeshError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let kind = match ext.as_str() {
        "obj" => Kind::Obj,
        "stl" => Kind::Stl,
        "ply" => Kind::Ply,
        _ => sniff(bytes).ok_or_else(|| MeshError::UnknownFormat {
            path: path.to_path_buf(),
            extension: ext.clone(),
        })?,
    };
    let (format, raw) = match kind {
        Kind::Obj => (MeshFormat::Obj, read_obj(bytes, path)?),
        Kind::Stl => read_stl(bytes, path)?,
        Kind::Ply => read_ply(bytes, path)?,
    };
    let file_vertices = raw.vertices.len();
    let file_faces = raw.arities.len();
    let (mesh, counts) = clean_polygons(raw, path)?;
    Ok(LoadedMesh {
        mesh,
        report: LoadReport {
            format,
            file_vertices,
            file_faces,
            degenerate_dropped: counts.degenerate_dropped,
            duplicates_welded: counts.duplicates_welded,
            unreferenced_removed: counts.unreferenced_removed,
        },
    })
}

#[derive(Clone, Copy)]
enum Kind {
    Obj,
    Stl,
    Ply,
}

/// Guesses the format from the content (for files without a known extension).
fn sniff(bytes: &[u8]) -> Option<Kind> {
    if bytes.starts_with(b"ply") {
        return Some(Kind::Ply);
    }
    if bytes.starts_with(b"solid") || binary_stl_size_matches(bytes) {
        return Some(Kind::Stl);
    }
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
    head.lines()
        .any(|l| l.starts_with("v ") || l.starts_with("f "))
        .then_some(Kind::Obj)
}

fn parse_error(path: &Path, format: &str, message: impl fmt::Display) -> MeshError {
    // Third-party messages may span lines; errors here are one line.
    let message = message
        .to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    MeshError::Parse {
        path: path.to_path_buf(),
        format: format.to_string(),
        message,
    }
}

// ---------------------------------------------------------------------------------------------
// OBJ

fn read_obj(bytes: &[u8], path: &Path) -> Result<RawPolygons, MeshError> {
    // A UTF-8 byte-order mark is not part of the first line (it would hide a `v` there and
    // shift every reported line).
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    // No triangulation (we fan ourselves), one index per vertex, geometry only.
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = Cursor::new(bytes);
    // Materials do not matter for geometry: never open .mtl files.
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| {
        if let Some(located) = locate_obj_problem(bytes) {
            return parse_error(path, "OBJ", located);
        }
        let hint = match e {
            tobj::LoadError::FaceVertexOutOfBounds => {
                " (a face refers to a vertex index that does not exist)"
            }
            tobj::LoadError::FaceParseError => " (a face line `f ...` is malformed)",
            tobj::LoadError::PositionParseError => " (a vertex line `v x y z` is malformed)",
            _ => "",
        };
        parse_error(path, "OBJ", format!("{e}{hint}"))
    })?;
    if models.iter().all(|m| m.mesh.indices.is_empty()) {
        if let Some(located) = locate_obj_problem(bytes) {
            return Err(parse_error(path, "OBJ", located));
        }
        // tobj keeps only the vertices faces use; count the file's own `v` lines.
        let n_v = bytes
            .split(|&b| b == b'\n')
            .filter(|l| l.trim_ascii_start().starts_with(b"v "))
            .count();
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
            detail: format!(
                "the file has {n_v} vertices and no face (`f` line); export the surface as triangles"
            ),
        });
    }
    // tobj numbers each object's vertices on its own; concatenate (welding joins the seams).
    let mut raw = RawPolygons::default();
    for model in &models {
        let m = &model.mesh;
        let base = raw.vertices.len() as i64;
        raw.vertices
            .extend(m.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));
        raw.indices
            .extend(m.indices.iter().map(|&i| base + i64::from(i)));
        if m.face_arities.is_empty() {
            // Every face is a triangle.
            raw.arities
                .extend(std::iter::repeat_n(3, m.indices.len() / 3));
        } else {
            raw.arities.extend(m.face_arities.iter().copied());
        }
    }
    // tobj accepts non-finite numbers and drops `f` lines of 1 or 2 corners (as points or
    // lines): locate those in the text.
    let n_f = bytes
        .split(|&b| b == b'\n')
        .filter(|l| matches!(l.trim_ascii_start(), [b'f', b' ' | b'\t', ..]))
        .count();
    if n_f != raw.arities.len() || raw.vertices.iter().flatten().any(|c| !c.is_finite()) {
        if let Some(located) = locate_obj_problem(bytes) {
            return Err(parse_error(path, "OBJ", located));
        }
    }
    Ok(raw)
}

/// Finds the first `v` or `f` line that breaks the rules (tobj's errors carry no line number):
/// `line N: ...`, or `None` if no such line is found.
fn locate_obj_problem(bytes: &[u8]) -> Option<String> {
    let text = String::from_utf8_lossy(bytes);
    let mut n_vertices: i64 = 0;
    let mut n_texcoords: i64 = 0;
    let mut n_normals: i64 = 0;
    for (i, line) in text.lines().enumerate() {
        let lineno = i + 1;
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("vt") => n_texcoords += 1,
            Some("vn") => n_normals += 1,
            Some("v") => {
                let nums: Vec<&str> = tokens.collect();
                if nums.len() < 3 || nums.iter().any(|t| t.parse::<f64>().is_err()) {
                    return Some(format!(
                        "line {lineno}: vertex line `{}` needs three numbers `v x y z`",
                        line.trim()
                    ));
                }
                if nums
                    .iter()
                    .any(|t| t.parse::<f64>().is_ok_and(|v| !v.is_finite()))
                {
                    return Some(format!(
                        "line {lineno}: vertex line `{}` has a non-finite coordinate; fix or remove that vertex",
                        line.trim()
                    ));
                }
                n_vertices += 1;
            }
            Some("f") => {
                let corners: Vec<&str> = tokens.collect();
                if corners.len() < 3 {
                    return Some(format!(
                        "line {lineno}: face `{}` has {} vertices; a face needs at least 3",
                        line.trim(),
                        corners.len()
                    ));
                }
                for c in corners {
                    let first = c.split('/').next().unwrap_or("");
                    let Ok(ix) = first.parse::<i64>() else {
                        return Some(format!(
                            "line {lineno}: `{c}` is not a vertex reference (`f a b c`, `f a/t/n ...`)"
                        ));
                    };
                    // 1-based, or negative = counted back from the last vertex so far.
                    let resolved = if ix < 0 { n_vertices + ix + 1 } else { ix };
                    if ix == 0 {
                        return Some(format!(
                            "line {lineno}: face refers to vertex 0, but OBJ vertex numbers start at 1"
                        ));
                    }
                    if resolved < 1 || resolved > n_vertices {
                        return Some(format!(
                            "line {lineno}: face refers to vertex {ix}, but only {n_vertices} vertices are defined before this line"
                        ));
                    }
                    // `a/t/n`: texture and normal references are checked the same way.
                    for (part, what, count) in [
                        (c.split('/').nth(1), "texture coordinate (vt)", n_texcoords),
                        (c.split('/').nth(2), "normal (vn)", n_normals),
                    ] {
                        let Some(part) = part.filter(|p| !p.is_empty()) else {
                            continue;
                        };
                        let Ok(jx) = part.parse::<i64>() else {
                            return Some(format!(
                                "line {lineno}: `{c}`: `{part}` is not a {what} number"
                            ));
                        };
                        let resolved = if jx < 0 { count + jx + 1 } else { jx };
                        if jx == 0 || resolved < 1 || resolved > count {
                            return Some(format!(
                                "line {lineno}: face refers to {what} {jx}, but only {count} are defined before this line"
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    None
}

// ---------------------------------------------------------------------------------------------
// STL

fn binary_stl_size_matches(bytes: &[u8]) -> bool {
    bytes.len() >= 84 && {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        bytes.len() as u64 == 84 + 50 * n
    }
}

fn read_stl(bytes: &[u8], path: &Path) -> Result<(MeshFormat, RawPolygons), MeshError> {
    // Many exporters start binary files with "solid" too: an exact size match means binary.
    let binary = binary_stl_size_matches(bytes) || !bytes.starts_with(b"solid");
    let format = if binary {
        MeshFormat::StlBinary
    } else {
        MeshFormat::StlAscii
    };
    let fname = format.to_string();
    let data: std::borrow::Cow<[u8]> = if binary {
        if bytes.len() < 84 {
            return Err(parse_error(
                path,
                &fname,
                format!(
                    "{} bytes is shorter than the 84-byte header (ASCII STL must start with `solid`)",
                    bytes.len()
                ),
            ));
        }
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        let need = 84 + 50 * n;
        if (bytes.len() as u64) != need {
            let held = (bytes.len() as u64).saturating_sub(84) as f64 / 50.0;
            return Err(parse_error(
                path,
                &fname,
                format!(
                    "the header says {n} triangles ({need} bytes) but the file has {} bytes (room for {held} triangles): {}",
                    bytes.len(),
                    if (bytes.len() as u64) < need {
                        "truncated, or not an STL file"
                    } else {
                        "the triangle count is wrong, or data follows the triangles"
                    }
                ),
            ));
        }
        // Make sure the reader does not take a binary file whose header begins with "solid"
        // for ASCII.
        let mut owned = bytes[..need as usize].to_vec();
        owned[..5].copy_from_slice(b"\0\0\0\0\0");
        std::borrow::Cow::Owned(owned)
    } else {
        // The reader wants "solid " with a space; a bare "solid" line is valid STL too.
        let first_line_end = bytes
            .iter()
            .position(|&b| b == b'\n')
            .unwrap_or(bytes.len());
        if bytes[..first_line_end].trim_ascii() == b"solid" {
            let mut owned = b"solid mesh".to_vec();
            owned.extend_from_slice(&bytes[first_line_end..]);
            std::borrow::Cow::Owned(owned)
        } else {
            std::borrow::Cow::Borrowed(bytes)
        }
    };
    let mut cursor = Cursor::new(&data[..]);
    let reader =
        stl_io::create_stl_reader(&mut cursor).map_err(|e| parse_error(path, &fname, e))?;
    let mut raw = RawPolygons::default();
    for (i, tri) in reader.enumerate() {
        let tri = tri.map_err(|e| parse_error(path, &fname, format!("triangle {i}: {e}")))?;
        let base = raw.vertices.len() as i64;
        for (corner, v) in tri.vertices.iter().enumerate() {
            let p = [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])];
            if !p.iter().all(|c| c.is_finite()) {
                // STL has no vertex numbers: name the triangle instead.
                return Err(parse_error(
                    path,
                    &fname,
                    format!(
                        "triangle {i}, corner {corner} has a non-finite coordinate ({}, {}, {}); fix or remove that triangle",
                        p[0], p[1], p[2]
                    ),
                ));
            }
            raw.vertices.push(p);
        }
        raw.indices.extend([base, base + 1, base + 2]);
        raw.arities.push(3);
    }
    Ok((format, raw))
}

// ---------------------------------------------------------------------------------------------
// PLY

/// The PLY parser's error as a short clause: `line 4: cannot parse `bogus line``. Its own
/// text carries the parser's debug dump (`Custom { kind: .. }`, `ParseError { .. }`), which
/// says nothing to a user. `with_line`: the parser's line number is the file's (header);
/// in the payload it counts from the element's first line, so it is left out there.
fn ply_message(e: &dyn fmt::Display, with_line: bool) -> String {
    let text = e.to_string();
    let quoted = text
        .split("String: '")
        .nth(1)
        .and_then(|r| r.split('\'').next())
        .map(|q| {
            let q = q.trim();
            match q.char_indices().nth(60) {
                Some((at, _)) => format!("{}…", &q[..at]),
                None => q.to_string(),
            }
        });
    let line = text
        .strip_prefix("Line ")
        .and_then(|r| r.split(':').next())
        .and_then(|n| n.parse::<usize>().ok());
    match (quoted, line) {
        (Some(q), Some(n)) if with_line => format!("line {n}: cannot parse `{q}`"),
        (Some(q), _) => format!("cannot parse `{q}`"),
        // Anything else: its first line, without a debug dump.
        _ => {
            let first = text.lines().next().unwrap_or("").trim();
            first.split(" Error: ").next().unwrap_or(first).to_string()
        }
    }
}

fn read_ply(bytes: &[u8], path: &Path) -> Result<(MeshFormat, RawPolygons), MeshError> {
    use ply_rs::parser::Parser;
    use ply_rs::ply::{DefaultElement, Encoding, Property};

    check_ply_element_counts(bytes, path)?;
    let parser = Parser::<DefaultElement>::new();
    let mut reader = std::io::BufReader::new(Cursor::new(bytes));
    let header = parser
        .read_header(&mut reader)
        .map_err(|e| parse_error(path, "PLY", format!("header {}", ply_message(&e, true))))?;
    let format = match header.encoding {
        Encoding::Ascii => MeshFormat::PlyAscii,
        Encoding::BinaryLittleEndian => MeshFormat::PlyBinaryLittleEndian,
        Encoding::BinaryBigEndian => MeshFormat::PlyBinaryBigEndian,
    };
    let fname = format.to_string();
    let mut raw = RawPolygons::default();
    let mut saw_vertex = false;
    for (name, def) in &header.elements {
        // Elements come in header order; read each (also those we skip) to stay in step.
        let elements = parser
            .read_payload_for_element(&mut reader, def, &header)
            .map_err(|e| {
                parse_error(
                    path,
                    &fname,
                    format!(
                        "element `{name}` (header says {}): {}",
                        def.count,
                        ply_message(&e, false)
                    ),
                )
            })?;
        match name.as_str() {
            "vertex" => {
                saw_vertex = true;
                for key in ["x", "y", "z"] {
                    if !def.properties.contains_key(key) {
                        return Err(parse_error(
                            path,
                            &fname,
                            format!("element `vertex` has no property `{key}`"),
                        ));
                    }
                }
                raw.vertices.reserve(elements.len());
                for (i, e) in elements.iter().enumerate() {
                    let mut p = [0.0; 3];
                    for (k, key) in ["x", "y", "z"].iter().enumerate() {
                        p[k] = e.get(*key).and_then(scalar).ok_or_else(|| {
                            parse_error(
                                path,
                                &fname,
                                format!("vertex {i}: property `{key}` is not a number"),
                            )
                        })?;
                    }
                    raw.vertices.push(p);
                }
            }
            "face" => {
                let key = ["vertex_indices", "vertex_index"]
                    .into_iter()
                    .find(|k| def.properties.contains_key(*k))
                    .ok_or_else(|| {
                        parse_error(
                            path,
                            &fname,
                            "element `face` has no list property `vertex_indices` or `vertex_index`",
                        )
                    })?;
                for (i, e) in elements.iter().enumerate() {
                    let before = raw.indices.len();
                    match e.get(key) {
                        Some(Property::ListChar(v)) => {
                            raw.indices.extend(v.iter().map(|&x| i64::from(x)))
                        }
                        Some(Property::ListUChar(v)) => {
                            raw.indices.extend(v.iter().map(|&x| i64::from(x)))
                        }
                        Some(Property::ListShort(v)) => {
                            raw.indices.extend(v.iter().map(|&x| i64::from(x)))
                        }
                        Some(Property::ListUShort(v)) => {
                            raw.indices.extend(v.iter().map(|&x| i64::from(x)))
                        }
                        Some(Property::ListInt(v)) => {
                            raw.indices.extend(v.iter().map(|&x| i64::from(x)))
                        }
                        Some(Property::ListUInt(v)) => {
                            raw.indices.extend(v.iter().map(|&x| i64::from(x)))
                        }
                        _ => {
                            return Err(parse_error(
                                path,
                                &fname,
                                format!("face {i}: `{key}` is not a list of integers"),
                            ))
                        }
                    }
                    raw.arities.push((raw.indices.len() - before) as u32);
                }
            }
            _ => {}
        }
    }
    // More data than the header declares (e.g. `element face 12` followed by 24 faces): the
    // counts are wrong, and loading the declared part would silently drop the rest.
    let mut rest = Vec::new();
    std::io::Read::read_to_end(&mut reader, &mut rest).map_err(|e| parse_error(path, &fname, e))?;
    if !rest.iter().all(u8::is_ascii_whitespace) {
        let declared: Vec<String> = header
            .elements
            .iter()
            .map(|(n, d)| format!("{} {n}", d.count))
            .collect();
        return Err(parse_error(
            path,
            &fname,
            format!(
                "{} bytes of data follow the last element: the header's counts ({}) are smaller than the data",
                rest.len(),
                declared.join(", ")
            ),
        ));
    }
    if !saw_vertex {
        return Err(parse_error(
            path,
            &fname,
            "no `vertex` element in the header",
        ));
    }
    Ok((format, raw))
}

/// Checks a PLY header before ply-rs reads it, wherever the header ends (any number of
/// `comment` lines): numbers on `format` / `element` lines must fit in 64 bits (ply-rs panics
/// on longer ones), and the elements must fit in the bytes after the header, counting the
/// fewest bytes each element can take (ply-rs would otherwise allocate for a count of 10^11,
/// an abort, or loop that many times on an element without properties, a hang).
fn check_ply_element_counts(bytes: &[u8], path: &Path) -> Result<(), MeshError> {
    struct Declared {
        name: String,
        count: u64,
        line: usize,
        /// Fewest bytes one element takes (ASCII: 2 per property; binary: the scalar sizes).
        min_bytes: u64,
    }
    let mut ascii = true;
    let mut elements: Vec<Declared> = Vec::new();
    let mut offset = 0usize;
    let mut header_end = None;
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        offset = offset.saturating_add(raw.len() + 1);
        let line = String::from_utf8_lossy(raw);
        let mut tokens = line.split_whitespace();
        let first = tokens.next();
        let bad = |what: String| {
            parse_error(
                path,
                "PLY",
                format!("header line {}: {what}; the header is corrupt", i + 1),
            )
        };
        match first {
            Some("end_header") => {
                header_end = Some(offset.min(bytes.len()));
                break;
            }
            Some("format" | "element") => {
                for run in line
                    .split(|c: char| !c.is_ascii_digit())
                    .filter(|r| !r.is_empty())
                {
                    if run.parse::<u64>().is_err() {
                        return Err(bad(format!("number {run} is too large")));
                    }
                }
                if first == Some("format") {
                    ascii = tokens.next() == Some("ascii");
                } else {
                    let name = tokens.next().unwrap_or("").to_string();
                    // A malformed count is ply-rs's to report (with its own message).
                    if let Ok(count) = tokens.next().unwrap_or("").parse::<u64>() {
                        elements.push(Declared {
                            name,
                            count,
                            line: i + 1,
                            min_bytes: 0,
                        });
                    }
                }
            }
            Some("property") => {
                if let Some(e) = elements.last_mut() {
                    let ty = match tokens.next() {
                        Some("list") => tokens.next().unwrap_or(""),
                        Some(t) => t,
                        None => "",
                    };
                    e.min_bytes += if ascii {
                        2
                    } else {
                        match ty {
                            "char" | "uchar" | "int8" | "uint8" => 1,
                            "short" | "ushort" | "int16" | "uint16" => 2,
                            "double" | "float64" => 8,
                            _ => 4,
                        }
                    };
                }
            }
            _ => {}
        }
    }
    // No `end_header`: ply-rs says so.
    let Some(end) = header_end else {
        return Ok(());
    };
    let body = (bytes.len() - end) as u128;
    let mut need: u128 = 0;
    for e in &elements {
        // At least one byte per element, so an element without properties cannot loop.
        need += u128::from(e.count) * u128::from(e.min_bytes.max(1));
        // The last ASCII value may lack its separator.
        if need > body + u128::from(ascii) {
            return Err(parse_error(
                path,
                "PLY",
                format!(
                    "header line {}: element `{}` count {} does not fit in the {body} bytes after the header (at least {} bytes each); the header is corrupt",
                    e.line,
                    e.name,
                    e.count,
                    e.min_bytes.max(1)
                ),
            ));
        }
    }
    Ok(())
}

/// A numeric PLY scalar as f64.
fn scalar(p: &ply_rs::ply::Property) -> Option<f64> {
    use ply_rs::ply::Property;
    Some(match *p {
        Property::Float(v) => f64::from(v),
        Property::Double(v) => v,
        Property::Char(v) => f64::from(v),
        Property::UChar(v) => f64::from(v),
        Property::Short(v) => f64::from(v),
        Property::UShort(v) => f64::from(v),
        Property::Int(v) => f64::from(v),
        Property::UInt(v) => f64::from(v),
        _ => return None,
    })
}
