//! The CSV form: a header `x,y,z,radius` or `x,y,z,radius,r,g,b`, then a sphere a line. A line
//! is split at its commas, each field trimmed; a line that does not read so and holds a `"` is
//! read again as CSV with quotes (RFC 4180), by the csv crate. Since no field with a `"` is a
//! number or a header name, a line without quotes reads as it always did.

use std::io::BufRead;

use super::header::{quoted, HeaderLines, CR_ALONE};
use super::listing::{FileProblem, Listing, Location};
use super::text::{text_f64, text_records, Rows};
use crate::format::SphereSpec;

/// A CSV file's columns, in the order its header names them.
const CSV_NAMES: [&str; 7] = ["x", "y", "z", "radius", "r", "g", "b"];

/// The CSV form read from `file`: the header line, then the body's lines in blocks on the
/// pool ([`text_records`]).
pub(super) fn csv_from<T>(
    mut file: impl BufRead + Send,
    out: &mut Vec<T>,
    make: &impl Fn(usize, &SphereSpec) -> T,
    listing: &mut Listing,
) -> Result<(), FileProblem> {
    let mut lines = HeaderLines::new("is it a CSV file?", false);
    let (n, header) = loop {
        match lines.next(&mut file)? {
            None => return Err(FileProblem::whole("empty: expected a header x,y,z,radius")),
            // A byte-order mark starts the file, whatever line holds the header.
            Some((1, l)) if l.trim_start_matches('\u{feff}').trim().is_empty() => continue,
            Some((_, l)) if l.is_empty() => continue,
            Some((n, l)) => break (n, l),
        }
    };
    let header = match n {
        1 => header
            .strip_prefix('\u{feff}')
            .unwrap_or(&header)
            .to_string(),
        _ => header,
    };
    let record;
    let mut names: Vec<&str> = header.split(',').map(str::trim).collect();
    if header.contains('"') {
        record = with_quotes(&header).map_err(|e| FileProblem::at(Location::Line(n), e))?;
        names = record.iter().map(str::trim).collect();
    }
    let colours = match names.as_slice() {
        ["x", "y", "z", "radius"] => false,
        ["x", "y", "z", "radius", "r", "g", "b"] => true,
        _ => {
            // A line that still holds a CR: lines end in CR alone.
            let cr = match header.contains('\r') {
                true => format!(" ({CR_ALONE})"),
                false => String::new(),
            };
            return Err(FileProblem::at(
                Location::Line(n),
                format!(
                    "the header must be x,y,z,radius or x,y,z,radius,r,g,b, got {}{cr}",
                    quoted(&header)
                ),
            ));
        }
    };
    let parse = |line: &str, _: &mut Vec<f64>| match sphere(line.split(','), colours) {
        Err(_) if line.contains('"') => requoted(line, colours),
        read => read,
    };
    let first = n + 1;
    listing.first_line = Some(first);
    let mut gaps = false;
    let mut count = 0;
    let take = |line, sphere: Result<SphereSpec, String>| match sphere {
        Ok(sphere) => {
            gaps |= line != first + count;
            out.push(make(count, &sphere));
            count += 1;
            listing.lines.push(line as u32);
        }
        // Passed: the lines of the spheres after it are kept.
        Err(what) => {
            gaps = true;
            let problem = FileProblem::at(Location::Line(line), what);
            listing.unreadable(count, problem);
        }
    };
    let problem = |_, line, what| FileProblem::at(Location::Line(line), what);
    let blank = |line: &str| line.trim().is_empty();
    let rows = Rows {
        first_line: first,
        count: usize::MAX,
        rest_blank: false,
    };
    let ended = text_records(&mut file, rows, blank, parse, take, problem);
    if !gaps {
        // Every sphere on the line after the one before: the lines need not be kept.
        listing.lines = Vec::new();
    }
    ended.map(|_| ())
}

/// The sphere of a line's fields (trimmed here), with colours or without.
#[inline(always)]
fn sphere<'a>(line: impl Iterator<Item = &'a str>, colours: bool) -> Result<SphereSpec, String> {
    let fields = if colours { 7 } else { 4 };
    let mut words = [""; 7];
    let mut got = 0;
    for (k, field) in line.enumerate() {
        if let Some(word) = words.get_mut(k) {
            *word = field.trim();
        }
        got = k + 1;
    }
    if got != fields {
        return Err(format!(
            "expected {fields} fields ({}), got {got}",
            CSV_NAMES[..fields].join(",")
        ));
    }
    let mut values = [0.0; 7];
    for (k, (value, word)) in values.iter_mut().zip(words).take(fields).enumerate() {
        *value = text_f64(word).ok_or_else(|| {
            let hint = match word.starts_with('"') {
                true => " (a quoted field starts with its quote: no space before it)",
                false => "",
            };
            format!("{}: not a number: {}{hint}", CSV_NAMES[k], quoted(word))
        })?;
    }
    let [x, y, z, radius, r, g, b] = values;
    Ok(SphereSpec {
        center: (x, y, z),
        radius,
        color: colours.then_some((r, g, b)),
    })
}

/// The sphere of a line that holds a quote, read as CSV with quotes.
#[cold]
fn requoted(line: &str, colours: bool) -> Result<SphereSpec, String> {
    sphere(with_quotes(line)?.iter(), colours)
}

/// A line's fields read as CSV with quotes: a field in quotes may hold commas, and `""` stands
/// for a quote in it. A line's quotes are closed on it: a sphere is a line.
fn with_quotes(line: &str) -> Result<csv::StringRecord, String> {
    if line.matches('"').count() % 2 == 1 {
        return Err("a quote is not closed: close it on the same line".to_string());
    }
    let mut record = csv::StringRecord::new();
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(line.as_bytes());
    reader.read_record(&mut record).map_err(|e| e.to_string())?;
    Ok(record)
}
