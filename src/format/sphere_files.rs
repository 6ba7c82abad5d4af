//! Sphere files: spheres kept outside the keyframe file, as PLY (ASCII or binary little-endian)
//! or CSV, the forms particle systems, point clouds and molecule tools write.
//!
//! - **PLY**: `element vertex N` with `x`, `y`, `z` and `radius` (any numeric type), and
//!   optionally `red`, `green`, `blue`: `uchar` 0–255 (divided by 255) or `float`/`double` 0–1.
//!   Other properties and elements are read past.
//! - **CSV**: a header `x,y,z,radius` or `x,y,z,radius,r,g,b` (colours 0–1), then one sphere a
//!   line; blank lines are skipped.
//!
//! Numbers are read exactly: a `double` in PLY, or a number in CSV (through `f64::from_str`, as
//! RON reads its floats), gives the same bits as the same number in RON. Nothing is checked here
//! beyond the form; [`crate::document`] checks the values as it checks inline spheres.

use std::path::Path;

use super::{SphereSpec, Triple};

/// Where in a sphere file a sphere or a problem is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// A PLY vertex, from 0.
    Vertex(usize),
    /// A line of text, from 1 (CSV, and PLY headers).
    Line(usize),
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Location::Vertex(v) => write!(f, "vertex {v}"),
            Location::Line(l) => write!(f, "line {l}"),
        }
    }
}

/// What is wrong with a sphere file's form, and where.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileProblem {
    /// Where in the file, when the problem has a place (not for a missing header line).
    pub at: Option<Location>,
    /// What is wrong.
    pub message: String,
}

impl FileProblem {
    fn at(at: Location, message: impl Into<String>) -> FileProblem {
        FileProblem {
            at: Some(at),
            message: message.into(),
        }
    }

    fn whole(message: impl Into<String>) -> FileProblem {
        FileProblem {
            at: None,
            message: message.into(),
        }
    }
}

/// A sphere file's spheres, unchecked, in file order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Spheres {
    /// The spheres, unchecked, in file order.
    pub spheres: Vec<SphereSpec>,
    /// Each sphere's line, for a text file whose lines are not one a sphere (CSV with blank
    /// lines); empty when sphere `i` is at [`Spheres::location`]'s default.
    lines: Vec<u32>,
    /// The line of the first sphere in a text file, or None for PLY vertices.
    first_line: Option<usize>,
}

impl Spheres {
    /// Where sphere `i` is in its file.
    pub fn location(&self, i: usize) -> Location {
        match (self.first_line, self.lines.get(i)) {
            (_, Some(line)) => Location::Line(*line as usize),
            (Some(first), None) => Location::Line(first + i),
            (None, None) => Location::Vertex(i),
        }
    }
}

/// Reads a sphere file, by its extension: `.ply` or `.csv`.
pub fn read(path: &Path) -> Result<Spheres, FileProblem> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let bytes = std::fs::read(path).map_err(|e| FileProblem::whole(format!("cannot read: {e}")))?;
    match ext.as_deref() {
        Some("ply") => ply(&bytes),
        Some("csv") => csv(&bytes),
        _ => Err(FileProblem::whole(
            "a sphere file is .ply or .csv (by its extension)",
        )),
    }
}

/// The CSV form.
pub fn csv(bytes: &[u8]) -> Result<Spheres, FileProblem> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|b| **b == b'\n')
            .count()
            + 1;
        FileProblem::at(Location::Line(line), "not UTF-8 text")
    })?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let header = loop {
        match lines.next() {
            None => return Err(FileProblem::whole("empty: expected a header x,y,z,radius")),
            Some((_, l)) if l.trim().is_empty() => continue,
            Some((n, l)) => break (n, l),
        }
    };
    let names: Vec<&str> = header.1.split(',').map(str::trim).collect();
    let colours = match names.as_slice() {
        ["x", "y", "z", "radius"] => false,
        ["x", "y", "z", "radius", "r", "g", "b"] => true,
        _ => {
            return Err(FileProblem::at(
                Location::Line(header.0),
                format!(
                    "the header must be x,y,z,radius or x,y,z,radius,r,g,b, got {:?}",
                    header.1
                ),
            ))
        }
    };
    let mut out = Spheres {
        first_line: Some(header.0 + 1),
        ..Spheres::default()
    };
    let mut gaps = false;
    for (n, line) in lines {
        if line.trim().is_empty() {
            gaps = true;
            continue;
        }
        let at = Location::Line(n);
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != names.len() {
            return Err(FileProblem::at(
                at,
                format!(
                    "expected {} fields ({}), got {}",
                    names.len(),
                    names.join(","),
                    fields.len()
                ),
            ));
        }
        let number = |k: usize| {
            fields[k].parse::<f64>().map_err(|_| {
                FileProblem::at(at, format!("{}: not a number: {:?}", names[k], fields[k]))
            })
        };
        let triple = |k: usize| -> Result<Triple, FileProblem> {
            Ok((number(k)?, number(k + 1)?, number(k + 2)?))
        };
        out.spheres.push(SphereSpec {
            center: triple(0)?,
            radius: number(3)?,
            color: if colours { Some(triple(4)?) } else { None },
        });
        out.lines.push(n as u32);
    }
    if !gaps {
        // Every sphere on the line after the one before: the lines need not be kept.
        out.lines = Vec::new();
    }
    Ok(out)
}

/// A PLY property's scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The value of little-endian `b` (exactly `size` bytes), widened exactly to f64.
    fn le(self, b: &[u8]) -> f64 {
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

/// A PLY property: a scalar, or a list (count type, item type).
#[derive(Debug, Clone, PartialEq)]
enum Property {
    Scalar(Scalar, String),
    List(Scalar, Scalar),
}

#[derive(Debug, Clone, PartialEq)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

/// The PLY form.
pub fn ply(bytes: &[u8]) -> Result<Spheres, FileProblem> {
    // The header is ASCII lines up to `end_header`.
    let mut pos = 0;
    let mut line_no = 0;
    let mut next_line = |pos: &mut usize| -> Option<(usize, String)> {
        let rest = bytes.get(*pos..)?;
        let end = rest.iter().position(|b| *b == b'\n')?;
        *pos += end + 1;
        line_no += 1;
        let line = String::from_utf8_lossy(&rest[..end]);
        Some((line_no, line.trim_end_matches('\r').trim().to_string()))
    };
    let bad = |n: usize, m: String| FileProblem::at(Location::Line(n), m);
    match next_line(&mut pos) {
        Some((_, l)) if l == "ply" => {}
        _ => {
            return Err(FileProblem::whole(
                "not a PLY file: it must start with `ply`",
            ))
        }
    }
    let mut binary = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some((n, line)) = next_line(&mut pos) else {
            return Err(FileProblem::whole("the header has no `end_header`"));
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["end_header"] => break,
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["format", "ascii", _] => binary = Some(false),
            ["format", "binary_little_endian", _] => binary = Some(true),
            ["format", other, _] => {
                return Err(bad(
                    n,
                    format!("format {other} is not read: write ascii or binary_little_endian"),
                ))
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| bad(n, format!("element count {count:?} is not a number")))?,
                properties: Vec::new(),
            }),
            ["property", "list", count, item, _] => {
                let (Some(c), Some(i)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(bad(n, format!("unknown list types in {line:?}")));
                };
                let e = elements
                    .last_mut()
                    .ok_or_else(|| bad(n, "a property before any element".into()))?;
                e.properties.push(Property::List(c, i));
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty).ok_or_else(|| bad(n, format!("unknown type {ty:?}")))?;
                let e = elements
                    .last_mut()
                    .ok_or_else(|| bad(n, "a property before any element".into()))?;
                e.properties.push(Property::Scalar(ty, name.to_string()));
            }
            _ => return Err(bad(n, format!("not a PLY header line: {line:?}"))),
        }
    }
    let binary = binary.ok_or_else(|| FileProblem::whole("the header has no `format` line"))?;
    let vertex = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| FileProblem::whole("the header has no `element vertex`"))?;
    let columns = Columns::of(&elements[vertex])?;
    let body = &bytes[pos..];
    if binary {
        binary_vertices(body, &elements, vertex, &columns)
    } else {
        ascii_vertices(body, line_no + 1, &elements, vertex, &columns)
    }
}

/// Which scalar of a vertex holds each sphere field, and whether colours are bytes.
struct Columns {
    xyz_radius: [usize; 4],
    rgb: Option<[usize; 3]>,
    rgb_bytes: bool,
}

impl Columns {
    fn of(vertex: &Element) -> Result<Columns, FileProblem> {
        let find = |name: &str| {
            vertex.properties.iter().position(|p| match p {
                Property::Scalar(_, n) => n == name,
                Property::List(..) => false,
            })
        };
        let mut xyz_radius = [0; 4];
        for (slot, name) in xyz_radius.iter_mut().zip(["x", "y", "z", "radius"]) {
            *slot = find(name).ok_or_else(|| {
                FileProblem::whole(format!("element vertex has no property {name}"))
            })?;
        }
        let rgb = match (find("red"), find("green"), find("blue")) {
            (Some(r), Some(g), Some(b)) => Some([r, g, b]),
            (None, None, None) => None,
            _ => {
                return Err(FileProblem::whole(
                    "element vertex has some of red, green, blue but not all three",
                ))
            }
        };
        let rgb_bytes = match rgb {
            Some(c) => {
                let types: Vec<Scalar> = c
                    .iter()
                    .map(|&k| match &vertex.properties[k] {
                        Property::Scalar(t, _) => *t,
                        Property::List(..) => unreachable!("found among scalars"),
                    })
                    .collect();
                if types.iter().all(|t| *t == Scalar::U8) {
                    true
                } else if types.iter().all(|t| matches!(t, Scalar::F32 | Scalar::F64)) {
                    false
                } else {
                    return Err(FileProblem::whole(
                        "red, green and blue must all be uchar (0–255) or all float or double (0–1)",
                    ));
                }
            }
            None => false,
        };
        Ok(Columns {
            xyz_radius,
            rgb,
            rgb_bytes,
        })
    }

    fn sphere(&self, values: &[f64]) -> SphereSpec {
        let [x, y, z, r] = self.xyz_radius.map(|k| values[k]);
        // A byte's level k is k / 255, as the same colour written in RON.
        let c = |k: usize| {
            if self.rgb_bytes {
                values[k] / 255.0
            } else {
                values[k]
            }
        };
        SphereSpec {
            center: (x, y, z),
            radius: r,
            color: self.rgb.map(|[r, g, b]| (c(r), c(g), c(b))),
        }
    }
}

fn binary_vertices(
    body: &[u8],
    elements: &[Element],
    vertex: usize,
    columns: &Columns,
) -> Result<Spheres, FileProblem> {
    let mut pos = 0;
    let take = |pos: &mut usize, n: usize| -> Option<&[u8]> {
        let b = body.get(*pos..*pos + n)?;
        *pos += n;
        Some(b)
    };
    // Elements before the vertices are read past, lists included.
    for e in &elements[..vertex] {
        for i in 0..e.count {
            for p in &e.properties {
                let cut = || {
                    FileProblem::whole(format!(
                        "truncated: the body ends inside element {} {i} (before the vertices)",
                        e.name
                    ))
                };
                match p {
                    Property::Scalar(t, _) => {
                        take(&mut pos, t.size()).ok_or_else(cut)?;
                    }
                    Property::List(c, t) => {
                        let n = c.le(take(&mut pos, c.size()).ok_or_else(cut)?);
                        take(&mut pos, n as usize * t.size()).ok_or_else(cut)?;
                    }
                }
            }
        }
    }
    let v = &elements[vertex];
    let mut out = Spheres::default();
    out.spheres.reserve(v.count.min(body.len()));
    let mut values = vec![0.0; v.properties.len()];
    for i in 0..v.count {
        for (k, p) in v.properties.iter().enumerate() {
            let cut = || {
                FileProblem::at(
                    Location::Vertex(i),
                    format!(
                        "truncated: the body ends inside vertex {i} of the header's {}",
                        v.count
                    ),
                )
            };
            match p {
                Property::Scalar(t, _) => {
                    values[k] = t.le(take(&mut pos, t.size()).ok_or_else(cut)?)
                }
                Property::List(c, t) => {
                    let n = c.le(take(&mut pos, c.size()).ok_or_else(cut)?);
                    take(&mut pos, n as usize * t.size()).ok_or_else(cut)?;
                }
            }
        }
        out.spheres.push(columns.sphere(&values));
    }
    Ok(out)
}

fn ascii_vertices(
    body: &[u8],
    first_line: usize,
    elements: &[Element],
    vertex: usize,
    columns: &Columns,
) -> Result<Spheres, FileProblem> {
    let text = std::str::from_utf8(body).map_err(|_| FileProblem::whole("the body is not text"))?;
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (first_line + i, l))
        .filter(|(_, l)| !l.trim().is_empty());
    for e in &elements[..vertex] {
        for i in 0..e.count {
            lines.next().ok_or_else(|| {
                FileProblem::whole(format!(
                    "truncated: the body ends at element {} {i} (before the vertices)",
                    e.name
                ))
            })?;
        }
    }
    let v = &elements[vertex];
    let mut out = Spheres::default();
    let mut values = vec![0.0; v.properties.len()];
    for i in 0..v.count {
        let Some((n, line)) = lines.next() else {
            return Err(FileProblem::at(
                Location::Vertex(i),
                format!("truncated: the file ends at vertex {i} of {}", v.count),
            ));
        };
        let at = Location::Line(n);
        let mut words = line.split_whitespace();
        for (k, p) in v.properties.iter().enumerate() {
            let mut word = |what: &str| {
                words.next().ok_or_else(|| {
                    FileProblem::at(at, format!("vertex {i}: a short row: no value for {what}"))
                })
            };
            match p {
                Property::Scalar(_, name) => {
                    let w = word(name)?;
                    values[k] = w.parse().map_err(|_| {
                        FileProblem::at(at, format!("vertex {i}: {name}: not a number: {w:?}"))
                    })?;
                }
                Property::List(..) => {
                    let w = word("a list's count")?;
                    let count: usize = w.parse().map_err(|_| {
                        FileProblem::at(
                            at,
                            format!("vertex {i}: a list count that is not a number: {w:?}"),
                        )
                    })?;
                    for _ in 0..count {
                        word("a list item")?;
                    }
                }
            }
        }
        if words.next().is_some() {
            return Err(FileProblem::at(
                at,
                format!("vertex {i}: more values than the header's properties"),
            ));
        }
        out.spheres.push(columns.sphere(&values));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(c: Triple, r: f64, color: Option<Triple>) -> SphereSpec {
        SphereSpec {
            center: c,
            radius: r,
            color,
        }
    }

    #[test]
    fn csv_with_and_without_colours() {
        let s = csv(b"x,y,z,radius\n1,2,3,0.5\n\n-1e3, .5, 7., 2\n").unwrap();
        assert_eq!(
            s.spheres,
            [
                sphere((1.0, 2.0, 3.0), 0.5, None),
                sphere((-1000.0, 0.5, 7.0), 2.0, None)
            ]
        );
        assert_eq!(s.location(1), Location::Line(4));
        let s = csv(b"x, y, z, radius, r, g, b\r\n0,0,0,1,0.25,0.5,1\r\n").unwrap();
        assert_eq!(
            s.spheres,
            [sphere((0.0, 0.0, 0.0), 1.0, Some((0.25, 0.5, 1.0)))]
        );
        assert_eq!(s.location(0), Location::Line(2));
        for (bad, at) in [
            (&b"x,y,radius\n"[..], Some(Location::Line(1))),
            (b"x,y,z,radius\n1,2,3\n", Some(Location::Line(2))),
            (b"x,y,z,radius\n1,2,3,4\n1,2,x,4\n", Some(Location::Line(3))),
            (b"", None),
        ] {
            assert_eq!(
                csv(bad).unwrap_err().at,
                at,
                "{}",
                String::from_utf8_lossy(bad)
            );
        }
    }

    fn header(format: &str, props: &str, n: usize) -> Vec<u8> {
        format!(
            "ply\nformat {format} 1.0\ncomment made by a test\nelement vertex {n}\n{props}end_header\n"
        )
        .into_bytes()
    }

    #[test]
    fn ply_ascii_and_binary_read_the_same_spheres() {
        let props = "property float x\nproperty float y\nproperty double z\nproperty double radius\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty list uchar int extra\n";
        let mut ascii = header("ascii", props, 2);
        ascii.extend_from_slice(b"1.5 -2 3.25 0.5 255 128 0 2 7 8\n0 0 0.1 1 0 0 0 0\n");
        let mut bin = header("binary_little_endian", props, 2);
        for (x, y, z, r, c, list) in [
            (
                1.5f32,
                -2f32,
                3.25f64,
                0.5f64,
                [255u8, 128, 0],
                vec![7i32, 8],
            ),
            (0.0, 0.0, 0.1, 1.0, [0, 0, 0], vec![]),
        ] {
            bin.extend(x.to_le_bytes());
            bin.extend(y.to_le_bytes());
            bin.extend(z.to_le_bytes());
            bin.extend(r.to_le_bytes());
            bin.extend(c);
            bin.push(list.len() as u8);
            for v in list {
                bin.extend(v.to_le_bytes());
            }
        }
        let want = [
            sphere((1.5, -2.0, 3.25), 0.5, Some((1.0, 128.0 / 255.0, 0.0))),
            sphere((0.0, 0.0, 0.1), 1.0, Some((0.0, 0.0, 0.0))),
        ];
        assert_eq!(ply(&ascii).unwrap().spheres, want);
        assert_eq!(ply(&bin).unwrap().spheres, want);
        // Truncated: the last byte gone.
        bin.pop();
        let e = ply(&bin).unwrap_err();
        assert_eq!(e.at, Some(Location::Vertex(1)), "{e:?}");
        assert!(e.message.contains("truncated"));
    }

    #[test]
    fn ply_problems_name_what_is_missing() {
        let e = ply(&header(
            "ascii",
            "property float x\nproperty float y\nproperty float z\n",
            0,
        ))
        .unwrap_err();
        assert!(e.message.contains("no property radius"), "{e:?}");
        let props = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
        let mut short = header("ascii", props, 1);
        short.extend_from_slice(b"1 2 3\n");
        let e = ply(&short).unwrap_err();
        assert_eq!(e.at, Some(Location::Line(10)), "{e:?}");
        assert!(e.message.contains("short row"), "{e:?}");
        assert!(ply(&header("binary_big_endian", props, 0))
            .unwrap_err()
            .message
            .contains("binary_big_endian"));
        assert!(ply(b"PLY\n").is_err());
    }
}
