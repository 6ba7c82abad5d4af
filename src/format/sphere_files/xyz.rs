//! The XYZ form, plain and extended (as OVITO and ASE write it): a line with the number of
//! atoms, a comment line, then an atom a line, its values separated by white space. An
//! extended comment line's `Properties=` names the columns, with their types and widths
//! (`species:S:1:pos:R:3:radius:R:1`); a plain file's columns are `species:S:1:pos:R:3`. A
//! property `name` of width n > 1 gives columns `name[0]` … `name[n−1]`; a plain file's values
//! past those four are read past. The first frame is read; what follows it (the next frames of
//! a trajectory) is not.

use std::io::BufRead;

use super::header::{quoted, HeaderLines};
use super::listing::{FileProblem, Listing, Location};
use super::look::{Column, Fields, Kind, Layout};
use super::text::{text_records, Rows};
use super::Sink;
use crate::format::{SphereFileSpec, SphereSpec};

/// The columns of a file whose comment line has no `Properties=`.
const PLAIN: &str = "species:S:1:pos:R:3";

/// The XYZ form read from `file`: its two header lines, then its atoms in blocks on the pool
/// ([`text_records`]).
pub(super) fn xyz_from<T>(
    mut file: impl BufRead + Send,
    spec: &SphereFileSpec,
    out: &mut impl Sink<T>,
    make: &impl Fn(usize, &SphereSpec) -> T,
    listing: &mut Listing,
) -> Result<(), FileProblem> {
    let mut lines = HeaderLines::new("is it an XYZ file?", false);
    let Some((_, first)) = lines.next(&mut file)? else {
        return Err(FileProblem::whole("empty: expected the number of atoms"));
    };
    let first = first.trim_start_matches('\u{feff}').trim();
    let count: usize = first.parse().map_err(|_| {
        let what = format!(
            "the first line must be the number of atoms, got {}",
            quoted(first)
        );
        FileProblem::at(Location::Line(1), what)
    })?;
    let comment = match lines.next(&mut file)? {
        Some((_, comment)) => comment,
        None if count == 0 => String::new(),
        None => {
            return Err(FileProblem::whole(
                "no comment line after the number of atoms",
            ))
        }
    };
    let at_comment = |what: String| FileProblem::at(Location::Line(2), what);
    let properties = properties(&comment).map_err(at_comment)?;
    let columns = columns(properties.as_deref().unwrap_or(PLAIN)).map_err(at_comment)?;
    let layout = Layout::resolve(spec, &columns).map_err(at_comment)?;
    listing.ignored = layout.ignored.clone();
    let width = columns.len();
    let plain = properties.is_none();
    let names: Vec<String> = columns.iter().map(|c| c.name.clone()).collect();
    // A plain file's values past its four are read past (charges, velocities).
    let fields = Fields::new(&layout, &names, plain);
    let parse = |line: &str, _: &mut Vec<f64>| {
        let words = fields.words(line.split_ascii_whitespace()).map_err(|_| {
            let got = line.split_ascii_whitespace().count();
            let fix = match plain {
                true => ": name the columns with Properties= on the comment line",
                false => ": does Properties= on line 2 match the rows?",
            };
            format!(
                "expected {width} values ({}), got {got}{fix}",
                fields_of(&columns)
            )
        })?;
        layout.sphere(&words)
    };
    let first = 3;
    listing.first_line = Some(first);
    let mut gaps = false;
    let mut taken = 0;
    let take = |line, sphere: Result<SphereSpec, String>| {
        gaps |= line != first + taken;
        match sphere {
            Ok(sphere) => {
                out.put(make(taken, &sphere));
                listing.lines.push(line as u32);
            }
            Err(what) => {
                listing.unreadable(taken, FileProblem::at(Location::Line(line), what));
                out.put(make(taken, &STAND_IN));
                listing.lines.push(line as u32);
            }
        }
        taken += 1;
    };
    let problem = |_, line, what| FileProblem::at(Location::Line(line), what);
    let blank = |line: &str| line.trim().is_empty();
    let rows = Rows {
        first_line: first,
        count,
        rest_blank: false,
    };
    let got = text_records(&mut file, rows, blank, parse, take, problem)?;
    if !gaps {
        listing.lines = Vec::new();
    }
    if got < count {
        return Err(FileProblem::whole(format!(
            "truncated: the file ends at atom {got} of the {count} its first line gives"
        )));
    }
    Ok(())
}

/// What stands in for an atom that could not be read: a sphere that passes every check, so
/// only the atom's own problem is named, and the atoms after it keep their numbers.
const STAND_IN: SphereSpec = SphereSpec {
    center: (0.0, 0.0, 0.0),
    radius: 1.0,
    color: None,
};

/// The columns' names, for a message: `species pos[0] pos[1] pos[2]`.
fn fields_of(columns: &[Column]) -> String {
    let names: Vec<&str> = columns.iter().map(|c| c.name.as_str()).collect();
    let joined = names.join(" ");
    match joined.chars().count() <= 60 {
        true => joined,
        false => format!("{}…", joined.chars().take(60).collect::<String>()),
    }
}

/// The value of the comment line's `Properties=` key (any case), if it has one. The line is
/// `key=value` pairs separated by white space; a value may be in double quotes or braces.
fn properties(comment: &str) -> Result<Option<String>, String> {
    let mut rest = comment.trim_start();
    while !rest.is_empty() {
        let key_end = rest
            .find(|c: char| c == '=' || c.is_whitespace())
            .unwrap_or(rest.len());
        let key = &rest[..key_end];
        rest = rest[key_end..].trim_start();
        let Some(after) = rest.strip_prefix('=') else {
            // A key without a value (a flag), or words of a plain comment.
            continue;
        };
        let after = after.trim_start();
        let (value, next) = match after.chars().next() {
            Some(open @ ('"' | '{')) => {
                let close = if open == '"' { '"' } else { '}' };
                let end = after[1..].find(close).ok_or_else(|| {
                    format!("the value of {} is not closed with {close}", quoted(key))
                })?;
                (&after[1..1 + end], &after[end + 2..])
            }
            _ => {
                let end = after.find(char::is_whitespace).unwrap_or(after.len());
                (&after[..end], &after[end..])
            }
        };
        if key.eq_ignore_ascii_case("properties") {
            return Ok(Some(value.to_string()));
        }
        rest = next.trim_start();
    }
    Ok(None)
}

/// The columns a `Properties=` value gives: `name:type:width` triples.
fn columns(properties: &str) -> Result<Vec<Column>, String> {
    let parts: Vec<&str> = properties.split(':').collect();
    if !parts.len().is_multiple_of(3) {
        return Err(format!(
            "Properties={} is not name:type:width triples",
            quoted(properties)
        ));
    }
    let mut columns = Vec::new();
    for p in parts.chunks(3) {
        let kind = match p[1].to_ascii_uppercase().as_str() {
            "R" | "I" => Kind::Number,
            "S" | "L" => Kind::Text,
            other => {
                return Err(format!(
                    "property {}: type {} is not R, I, S or L",
                    quoted(p[0]),
                    quoted(other)
                ))
            }
        };
        let width: usize = match p[2].parse() {
            Ok(w) if w > 0 => w,
            _ => {
                return Err(format!(
                    "property {}: width {} is not a whole number above 0",
                    quoted(p[0]),
                    quoted(p[2])
                ))
            }
        };
        match width {
            1 => columns.push(Column {
                name: p[0].to_string(),
                kind,
            }),
            _ => columns.extend((0..width).map(|k| Column {
                name: format!("{}[{k}]", p[0]),
                kind,
            })),
        }
    }
    Ok(columns)
}
