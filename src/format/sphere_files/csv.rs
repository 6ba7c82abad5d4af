//! The CSV form: a header line naming the columns, then a sphere a line. Columns are found by
//! name in any order, extra ones read past ([`Layout`]). A line is split at its commas, each
//! field trimmed; a line that does not read so and holds a `"` is read again as CSV with quotes
//! (RFC 4180), by the csv crate. Since no field with a `"` is a number, a line without quotes
//! reads as it always did.

use std::io::BufRead;

use super::header::{HeaderLines, CR_ALONE};
use super::listing::{FileProblem, Listing, Location};
use super::look::{Column, Kind, Layout, Words, SLOTS};
use super::text::{text_records, Rows};
use crate::format::{SphereFileSpec, SphereSpec};

/// The CSV form read from `file`: the header line, then the body's lines in blocks on the
/// pool ([`text_records`]).
pub(super) fn csv_from<T>(
    mut file: impl BufRead + Send,
    spec: &SphereFileSpec,
    out: &mut Vec<T>,
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
    let fields = Fields::new(&layout, &names);
    let parse = |line: &str, _: &mut Vec<f64>| {
        let read = fields
            .words(line.split(','))
            .and_then(|w| layout.sphere(&w));
        match read {
            Err(_) if line.contains('"') => fields.requoted(line, &layout),
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

/// Which of a line's fields each slot reads.
pub(super) struct Fields {
    /// (column, slot), by column.
    wanted: Vec<(usize, usize)>,
    /// How many fields a line holds, and the header's names for a message.
    count: usize,
    names: String,
}

impl Fields {
    pub(super) fn new(layout: &Layout, names: &[String]) -> Fields {
        let mut wanted: Vec<(usize, usize)> = (layout.cols.iter().enumerate())
            .filter_map(|(slot, col)| col.map(|k| (k, slot)))
            .collect();
        wanted.sort_unstable();
        let joined = names.join(",");
        Fields {
            wanted,
            count: names.len(),
            names: match joined.chars().count() <= 60 {
                true => joined,
                false => "as the header names them".to_string(),
            },
        }
    }

    /// A line's fields (trimmed here), one a slot; the line must have the header's count.
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
        if got != self.count {
            return Err(format!(
                "expected {} fields ({}), got {got}",
                self.count, self.names
            ));
        }
        Ok(Words(words))
    }

    /// The sphere of a line that holds a quote, read as CSV with quotes.
    #[cold]
    fn requoted(&self, line: &str, layout: &Layout) -> Result<SphereSpec, String> {
        let record = with_quotes(line)?;
        layout.sphere(&self.words(record.iter())?)
    }
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
