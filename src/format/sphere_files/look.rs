//! How a sphere file's columns become spheres ([`Layout`]): which column holds each field,
//! found by its usual names or by the keyframe file's `columns`, and what the file lacks given
//! by the keyframe file (one radius, one colour, a colour or radius by type or over a number).
//! Each form (CSV, PLY, XYZ) names its columns; a row's values reach [`Layout::sphere`] as
//! text or as numbers ([`Row`]), one slot a field.

use std::borrow::Cow;
use std::collections::BTreeMap;

use super::header::quoted;
use super::text::text_f64;
use crate::format::{ColorBySpec, RadiusBySpec, SphereFileSpec, SphereSpec, Triple};
use crate::scene::srgb_linear;

/// The slots of a row: the fields a sphere reads, each from one column.
pub(super) const X: usize = 0;
pub(super) const RADIUS: usize = 3;
pub(super) const RED: usize = 4;
pub(super) const BLUE: usize = 6;
/// The column `color_by` reads.
pub(super) const COLOR_KEY: usize = 7;
/// The column `radius_by` reads.
pub(super) const RADIUS_KEY: usize = 8;
pub(super) const SLOTS: usize = 9;

/// The fields x, y, z, radius, red, green, blue as the keyframe file's `columns` names them.
const FIELDS: [&str; 7] = ["x", "y", "z", "radius", "red", "green", "blue"];

/// Each field's usual names in a header, compared in lower case.
const USUAL: [&[&str]; 7] = [
    &[
        "x",
        "pos.x",
        "position.x",
        "pos_x",
        "position_x",
        "pos[0]",
        "position[0]",
        "positions[0]",
    ],
    &[
        "y",
        "pos.y",
        "position.y",
        "pos_y",
        "position_y",
        "pos[1]",
        "position[1]",
        "positions[1]",
    ],
    &[
        "z",
        "pos.z",
        "position.z",
        "pos_z",
        "position_z",
        "pos[2]",
        "position[2]",
        "positions[2]",
    ],
    &["radius", "radii"],
    &[
        "red",
        "color.r",
        "colour.r",
        "color.red",
        "color[0]",
        "colors[0]",
        "colour[0]",
        "rgb[0]",
    ],
    &[
        "green",
        "color.g",
        "colour.g",
        "color.green",
        "color[1]",
        "colors[1]",
        "colour[1]",
        "rgb[1]",
    ],
    &[
        "blue",
        "color.b",
        "colour.b",
        "color.blue",
        "color[2]",
        "colors[2]",
        "colour[2]",
        "rgb[2]",
    ],
];

/// The one-letter names, where no usual name is there: `r`, `g` and `b` are red, green and blue
/// when all three are in the header (`x,y,z,radius,r,g,b`); `r` without `g` and `b` is the radius
/// (`X,Y,Z,R`); a lone `g` or `b` (a B-factor) is nothing's.
const LETTERS: [Option<&str>; 7] = [None, None, None, Some("r"), Some("r"), Some("g"), Some("b")];

/// The named colormaps of `color_by: Colormap(map: …)`: those colorous computes with
/// arithmetic alone (its cubehelix maps call the platform's sine and cosine, so they are not
/// here: the same file must give the same bytes on every machine).
pub const COLORMAPS: [(&str, colorous::Gradient); 11] = [
    ("viridis", colorous::VIRIDIS),
    ("plasma", colorous::PLASMA),
    ("inferno", colorous::INFERNO),
    ("magma", colorous::MAGMA),
    ("cividis", colorous::CIVIDIS),
    ("turbo", colorous::TURBO),
    ("greys", colorous::GREYS),
    ("blues", colorous::BLUES),
    ("reds", colorous::REDS),
    ("spectral", colorous::SPECTRAL),
    ("red_blue", colorous::RED_BLUE),
];

/// The colormap of a name, in any case.
pub fn colormap(name: &str) -> Option<colorous::Gradient> {
    (COLORMAPS.iter())
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map(|(_, g)| *g)
}

/// What a column can hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// A number (CSV's text is read as one where a number is wanted).
    Number,
    /// Text only (an XYZ `S` or `L` property): a type's name.
    Text,
    /// A PLY list: nothing a sphere reads.
    List,
}

/// A file's column as its header names it.
pub(super) struct Column {
    pub name: String,
    pub kind: Kind,
}

/// How a sphere's radius is found.
enum Radius {
    Column,
    Fixed(f64),
    Types(BTreeMap<String, f64>),
    /// `range.0 + t (range.1 − range.0)` ↦ `radii.0 + t (radii.1 − radii.0)`.
    Range {
        range: (f64, f64),
        radii: (f64, f64),
    },
}

/// How a sphere's colour is found.
enum Color {
    /// Red, green and blue columns: levels 0–1, or bytes 0–255 (`bytes`).
    Columns {
        bytes: bool,
    },
    /// The keyframe file's colour, or white.
    Fixed(Option<Triple>),
    Types(BTreeMap<String, Triple>),
    Map {
        map: colorous::Gradient,
        range: (f64, f64),
    },
}

/// How a file's rows become spheres: the column of each slot, and the rules for radius and
/// colour.
pub(super) struct Layout {
    /// The column each slot reads ([`X`] … [`RADIUS_KEY`]); None where none is read.
    pub cols: [Option<usize>; SLOTS],
    /// Each read slot's column, for messages: `column 4 (radius)`.
    labels: [String; SLOTS],
    radius: Radius,
    color: Color,
    /// The columns nothing reads, named once.
    pub ignored: Vec<String>,
}

/// A row's values, slot by slot.
pub(super) trait Row {
    /// The slot's number, or None where its text is not one.
    fn number(&self, slot: usize) -> Option<f64>;
    /// The slot's text: a type's name, and what a message quotes.
    fn text(&self, slot: usize) -> Cow<'_, str>;
}

/// A text row's fields, one a slot (CSV, XYZ).
pub(super) struct Words<'a>(pub [&'a str; SLOTS]);

impl Row for Words<'_> {
    #[inline(always)]
    fn number(&self, slot: usize) -> Option<f64> {
        text_f64(self.0[slot])
    }

    fn text(&self, slot: usize) -> Cow<'_, str> {
        Cow::Borrowed(self.0[slot])
    }
}

/// A binary or typed row's values, one a slot (PLY).
impl Row for [f64; SLOTS] {
    #[inline(always)]
    fn number(&self, slot: usize) -> Option<f64> {
        Some(self[slot])
    }

    fn text(&self, slot: usize) -> Cow<'_, str> {
        Cow::Owned(number_name(self[slot]))
    }
}

/// A number as a type's name: a whole number without a point (`3`), any other as Rust
/// writes it.
fn number_name(v: f64) -> String {
    match v == v.trunc() && v.abs() < 1e15 {
        true => format!("{}", v as i64),
        false => format!("{v}"),
    }
}

impl Layout {
    /// The layout of a file whose header names `columns`, by `spec`'s rules (checked by
    /// [`crate::document`]: radii > 0, colours in [0, 1], colormaps known, ranges not empty).
    pub(super) fn resolve(spec: &SphereFileSpec, columns: &[Column]) -> Result<Layout, String> {
        if let Some(all) = no_header(columns) {
            return Err(all);
        }
        let lower: Vec<String> = columns.iter().map(|c| c.name.to_lowercase()).collect();
        let has = |n: &str| lower.iter().any(|l| l == n);
        // `r`, `g` and `b` are colours only all three together; `r` alone is a radius.
        let rgb_letters = has("r") && has("g") && has("b");
        let header = || {
            let names: Vec<&str> = columns.iter().map(|c| c.name.as_str()).collect();
            quoted(&names.join(","))
        };
        let c = &spec.columns;
        let given = [&c.x, &c.y, &c.z, &c.radius, &c.red, &c.green, &c.blue];
        // Columns the keyframe file names for a field are no other field's by their usual names.
        let claimed: Vec<String> = (given.iter())
            .filter_map(|g| g.as_deref().map(str::to_lowercase))
            .collect();
        // The column a name picks (given), or the one of the field's usual names (None where
        // there is none); two picked is a question the keyframe file answers.
        let find = |field: usize, given: Option<&str>| -> Result<Option<usize>, String> {
            let hits: Vec<usize> = match given {
                Some(name) => {
                    let name = name.to_lowercase();
                    (0..columns.len()).filter(|&k| lower[k] == name).collect()
                }
                None => {
                    let usual = |letters: bool| {
                        (0..columns.len())
                            .filter(|&k| !claimed.contains(&lower[k]))
                            .filter(|&k| {
                                let l = lower[k].as_str();
                                match letters {
                                    false => USUAL[field].contains(&l),
                                    true => LETTERS[field] == Some(l),
                                }
                            })
                            .collect::<Vec<usize>>()
                    };
                    match usual(false) {
                        // A letter only where no full name is there: `r` beside `radius` is
                        // read past, not a second radius.
                        hits if hits.is_empty() && (field == RADIUS) != rgb_letters => usual(true),
                        hits => hits,
                    }
                }
            };
            match (hits.as_slice(), given) {
                ([], Some(name)) => Err(format!(
                    "columns.{} names {}, which the header {} does not have",
                    FIELDS[field],
                    quoted(name),
                    header()
                )),
                ([], None) => Ok(None),
                ([k], _) => Ok(Some(*k)),
                ([a, b, ..], _) if columns[*a].name == columns[*b].name => Err(format!(
                    "the header {} names {} twice: rename one",
                    header(),
                    quoted(&columns[*a].name)
                )),
                ([a, b, ..], _) => Err(format!(
                    "columns {} and {} could both be {}: name one with columns: ({}: \"…\")",
                    quoted(&columns[*a].name),
                    quoted(&columns[*b].name),
                    FIELDS[field],
                    FIELDS[field]
                )),
            }
        };
        let mut cols = [None; SLOTS];
        for (field, name) in given.iter().enumerate() {
            // A field a rule decides is not looked for: its columns, if any, are read past.
            let ruled = match field {
                RADIUS => spec.radius_by.is_some(),
                RED..=BLUE => spec.color_by.is_some(),
                _ => false,
            };
            if !ruled {
                cols[field] = find(field, name.as_deref())?;
            }
        }
        // One column is one field's.
        for a in X..=BLUE {
            for b in a + 1..=BLUE {
                if let (Some(k), true) = (cols[a], cols[a] == cols[b]) {
                    return Err(format!(
                        "column {} would be both {} and {}: name each with columns: ({}: \"…\", {}: \"…\")",
                        quoted(&columns[k].name),
                        FIELDS[a],
                        FIELDS[b],
                        FIELDS[a],
                        FIELDS[b]
                    ));
                }
            }
        }
        // A column a rule names.
        let named = |rule: &str, name: &str| -> Result<usize, String> {
            let l = name.to_lowercase();
            lower.iter().position(|c| *c == l).ok_or_else(|| {
                format!(
                    "{rule}'s column {} is not in the header {}",
                    quoted(name),
                    header()
                )
            })
        };
        for (field, axis) in ["x", "y", "z"].iter().enumerate() {
            if cols[field].is_none() {
                return Err(format!(
                    "no column for {axis} in the header {}: name it with columns: ({axis}: \"…\")",
                    header()
                ));
            }
        }
        let radius = match &spec.radius_by {
            Some(RadiusBySpec::Types { column, radii }) => {
                cols[RADIUS_KEY] = Some(named("radius_by", column)?);
                Radius::Types(radii.iter().map(|(k, v)| (k.clone(), *v)).collect())
            }
            Some(RadiusBySpec::Range {
                column,
                range,
                radii,
            }) => {
                cols[RADIUS_KEY] = Some(named("radius_by", column)?);
                Radius::Range {
                    range: *range,
                    radii: *radii,
                }
            }
            None => match (cols[RADIUS], spec.radius) {
                (Some(_), _) => Radius::Column,
                (None, Some(r)) => Radius::Fixed(r),
                (None, None) => {
                    return Err(format!(
                        "no radius column in the header {}: give one radius with (path: {}, radius: …), or name the column with columns: (radius: \"…\")",
                        header(),
                        quoted(&spec.path)
                    ))
                }
            },
        };
        if spec.radius_by.is_some() {
            cols[RADIUS] = None;
        }
        let rgb = [cols[RED], cols[RED + 1], cols[BLUE]];
        let color = match &spec.color_by {
            Some(ColorBySpec::Types { column, colors }) => {
                cols[COLOR_KEY] = Some(named("color_by", column)?);
                Color::Types(colors.iter().map(|(k, v)| (k.clone(), *v)).collect())
            }
            Some(ColorBySpec::Colormap { column, map, range }) => {
                cols[COLOR_KEY] = Some(named("color_by", column)?);
                let map = colormap(map).ok_or_else(|| format!("no colormap {}", quoted(map)))?;
                Color::Map { map, range: *range }
            }
            None => match rgb {
                [Some(_), Some(_), Some(_)] => Color::Columns { bytes: false },
                [None, None, None] => Color::Fixed(spec.color),
                _ => {
                    let missing: Vec<&str> = (RED..=BLUE)
                        .filter(|&f| cols[f].is_none())
                        .map(|f| FIELDS[f])
                        .collect();
                    return Err(format!(
                        "the header {} has some colour columns but no {}: name it with columns: ({}: \"…\"), or colour the file with color_by",
                        header(),
                        missing.join(" or "),
                        missing[0]
                    ));
                }
            },
        };
        if spec.color_by.is_some() {
            cols[RED..=BLUE].fill(None);
        }
        let mut labels: [String; SLOTS] = Default::default();
        for (slot, col) in cols.iter().enumerate() {
            if let Some(k) = *col {
                let column = &columns[k];
                let wanted = match slot {
                    COLOR_KEY if matches!(color, Color::Types(_)) => Kind::Text,
                    RADIUS_KEY if matches!(radius, Radius::Types(_)) => Kind::Text,
                    _ => Kind::Number,
                };
                let reader = match slot {
                    COLOR_KEY => "color_by",
                    RADIUS_KEY => "radius_by",
                    field => FIELDS[field],
                };
                match (column.kind, wanted) {
                    (Kind::List, _) => {
                        return Err(format!(
                            "column {} is a list, which {reader} cannot read",
                            quoted(&column.name)
                        ))
                    }
                    (Kind::Text, Kind::Number) => {
                        return Err(format!(
                            "column {} holds text, not the numbers {reader} needs",
                            quoted(&column.name)
                        ))
                    }
                    _ => {}
                }
                labels[slot] = format!("column {} ({})", k + 1, column.name);
            }
        }
        let ignored = (0..columns.len())
            .filter(|k| !cols.contains(&Some(*k)))
            .map(|k| columns[k].name.clone())
            .collect();
        Ok(Layout {
            cols,
            labels,
            radius,
            color,
            ignored,
        })
    }

    /// The red, green and blue columns a sphere's colour is read from, if it is.
    pub(super) fn color_columns(&self) -> Option<[usize; 3]> {
        match (
            &self.color,
            self.cols[RED],
            self.cols[RED + 1],
            self.cols[RED + 2],
        ) {
            (Color::Columns { .. }, Some(r), Some(g), Some(b)) => Some([r, g, b]),
            _ => None,
        }
    }

    /// Whether a row's sphere is its x, y, z and radius columns as they are and its colour
    /// columns as bytes (each level k as k / 255), by no other rule: what a
    /// [`crate::format::PlainSphere`] holds.
    pub(super) fn plain(&self) -> bool {
        matches!(self.radius, Radius::Column)
            && matches!(self.color, Color::Columns { bytes: true })
    }

    /// Reads the colour columns as bytes, each level k as k / 255.
    pub(super) fn color_bytes(&mut self) {
        if let Color::Columns { bytes } = &mut self.color {
            *bytes = true;
        }
    }

    /// The sphere of a row; or what is wrong with it, naming the column.
    #[inline(always)]
    pub(super) fn sphere(&self, row: &impl Row) -> Result<SphereSpec, String> {
        let number = |slot: usize| {
            row.number(slot).ok_or_else(|| {
                let text = row.text(slot);
                let hint = match text.starts_with('"') {
                    true => " (a quoted field starts with its quote: no space before it)",
                    false => "",
                };
                format!(
                    "{}: not a number: {}{hint}",
                    self.labels[slot],
                    quoted(&text)
                )
            })
        };
        let center = (number(X)?, number(X + 1)?, number(X + 2)?);
        let radius = match &self.radius {
            Radius::Column => number(RADIUS)?,
            Radius::Fixed(r) => *r,
            Radius::Types(radii) => *self.of_type(row, RADIUS_KEY, radii, "radius_by's radii")?,
            Radius::Range { range, radii } => {
                let t = self.along(number(RADIUS_KEY)?, *range, RADIUS_KEY)?;
                // Exact at both ends.
                (1.0 - t) * radii.0 + t * radii.1
            }
        };
        let color = match &self.color {
            Color::Columns { bytes } => {
                let level = |v: f64| if *bytes { v / 255.0 } else { v };
                let [r, g, b] = [number(RED)?, number(RED + 1)?, number(RED + 2)?];
                Some((level(r), level(g), level(b)))
            }
            Color::Fixed(c) => *c,
            Color::Types(colors) => {
                Some(*self.of_type(row, COLOR_KEY, colors, "color_by's colors")?)
            }
            Color::Map { map, range } => {
                let t = self.along(number(COLOR_KEY)?, *range, COLOR_KEY)?;
                let c = map.eval_continuous(t);
                Some((srgb_linear(c.r), srgb_linear(c.g), srgb_linear(c.b)))
            }
        };
        Ok(SphereSpec {
            center,
            radius,
            color,
        })
    }

    /// A type's entry in `table`.
    fn of_type<'t, V>(
        &self,
        row: &impl Row,
        slot: usize,
        table: &'t BTreeMap<String, V>,
        named: &str,
    ) -> Result<&'t V, String> {
        let name = row.text(slot);
        table.get(name.as_ref()).ok_or_else(|| {
            let known: Vec<String> = table.keys().map(|k| quoted(k)).collect();
            format!(
                "{}: type {} is not in {named} ({}): add it",
                self.labels[slot],
                quoted(&name),
                known.join(", ")
            )
        })
    }

    /// Where `v` lies along `range`, from 0 at its start to 1 at its end, held there beyond.
    fn along(&self, v: f64, range: (f64, f64), slot: usize) -> Result<f64, String> {
        if !v.is_finite() {
            return Err(format!("{}: not a finite number: {v}", self.labels[slot]));
        }
        Ok(((v - range.0) / (range.1 - range.0)).clamp(0.0, 1.0))
    }
}

/// Whether a header is a row of numbers: a file without a header line.
fn no_header(columns: &[Column]) -> Option<String> {
    let numbers = columns.iter().all(|c| text_f64(c.name.trim()).is_some());
    numbers.then(|| {
        let names: Vec<&str> = columns.iter().map(|c| c.name.as_str()).collect();
        format!(
            "no header: the first line must name the columns (x,y,z,radius and more), got {}",
            quoted(&names.join(","))
        )
    })
}

/// Which of a line's fields each slot reads.
pub(super) struct Fields {
    /// (column, slot), by column.
    wanted: Vec<(usize, usize)>,
    /// How many fields a line holds, and the header's names for a message.
    count: usize,
    names: String,
    /// Whether a line may hold more fields than the header names (read past).
    more: bool,
}

impl Fields {
    pub(super) fn new(layout: &Layout, names: &[String], more: bool) -> Fields {
        let mut wanted: Vec<(usize, usize)> = (layout.cols.iter().enumerate())
            .filter_map(|(slot, col)| col.map(|k| (k, slot)))
            .collect();
        wanted.sort_unstable();
        let joined = names.join(",");
        Fields {
            wanted,
            count: names.len(),
            more,
            names: match joined.chars().count() <= 60 {
                true => joined,
                false => "as the header names them".to_string(),
            },
        }
    }

    /// A line's fields (trimmed here), one a slot; the line must have the header's count (or
    /// more, where more are read past).
    #[inline(always)]
    pub(super) fn words<'a>(
        &self,
        line: impl Iterator<Item = &'a str>,
    ) -> Result<Words<'a>, String> {
        let mut words = [""; SLOTS];
        let mut next = 0;
        let mut got = 0;
        for (k, field) in line.enumerate() {
            while let Some(&(col, slot)) = self.wanted.get(next) {
                if col != k {
                    break;
                }
                words[slot] = field.trim();
                next += 1;
            }
            got = k + 1;
        }
        if got != self.count && !(self.more && got > self.count) {
            return Err(format!(
                "expected {} fields ({}), got {got}",
                self.count, self.names
            ));
        }
        Ok(Words(words))
    }
}
