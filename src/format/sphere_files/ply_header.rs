//! A PLY header: its `format`, its elements and their properties, and which vertex properties
//! hold a sphere's fields.

use std::io::BufRead;

use super::header::{quoted, HeaderLines, CR_ALONE};
use super::listing::{FileProblem, Location};
use super::look::{Column, Kind, Layout};
use super::text::{text_f32, text_f64};
use crate::format::SphereFileSpec;

/// A PLY property's scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

/// Each scalar type, in the order of [`Scalar`]: its two names in a header (the first is the
/// one messages use) and its size in bytes.
const SCALARS: [(Scalar, [&str; 2], usize); 8] = [
    (Scalar::I8, ["char", "int8"], 1),
    (Scalar::U8, ["uchar", "uint8"], 1),
    (Scalar::I16, ["short", "int16"], 2),
    (Scalar::U16, ["ushort", "uint16"], 2),
    (Scalar::I32, ["int", "int32"], 4),
    (Scalar::U32, ["uint", "uint32"], 4),
    (Scalar::F32, ["float", "float32"], 4),
    (Scalar::F64, ["double", "float64"], 8),
];

// The table is looked up by the variant's position.
const _: () = {
    let mut k = 0;
    while k < SCALARS.len() {
        assert!(SCALARS[k].0 as usize == k, "SCALARS in the order of Scalar");
        k += 1;
    }
};

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        SCALARS.iter().find(|s| s.1.contains(&name)).map(|s| s.0)
    }

    /// The type's name in a header.
    pub fn name(self) -> &'static str {
        SCALARS[self as usize].1[0]
    }

    /// Whether a list's count may be of this type.
    fn counts(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The value of an ASCII body's word, read as this type (a `float` rounded to f32, as a
    /// binary body stores it, an integer type in its range) and widened exactly to f64; None
    /// when the word is not one.
    pub fn ascii(self, w: &str) -> Option<f64> {
        match self {
            Scalar::F32 => text_f32(w).map(f64::from),
            Scalar::F64 => text_f64(w),
            // Read as an i64 (so `-0` is a uchar's 0, as C's readers take it), then kept to
            // the type's range.
            _ => {
                let (lo, hi) = match self {
                    Scalar::I8 => (i8::MIN.into(), i8::MAX.into()),
                    Scalar::U8 => (0, u8::MAX.into()),
                    Scalar::I16 => (i16::MIN.into(), i16::MAX.into()),
                    Scalar::U16 => (0, u16::MAX.into()),
                    Scalar::I32 => (i32::MIN.into(), i32::MAX.into()),
                    _ => (0, u32::MAX.into()),
                };
                let v: i64 = w.parse().ok().filter(|v| (lo..=hi).contains(v))?;
                Some(v as f64)
            }
        }
    }

    pub fn size(self) -> usize {
        SCALARS[self as usize].2
    }

    /// The value of little-endian `b` (exactly `size` bytes), widened exactly to f64.
    #[inline(always)]
    pub fn le(self, b: &[u8]) -> f64 {
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            Scalar::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            Scalar::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F64 => f64::from_le_bytes(b.try_into().expect("8 bytes")),
        }
    }
}

/// A PLY property: a scalar, or a list (count type, item type), with its name.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Property {
    Scalar(Scalar, String),
    List(Scalar, Scalar, String),
}

impl Property {
    fn name(&self) -> &str {
        match self {
            Property::Scalar(_, name) | Property::List(_, _, name) => name,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub(super) struct Element {
    pub name: String,
    pub count: usize,
    pub properties: Vec<Property>,
}
/// What a PLY header says of its body.
pub(super) struct Header {
    /// Binary little-endian, or ASCII.
    pub binary: bool,
    pub elements: Vec<Element>,
    /// Which element is `vertex`.
    pub vertex: usize,
    pub layout: Layout,
    /// The body's first line.
    pub first_line: usize,
    /// Whether nothing follows the vertices.
    pub last: bool,
}

/// The header of a PLY file, read up to its `end_header` line.
pub(super) fn header(mut file: impl BufRead, spec: &SphereFileSpec) -> Result<Header, FileProblem> {
    // The header is ASCII lines up to `end_header`.
    let mut lines = HeaderLines::new("is `end_header` missing?", true);
    let bad = |n: usize, m: String| FileProblem::at(Location::Line(n), m);
    let head = file.fill_buf().map_err(FileProblem::io)?;
    if head.starts_with(b"ply\r") && head.get(4) != Some(&b'\n') {
        return Err(FileProblem::whole(format!("not read as PLY: {CR_ALONE}")));
    }
    match lines.next(&mut file) {
        Ok(Some((_, l))) if l == "ply" => {}
        // A file that cannot be read is named so; a first line too long is no PLY either.
        Err(e) if e.at.is_none() => return Err(e),
        _ => {
            return Err(FileProblem::whole(
                "not a PLY file: it must start with `ply`",
            ))
        }
    }
    let mut binary = None;
    let mut elements: Vec<Element> = Vec::new();
    // The lines of the `format` and `element vertex` lines, each allowed once.
    let (mut format_at, mut vertex_at) = (None, None);
    loop {
        let Some((n, line)) = lines.next(&mut file)? else {
            return Err(FileProblem::whole("the header has no `end_header`"));
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        let once = |at: &mut Option<usize>, what: &str| match at.replace(n) {
            Some(first) => Err(bad(
                n,
                format!("a second `{what}` line (the first is line {first})"),
            )),
            None => Ok(()),
        };
        match words.as_slice() {
            ["end_header"] => break,
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["format", form, version] => {
                once(&mut format_at, "format")?;
                binary = match *form {
                    "ascii" => Some(false),
                    "binary_little_endian" => Some(true),
                    other => {
                        return Err(bad(
                            n,
                            format!(
                                "format {other} is not read: write ascii or binary_little_endian"
                            ),
                        ))
                    }
                };
                if *version != "1.0" {
                    return Err(bad(
                        n,
                        format!("format version {}: PLY 1.0 is read", quoted(version)),
                    ));
                }
            }
            ["element", name, count] => {
                if *name == "vertex" {
                    once(&mut vertex_at, "element vertex")?;
                }
                elements.push(Element {
                    name: name.to_string(),
                    count: count.parse().map_err(|_| {
                        bad(
                            n,
                            format!("element count {} is not a number", quoted(count)),
                        )
                    })?,
                    properties: Vec::new(),
                })
            }
            ["property", "list", count, item, name] => {
                let (Some(c), Some(i)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(bad(n, format!("unknown list types in {}", quoted(&line))));
                };
                if !c.counts() {
                    return Err(bad(
                        n,
                        format!("a list's count is an integer type, not {}", c.name()),
                    ));
                }
                let e = last_element(&mut elements, name).map_err(|m| bad(n, m))?;
                e.properties.push(Property::List(c, i, name.to_string()));
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty)
                    .ok_or_else(|| bad(n, format!("unknown type {}", quoted(ty))))?;
                let e = last_element(&mut elements, name).map_err(|m| bad(n, m))?;
                e.properties.push(Property::Scalar(ty, name.to_string()));
            }
            _ => return Err(bad(n, format!("not a PLY header line: {}", quoted(&line)))),
        }
    }
    let binary = binary.ok_or_else(|| FileProblem::whole("the header has no `format` line"))?;
    let vertex = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| FileProblem::whole("the header has no `element vertex`"))?;
    let layout = layout(&elements[vertex], spec)?;
    // Whether the vertices end the body: then nothing may follow them.
    let last = (elements[vertex + 1..].iter()).all(|e| e.count == 0 || e.properties.is_empty());
    Ok(Header {
        binary,
        elements,
        vertex,
        layout,
        first_line: lines.line + 1,
        last,
    })
}

/// The element a `property` line adds to (the last), refusing a property named twice.
fn last_element<'a>(elements: &'a mut [Element], name: &str) -> Result<&'a mut Element, String> {
    let e = elements
        .last_mut()
        .ok_or_else(|| "a property before any element".to_string())?;
    match e.properties.iter().any(|p| p.name() == name) {
        true => Err(format!(
            "element {} has a second property {}",
            e.name,
            quoted(name)
        )),
        false => Ok(e),
    }
}

/// The layout of a vertex's properties ([`Layout`]): colours of `uchar` are bytes (0–255),
/// of `float` or `double` levels (0–1).
fn layout(vertex: &Element, spec: &SphereFileSpec) -> Result<Layout, FileProblem> {
    let columns: Vec<Column> = (vertex.properties.iter())
        .map(|p| match p {
            Property::Scalar(_, name) => Column {
                name: name.clone(),
                kind: Kind::Number,
            },
            Property::List(_, _, name) => Column {
                name: name.clone(),
                kind: Kind::List,
            },
        })
        .collect();
    let mut layout = Layout::resolve(spec, &columns)
        .map_err(|m| FileProblem::whole(format!("element vertex: {m}")))?;
    if let Some(rgb) = layout.color_columns() {
        let types = rgb.map(|k| match &vertex.properties[k] {
            Property::Scalar(t, _) => *t,
            Property::List(..) => unreachable!("a list is never a colour"),
        });
        if types.iter().all(|t| *t == Scalar::U8) {
            layout.color_bytes();
        } else if !types.iter().all(|t| matches!(t, Scalar::F32 | Scalar::F64)) {
            return Err(FileProblem::whole(
                "red, green and blue must all be uchar (0–255) or all float or double (0–1)",
            ));
        }
    }
    Ok(layout)
}

/// Each vertex property's byte offset and type, when all are scalars: a vertex is then a
/// fixed number of bytes, and the body can be cut anywhere between vertices.
pub(super) fn fixed_offsets(v: &Element) -> Option<Vec<(usize, Scalar)>> {
    let mut at = 0;
    v.properties
        .iter()
        .map(|p| match p {
            Property::Scalar(t, _) => {
                at += t.size();
                Some((at - t.size(), *t))
            }
            Property::List(..) => None,
        })
        .collect()
}
