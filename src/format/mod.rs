//! The keyframe file as written: RON types that mirror the text, with every optional field an
//! `Option`, and the sphere files it names (PLY, CSV). Nothing here is checked;
//! [`crate::document`] turns these into domain types. This is the only module that knows RON.

use serde::Deserialize;

mod blocks;
mod pieces;
mod quick;
pub mod sphere_files;
pub mod splice;

use crate::keyframes::Interpolation;
use crate::mode::Mode;
use std::path::Path;

use crate::error::{Error, Result};

/// `(x, y, z)` in world units (or linear RGB for colours).
pub type Triple = (f64, f64, f64);
/// `(a, b)`: a window's (width, height) or a COP's (u, v).
pub type Pair = (f64, f64);

/// The whole keyframe file (docs/format.md).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "file")]
pub struct FileSpec {
    /// Any whole number, so that the checker can say what range it must lie in.
    pub frames: Option<i64>,
    /// Frames per second, > 0 (default 24).
    pub fps: Option<f64>,
    /// Image size and sampling.
    #[serde(default)]
    pub image: ImageSpec,
    /// The base camera.
    pub camera: CameraSpec,
    /// The tracks, at most one per animated parameter.
    #[serde(default)]
    pub animate: Vec<TrackSpec>,
    /// Spheres, lights, background and ambient.
    #[serde(default)]
    pub scene: SceneSpec,
    /// A frame-hash test's tolerance, for shots only.
    #[serde(default)]
    pub test: Option<TestSpec>,
    /// The file's fields in the order it writes them, top-level (`frames`, `camera`) and one
    /// level down (`camera.vpn`, `image.width`), for listing problems in the file's order.
    /// Filled by [`parse`].
    #[serde(skip)]
    pub order: Vec<String>,
}

/// The file's `test`: how far a frame may stray from its golden frame and still pass.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TestSpec {
    /// Pixels that may differ by more than `max_level` (default 0).
    pub max_pixels: Option<i64>,
    /// Levels of 255 a channel may differ by unnoticed (default 0).
    pub max_level: Option<i64>,
}

/// The file's `image`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, rename = "image")]
pub struct ImageSpec {
    /// Whole numbers of any sign; the checker says the range each must lie in.
    pub width: Option<i64>,
    /// Pixels, 1 to 16384 (default 360).
    pub height: Option<i64>,
    /// An s×s grid of samples per pixel, 1 to 16 (default 1).
    pub samples: Option<i64>,
    /// With s ≥ 2, trace the grid's corners first (default false).
    pub adaptive: Option<bool>,
    /// Shutter motion blur (default none).
    pub motion_blur: Option<MotionBlurSpec>,
}

/// The file's `image.motion_blur`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "motion_blur")]
pub struct MotionBlurSpec {
    /// The fraction of the frame interval the shutter is open; the checker wants (0, 1].
    pub shutter: f64,
    /// Time samples per frame, any whole number; the checker wants 1 to 64.
    pub samples: i64,
}

/// The file's `camera`; see docs/format.md for each field.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, rename = "camera")]
pub struct CameraSpec {
    /// View Reference Point, world units (default the origin).
    pub vrp: Option<Triple>,
    /// View Plane Normal, any length ≠ 0; or `tp`.
    pub vpn: Option<Triple>,
    /// Target point (look-at), instead of `vpn`.
    pub tp: Option<Triple>,
    /// View Up Vector (default (0, 1, 0)).
    pub vuv: Option<Triple>,
    /// Centre Of Projection in view coordinates (u, v, n), n < 0 (default (0, 0, −1)).
    pub cop: Option<Triple>,
    /// Window (width, height) on the view plane, world units; or a field of view.
    pub window: Option<Pair>,
    /// Horizontal field of view, degrees in (0, 180).
    pub hfov: Option<f64>,
    /// Vertical field of view, degrees in (0, 180).
    pub vfov: Option<f64>,
    /// The camera turned about the VPN, degrees (default 0), unless a Roll track sets it.
    pub roll: Option<f64>,
}

/// How an Observer path is timed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub enum SpeedSpec {
    /// Each key is reached at its time.
    Keyed,
    /// Constant speed along the path from the first key's time to the last.
    Uniform,
}

/// `ease: (start: 1.0, end: 1.0)`: seconds over which a `Uniform` path starts from rest and
/// comes to rest; either may be left out (0).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename = "ease")]
pub struct EaseSpec {
    /// Seconds from rest to the cruising speed.
    pub start: Option<f64>,
    /// Seconds from the cruising speed to rest.
    pub end: Option<f64>,
}

/// One key of a track.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "key")]
pub struct KeySpec<V> {
    /// Seconds.
    pub t: f64,
    /// The animated parameter's value at `t`.
    pub value: V,
    /// The segment from this key to the next, overriding the track's.
    pub interpolation: Option<Interpolation>,
}

/// One track of `animate`: the mode it animates and its keys.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "animate")]
pub enum TrackSpec {
    /// Animates the VRP.
    Observer {
        /// VRP positions, world units.
        keys: Vec<KeySpec<Triple>>,
        /// Default for every segment.
        interpolation: Option<Interpolation>,
        /// `Keyed` (default) or `Uniform` (constant speed along the path).
        speed: Option<SpeedSpec>,
        /// Arc-length table steps per key segment with `Uniform` (default 256).
        arc_samples: Option<i64>,
        /// With `Uniform`: seconds to start from rest and to come to rest.
        ease: Option<EaseSpec>,
    },
    /// Animates the VPN, on the unit sphere.
    LookAround {
        /// View directions, any length ≠ 0.
        keys: Vec<KeySpec<Triple>>,
        /// Default for every segment.
        interpolation: Option<Interpolation>,
    },
    /// Animates the target point: VPN = TP − VRP.
    Track {
        /// Target points, world units.
        keys: Vec<KeySpec<Triple>>,
        /// Default for every segment.
        interpolation: Option<Interpolation>,
    },
    /// Animates the COP's n (along the VPN).
    Zoom {
        /// The COP's n, < 0.
        keys: Vec<KeySpec<f64>>,
        /// Default for every segment.
        interpolation: Option<Interpolation>,
    },
    /// Animates the COP's (u, v) (across the VPN).
    Distort {
        /// The COP's (u, v).
        keys: Vec<KeySpec<Pair>>,
        /// Default for every segment.
        interpolation: Option<Interpolation>,
    },
    /// Animates the roll: the camera turned about the VPN.
    Roll {
        /// Degrees, counterclockwise as seen from behind the camera.
        keys: Vec<KeySpec<f64>>,
        /// Default for every segment.
        interpolation: Option<Interpolation>,
    },
}

impl TrackSpec {
    /// The mode this track animates.
    pub fn mode(&self) -> Mode {
        match self {
            TrackSpec::Observer { .. } => Mode::Observer,
            TrackSpec::LookAround { .. } => Mode::LookAround,
            TrackSpec::Track { .. } => Mode::Track,
            TrackSpec::Zoom { .. } => Mode::Zoom,
            TrackSpec::Distort { .. } => Mode::Distort,
            TrackSpec::Roll { .. } => Mode::Roll,
        }
    }
}

/// The file's `scene`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, rename = "scene")]
pub struct SceneSpec {
    /// Linear RGB where no sphere is hit (default black).
    pub background: Option<Triple>,
    /// Ambient term, ≥ 0 (default 1 without lights, 0.1 with).
    pub ambient: Option<f64>,
    /// Directional lights.
    #[serde(default)]
    pub lights: Vec<LightSpec>,
    /// The spheres.
    #[serde(default)]
    pub spheres: Vec<SphereSpec>,
    /// PLY, CSV or XYZ files of more spheres, relative to the keyframe file; their spheres
    /// follow `spheres`, file by file.
    #[serde(default)]
    pub sphere_files: Vec<SphereFileSpec>,
}

/// An entry of `sphere_files`: a file's path alone (`"cloud.ply"`), or with how its columns
/// become spheres (`(path: "cloud.csv", radius: 0.1, color_by: …)`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SphereFileSpec {
    /// Relative to the keyframe file.
    pub path: String,
    /// The columns that hold a sphere's fields, where the file's names are not the usual ones.
    pub columns: ColumnsSpec,
    /// World units, > 0: the radius of the file's spheres where it has no radius column.
    pub radius: Option<f64>,
    /// Linear RGB in [0, 1]: the colour of its spheres where it has no colour columns.
    pub color: Option<Triple>,
    /// A colour from a column: a type's colour, or a colormap over a number.
    pub color_by: Option<ColorBySpec>,
    /// A radius from a column: a type's radius, or a range over a number.
    pub radius_by: Option<RadiusBySpec>,
}

/// The struct form of a `sphere_files` entry, as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "sphere_file")]
struct SphereFileFields {
    path: String,
    #[serde(default)]
    columns: ColumnsSpec,
    radius: Option<f64>,
    color: Option<Triple>,
    color_by: Option<ColorBySpec>,
    radius_by: Option<RadiusBySpec>,
}

impl<'de> Deserialize<'de> for SphereFileSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        use serde::de::{self, MapAccess, Visitor};
        struct Entry;
        impl<'de> Visitor<'de> for Entry {
            type Value = SphereFileSpec;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a file's path, or (path: \"…\", …)")
            }
            fn visit_str<E: de::Error>(self, path: &str) -> std::result::Result<Self::Value, E> {
                Ok(SphereFileSpec {
                    path: path.to_string(),
                    ..SphereFileSpec::default()
                })
            }
            fn visit_map<A: MapAccess<'de>>(
                self,
                map: A,
            ) -> std::result::Result<Self::Value, A::Error> {
                let f = SphereFileFields::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(SphereFileSpec {
                    path: f.path,
                    columns: f.columns,
                    radius: f.radius,
                    color: f.color,
                    color_by: f.color_by,
                    radius_by: f.radius_by,
                })
            }
        }
        d.deserialize_any(Entry)
    }
}

/// A sphere file's columns by the names its header gives them (compared without regard to
/// case); a field not named here is found by its usual names (docs/format.md).
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename = "columns")]
pub struct ColumnsSpec {
    pub x: Option<String>,
    pub y: Option<String>,
    pub z: Option<String>,
    pub radius: Option<String>,
    pub red: Option<String>,
    pub green: Option<String>,
    pub blue: Option<String>,
}

/// A sphere's colour from one of its file's columns.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename = "color_by")]
pub enum ColorBySpec {
    /// A colour per type: the column's text (a whole number as written without a point)
    /// names the type; every type in the file must be in `colors`.
    Types {
        column: String,
        colors: std::collections::BTreeMap<String, Triple>,
    },
    /// A named colormap over a numeric column: `range.0` maps to its start and `range.1` to
    /// its end, values beyond held at the ends.
    Colormap {
        column: String,
        map: String,
        range: Pair,
    },
}

/// A sphere's radius from one of its file's columns.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename = "radius_by")]
pub enum RadiusBySpec {
    /// A radius per type, as [`ColorBySpec::Types`].
    Types {
        column: String,
        radii: std::collections::BTreeMap<String, f64>,
    },
    /// A numeric column's `range` mapped linearly onto `radii`, values beyond held at the ends.
    Range {
        column: String,
        range: Pair,
        radii: Pair,
    },
}

/// A directional light.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "light")]
pub struct LightSpec {
    /// The direction the light travels, any length ≠ 0.
    pub direction: Triple,
    /// Linear RGB, ≥ 0 (default white).
    pub color: Option<Triple>,
    /// Whether spheres cast shadows from it (default true).
    pub shadows: Option<bool>,
}

/// A sphere.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename = "sphere")]
pub struct SphereSpec {
    /// World units.
    pub center: Triple,
    /// World units, > 0.
    pub radius: f64,
    /// Linear RGB in [0, 1] (default white).
    pub color: Option<Triple>,
}

/// A sphere file's row in a float PLY's usual form, as read: a centre and radius of f32 values
/// and a colour of three byte levels (k / 255). Its sphere is the one the same row gives
/// through the file's column rules (`PlainSphere::spec`, in the tests, says which).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlainSphere {
    /// x, y, z and radius.
    pub ball: [f32; 4],
    /// Red, green and blue.
    pub levels: [u8; 3],
}

impl PlainSphere {
    /// The row as a sphere's spec: each value widened exactly, each level k as k / 255.
    #[cfg(test)]
    pub(crate) fn spec(&self) -> SphereSpec {
        let [x, y, z, r] = self.ball.map(f64::from);
        let [red, green, blue] = self.levels.map(|k| f64::from(k) / 255.0);
        SphereSpec {
            center: (x, y, z),
            radius: r,
            color: Some((red, green, blue)),
        }
    }
}

/// Parses RON text. Optional fields may be written bare (`tp: (0.0, 0.0, 0.0)`), without `Some`.
/// A long `spheres` list is parsed in pieces in parallel (`pieces.rs`), its plain pieces
/// without RON (`quick.rs`), on one thread as on several; the result, and any error, is the
/// same as RON's on the whole text.
pub fn parse(path: &Path, text: &str) -> Result<FileSpec> {
    // A byte-order mark some editors write first: not part of the text (columns on the first
    // line are counted as the editor shows them, without it).
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    // The fields' order from the whole text, or from the text without its long list (a
    // million spheres: 0.35 s on one thread for names the list does not hold).
    let spec = match pieces::parse(text, pieces::PIECE_BYTES) {
        Some(spec) => Ok(spec),
        None => options().from_str::<FileSpec>(text).map(|mut spec| {
            spec.order = field_order(text);
            spec
        }),
    };
    spec.map_err(|e| {
        let (line, col) = (e.span.start.line, e.span.start.col);
        Error::Parse {
            path: path.to_path_buf(),
            line,
            col,
            message: message(text, line, col, &e.code),
        }
    })
}

/// The names of the outermost struct's fields and of the fields of the structs they hold
/// (`camera.vpn`), in the order the text writes them; strings and comments are passed over.
fn field_order(text: &str) -> Vec<String> {
    let s = text.as_bytes();
    let ident = |c: &u8| c.is_ascii_alphanumeric() || *c == b'_';
    let (mut out, mut depth, mut top, mut i) = (Vec::new(), 0usize, "", 0);
    while i < s.len() {
        match s[i] {
            b'"' => {
                i += 1;
                while i < s.len() && s[i] != b'"' {
                    i += 1 + usize::from(s[i] == b'\\');
                }
            }
            b'/' if s.get(i + 1) == Some(&b'/') => i = pieces::line_comment_end(s, i),
            b'/' if s.get(i + 1) == Some(&b'*') => {
                // Block comments nest, as RON reads them.
                i = pieces::block_comment_end(s, i).unwrap_or(s.len());
                continue;
            }
            b'(' | b'[' | b'{' => depth += 1,
            b')' | b']' | b'}' => depth = depth.saturating_sub(1),
            c if (depth == 1 || depth == 2) && (c.is_ascii_alphabetic() || c == b'_') => {
                let end = s[i..]
                    .iter()
                    .position(|c| !ident(c))
                    .map_or(s.len(), |n| i + n);
                if text[end..].trim_start().starts_with(':') {
                    let name = &text[i..end];
                    if depth == 1 {
                        top = name;
                        out.push(top.to_string());
                    } else {
                        out.push(format!("{top}.{name}"));
                    }
                }
                i = end;
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// RON's message in the file's words: the field a bad value belongs to, and the file's names
/// for what RON calls by campath's type names.
fn message(text: &str, line: usize, col: usize, code: &ron::Error) -> String {
    let field = field_before(text, line, col);
    let message = match code {
        ron::Error::NoSuchEnumVariant {
            expected, found, ..
        } => {
            let what = match field {
                Some("interpolation") => "an interpolation",
                Some("speed") => "a speed",
                _ if expected.contains(&"Observer") => "a track",
                _ => "a name campath knows here",
            };
            return format!(
                "`{found}` is not {what}; expected one of {}",
                expected
                    .iter()
                    .map(|e| format!("`{e}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        ron::Error::IntegerOutOfBounds => {
            "the number is out of range for a whole number (at most 9223372036854775807)"
                .to_string()
        }
        other => other.to_string(),
    };
    match field {
        Some(f) => format!("{f}: {message}"),
        None => message,
    }
}

/// The field whose value starts at `line`:`col` (1-based, columns in characters), if the text
/// there follows `name:`.
fn field_before(text: &str, line: usize, col: usize) -> Option<&str> {
    let start: usize = text
        .split_inclusive('\n')
        .take(line.saturating_sub(1))
        .map(str::len)
        .sum();
    let row = text.get(start..)?;
    let offset = row
        .char_indices()
        .nth(col.saturating_sub(1))
        .map_or(row.len(), |(i, _)| i);
    let before = text
        .get(..start + offset)?
        .trim_end()
        .strip_suffix(':')?
        .trim_end();
    let name_start = before
        .rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .map_or(0, |i| i + 1);
    let name = &before[name_start..];
    (!name.is_empty() && !name.starts_with(|c: char| c.is_ascii_digit())).then_some(name)
}

/// RON as campath reads it.
fn options() -> ron::Options {
    ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
}

/// Reads and parses a keyframe file, which must be UTF-8 (a leading byte-order mark is
/// skipped).
pub fn read(path: &Path) -> Result<FileSpec> {
    // A long file's list parsed in pieces as the file is read, the text never held whole (a
    // million spheres: 169 MB of pages not faulted in); when that gives nothing (an odd form,
    // an error to report), the whole text as below.
    if let Ok(mut file) = std::fs::File::open(path) {
        let len = file.metadata().map_or(0, |m| m.len());
        if len >= DROP_ASIDE_BYTES as u64 {
            let (piece, block) = (pieces::PIECE_BYTES, pieces::BLOCK_BYTES);
            if let Some(spec) = pieces::read(&mut file, len, piece, block) {
                return Ok(spec);
            }
        }
    }
    match read_bytes(path) {
        Ok(bytes) => from_bytes(path, bytes),
        Err(cause) => Err(Error::read(path)(cause)),
    }
}

/// The file's bytes parsed.
fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<FileSpec> {
    let spec = parse(path, utf8(path, &bytes)?);
    // Giving a large text's pages back takes a while (0.1 s at a million spheres' 169 MB):
    // on a thread of its own, beside the work that follows.
    if bytes.len() >= DROP_ASIDE_BYTES {
        // Where no thread can be made, it is let go of here.
        let _ = std::thread::Builder::new().spawn(move || drop(bytes));
    }
    spec
}

/// Files at least this long are read in blocks (`pieces::read`); when that gives nothing, their
/// text is read in two halves and let go of on a thread of its own.
const DROP_ASIDE_BYTES: usize = 16 << 20;

/// A file's bytes, as `std::fs::read` gives them. A long file is read in two halves side by
/// side: most of reading it is faulting in and filling fresh pages (0.1 s for 169 MB), which
/// the two halves share between the cores.
fn read_bytes(path: &Path) -> std::io::Result<Vec<u8>> {
    #[cfg(unix)]
    {
        use std::io::{Read, Seek, SeekFrom};
        use std::os::unix::fs::FileExt;
        let mut file = std::fs::File::open(path)?;
        let len = usize::try_from(file.metadata()?.len()).unwrap_or(0);
        if len >= DROP_ASIDE_BYTES {
            let mut bytes = vec![0u8; len];
            let (a, b) = bytes.split_at_mut(len / 2);
            let (ra, rb) = rayon::join(
                || file.read_exact_at(a, 0),
                || file.read_exact_at(b, (len / 2) as u64),
            );
            match ra.and(rb) {
                // Shorter than it was a moment ago (an editor writing it): read it whole.
                Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
                    return std::fs::read(path);
                }
                r => r?,
            }
            // Whatever was written past the length it had a moment ago.
            file.seek(SeekFrom::Start(len as u64))?;
            file.read_to_end(&mut bytes)?;
            return Ok(bytes);
        }
    }
    std::fs::read(path)
}

/// The file's bytes as text, or a parse error at the line and column of the first byte that
/// is not UTF-8.
fn utf8<'a>(path: &Path, bytes: &'a [u8]) -> Result<&'a str> {
    std::str::from_utf8(bytes).map_err(|e| {
        let good = std::str::from_utf8(&bytes[..e.valid_up_to()]).expect("valid up to here");
        let good = good.strip_prefix('\u{feff}').unwrap_or(good);
        let last = good.rsplit('\n').next().unwrap_or("");
        Error::Parse {
            path: path.to_path_buf(),
            line: good.matches('\n').count() + 1,
            col: last.chars().count() + 1,
            message: match bytes {
                // UTF-16's byte-order marks, little- and big-endian.
                [0xFF, 0xFE, ..] | [0xFE, 0xFF, ..] => {
                    "the file is UTF-16 (it starts with UTF-16's byte-order mark); save it as \
                     UTF-8"
                        .to_string()
                }
                _ => format!(
                    "the file is not UTF-8: byte 0x{:02X} does not belong here (a file saved as \
                     Latin-1 or Windows-1252?); save it as UTF-8",
                    bytes[e.valid_up_to()]
                ),
            },
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Calls `f` with every string of `len` characters from `alphabet`, one after another: the
    /// exhaustive tests of the number readers against `from_str`.
    pub(super) fn each_string(alphabet: &[u8], len: u32, mut f: impl FnMut(&str)) {
        let mut text = String::with_capacity(len as usize);
        for n in 0..alphabet.len().pow(len) {
            text.clear();
            let mut n = n;
            for _ in 0..len {
                text.push(alphabet[n % alphabet.len()] as char);
                n /= alphabet.len();
            }
            f(&text);
        }
    }

    /// Names in comments, nested ones too, are no fields; the outer fields and their
    /// structs' fields are, in the text's order.
    #[test]
    fn field_order_skips_nested_comments() {
        let text =
            "/* /* (frames: 1) */ (fps: 2) */ (camera: (vpn: (0, 0, 1), /* a: */ tp: (0, 0, 0)),\n\
                    // image: (width: 1)\n scene: (spheres: [(center: (0, 0, 0))]), frames: 3)";
        assert_eq!(
            field_order(text),
            [
                "camera",
                "camera.vpn",
                "camera.tp",
                "scene",
                "scene.spheres",
                "frames"
            ]
        );
    }

    /// A long file read in halves gives the bytes `std::fs::read` gives: an odd length, so
    /// the halves differ, and no byte twice or lost at the cut.
    #[test]
    fn a_long_file_reads_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("long.ron");
        let len = DROP_ASIDE_BYTES + 4097;
        let bytes: Vec<u8> = (0..len).map(|k| (k % 251) as u8).collect();
        std::fs::write(&path, &bytes).unwrap();
        assert!(read_bytes(&path).unwrap() == bytes);
        let short = dir.path().join("short.ron");
        std::fs::write(&short, &bytes[..1000]).unwrap();
        assert!(read_bytes(&short).unwrap() == bytes[..1000]);
        assert!(read_bytes(&dir.path().join("missing.ron")).is_err());
    }

    /// A file long enough to be read in blocks gives what its whole text gives; one with a
    /// problem deep in its list is read whole and reports it at its line and column.
    #[test]
    fn a_long_file_read_in_blocks_is_its_whole_text() {
        let sphere = "(center: (1.25, -3.5, 1e3), radius: 0.125, color: (0.5, 0.25, 1.0)),\n";
        let n = DROP_ASIDE_BYTES / sphere.len() + 1;
        let text = format!(
            "// a long list\n(\n    frames: 2,\n    camera: (tp: (0.0, 0.0, 0.0)),\n    \
             scene: (spheres: [\n{}], ambient: 0.3),\n)\n",
            sphere.repeat(n)
        );
        assert!(text.len() >= DROP_ASIDE_BYTES);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("long.ron");
        std::fs::write(&path, &text).unwrap();
        let whole = parse(&path, &text).unwrap();
        assert_eq!(whole.scene.spheres.len(), n);
        assert_eq!(format!("{:?}", read(&path).unwrap()), format!("{whole:?}"));
        // The streamed read gives it without falling back to the whole text.
        let mut file = std::fs::File::open(&path).unwrap();
        let len = text.len() as u64;
        let streamed = pieces::read(&mut file, len, pieces::PIECE_BYTES, pieces::BLOCK_BYTES);
        assert_eq!(format!("{streamed:?}"), format!("{:?}", Some(whole)));
        let at = text.rmatch_indices("radius").nth(2).unwrap().0;
        let bad = format!("{},,{}", &text[..at], &text[at..]);
        std::fs::write(&path, &bad).unwrap();
        let (read, parsed) = (read(&path).unwrap_err(), parse(&path, &bad).unwrap_err());
        assert_eq!(read.to_string(), parsed.to_string());
        let line = text[..at].matches('\n').count() + 1;
        assert!(read.to_string().contains(&format!(":{line}:")), "{read}");
    }

    #[test]
    fn fields_in_the_order_written() {
        let text = "// frames: 1\n(scene: (spheres: [(center: (0.0, 0.0, 0.0))]), /* fps: 2 */\n \
                    camera: (vpn: (0.0, 0.0, 1.0)), frames: 3, animate: [Observer(keys: [])])";
        assert_eq!(
            field_order(text),
            [
                "scene",
                "scene.spheres",
                "camera",
                "camera.vpn",
                "frames",
                "animate"
            ]
        );
    }

    #[test]
    fn the_field_before_a_value() {
        let text = "(\n  frames: -5,\n  image: (width:  -1))";
        assert_eq!(field_before(text, 2, 11), Some("frames"));
        assert_eq!(field_before(text, 3, 19), Some("width"));
        assert_eq!(field_before(text, 3, 10), Some("image"));
        assert_eq!(field_before(text, 3, 11), None);
        assert_eq!(field_before(text, 1, 1), None);
        assert_eq!(field_before("(a: (1.0 2.0))", 1, 10), None);
    }

    #[test]
    fn the_first_byte_that_is_not_utf8_is_placed() {
        // "é" in Latin-1 is the single byte 0xE9, which UTF-8 reads as an unfinished character.
        let bytes = b"(\n  // caf\xe9\n)";
        let e = utf8(Path::new("x.ron"), bytes).unwrap_err();
        let Error::Parse {
            line, col, message, ..
        } = e
        else {
            panic!("{e}")
        };
        assert_eq!((line, col), (2, 9));
        assert!(message.contains("0xE9"), "{message}");
        // A BOM is not a column.
        let e = utf8(Path::new("x.ron"), b"\xef\xbb\xbfab\xff").unwrap_err();
        assert!(
            matches!(
                e,
                Error::Parse {
                    line: 1,
                    col: 3,
                    ..
                }
            ),
            "{e}"
        );
    }
}
