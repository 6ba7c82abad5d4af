//! The CSV form: a header line naming the columns, then a sphere a line. Columns are found by
//! name in any order, extra ones read past ([`Layout`]). A line is split at its commas, each
//! field trimmed; a line that does not read so and holds a `"` is read again as CSV with quotes
//! (RFC 4180), by the csv crate. Since no field with a `"` is a number, a line without quotes
//! reads as it always did.

use std::io::BufRead;

use super::header::{HeaderLines, CR_ALONE};
use super::listing::{FileProblem, Listing, Location};
use super::look::{Column, Fields, Kind, Layout};
use super::text::{text_records, Rows};
use super::Sink;
use crate::format::{SphereFileSpec, SphereSpec};

/// The CSV form read from `file`: the header line, then the body's lines in blocks on the
/// pool ([`text_records`]).
pub(super) fn csv_from<T>(
    mut file: impl BufRead + Send,
    spec: &SphereFileSpec,
    out: &mut impl Sink<T>,
    make: &impl Fn(usize, &SphereSpec) -> T,
    listing: &mut Listing,
) -> Result<(), FileProblem> {
    let mut lines = HeaderLines::new("is it a CSV file?", false);
    let (n, header) = loop {
        match lines.next(&mut file)? {
            None => {
                return Err(FileProblem::whole(
                    "empty: expected a header line, as x,y,z,radius",
                ))
            }
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
    // A header some tools mark as a comment: `# x,y,z` (NumPy), `//X,Y,Z` (CloudCompare).
    let names_text = (header
        .strip_prefix("//")
        .or_else(|| header.strip_prefix('#')))
    .unwrap_or(&header);
    let bad_header = |e: String| {
        // A line that still holds a CR: lines end in CR alone.
        let cr = match header.contains('\r') {
            true => format!(" ({CR_ALONE})"),
            false => String::new(),
        };
        FileProblem::at(Location::Line(n), format!("{e}{cr}"))
    };
    let names: Vec<String> = match names_text.contains('"') {
        true => with_quotes(names_text)
            .map_err(bad_header)?
            .iter()
            .map(|f| f.trim().to_string())
            .collect(),
        false => names_text
            .split(',')
            .map(|f| f.trim().to_string())
            .collect(),
    };
    let columns: Vec<Column> = (names.iter())
        .map(|name| Column {
            name: name.clone(),
            kind: Kind::Number,
        })
        .collect();
    let layout = Layout::resolve(spec, &columns).map_err(bad_header)?;
    listing.ignored = layout.ignored.clone();
    let fields = Fields::new(&layout, &names, false);
    let parse = |line: &str, _: &mut Vec<f64>| {
        let read = fields
            .words(line.split(','))
            .and_then(|w| layout.sphere(&w));
        match read {
            Err(_) if line.contains('"') => requoted(&fields, line, &layout),
            read => read,
        }
    };
    let first = n + 1;
    listing.first_line = Some(first);
    let mut gaps = false;
    let mut count = 0;
    let take = |line, sphere: Result<SphereSpec, String>| match sphere {
        Ok(sphere) => {
            gaps |= line != first + count;
            out.put(make(count, &sphere));
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

/// The sphere of a line that holds a quote, read as CSV with quotes.
#[cold]
fn requoted(fields: &Fields, line: &str, layout: &Layout) -> Result<SphereSpec, String> {
    let record = with_quotes(line)?;
    layout.sphere(&fields.words(record.iter())?)
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
