//! The CSV form: a header `x,y,z,radius` or `x,y,z,radius,r,g,b`, then a sphere a line.

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
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
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
    let fields = names.len();
    let parse = |line: &str, _: &mut Vec<f64>| -> Result<SphereSpec, String> {
        let mut words = [""; 7];
        let mut got = 0;
        for (k, field) in line.split(',').enumerate() {
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
            *value = text_f64(word)
                .ok_or_else(|| format!("{}: not a number: {}", CSV_NAMES[k], quoted(word)))?;
        }
        let [x, y, z, radius, r, g, b] = values;
        Ok(SphereSpec {
            center: (x, y, z),
            radius,
            color: colours.then_some((r, g, b)),
        })
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
