//! JUnit XML reports, the format CI systems show as test results (GitHub Actions' report
//! actions, GitLab, Jenkins): one test suite per shot, one test case per frame.

use std::fmt::Write as _;
use std::path::Path;

use super::error::Result;

/// One test suite: a shot's frames.
pub struct Suite {
    name: String,
    /// Each case's name and, when it failed, why.
    cases: Vec<(String, Option<String>)>,
    /// A suite that could not run at all (a shot that does not load).
    error: Option<String>,
}

impl Suite {
    pub fn new(name: &str) -> Suite {
        Suite {
            name: name.to_string(),
            cases: Vec::new(),
            error: None,
        }
    }

    /// A suite with one errored case: the shot could not be checked.
    pub fn errored(name: &str, message: &str) -> Suite {
        Suite {
            error: Some(message.to_string()),
            ..Suite::new(name)
        }
    }

    /// Adds a case, failed with `failure` when it is Some.
    pub fn case(&mut self, name: &str, failure: Option<String>) {
        self.cases.push((name.to_string(), failure));
    }

    fn failures(&self) -> usize {
        self.cases.iter().filter(|(_, f)| f.is_some()).count()
    }

    fn tests(&self) -> usize {
        self.cases.len() + usize::from(self.error.is_some())
    }
}

/// The report's text.
pub fn text(name: &str, suites: &[Suite]) -> String {
    let mut xml = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let tests: usize = suites.iter().map(Suite::tests).sum();
    let failures: usize = suites.iter().map(Suite::failures).sum();
    let errors = suites.iter().filter(|s| s.error.is_some()).count();
    let _ = writeln!(
        xml,
        "<testsuites name=\"{}\" tests=\"{tests}\" failures=\"{failures}\" errors=\"{errors}\">",
        escape(name)
    );
    for s in suites {
        let suite = escape(&s.name);
        let _ = writeln!(
            xml,
            "  <testsuite name=\"{suite}\" tests=\"{}\" failures=\"{}\" errors=\"{}\" skipped=\"0\">",
            s.tests(),
            s.failures(),
            usize::from(s.error.is_some())
        );
        if let Some(e) = &s.error {
            let e = escape(e);
            let _ = writeln!(
                xml,
                "    <testcase classname=\"{suite}\" name=\"load\">\n      <error message=\"{e}\" type=\"bad shot\">{e}</error>\n    </testcase>"
            );
        }
        for (case, failure) in &s.cases {
            let case = escape(case);
            let _ = write!(xml, "    <testcase classname=\"{suite}\" name=\"{case}\"");
            match failure {
                None => xml += "/>\n",
                Some(message) => {
                    let message = escape(message);
                    let _ = writeln!(
                        xml,
                        ">\n      <failure message=\"{message}\" type=\"hash mismatch\">{message}</failure>\n    </testcase>"
                    );
                }
            }
        }
        xml += "  </testsuite>\n";
    }
    xml += "</testsuites>\n";
    xml
}

/// Refuses (exit 2, before anything runs) a report path that is a folder or a file campath did
/// not write as a JUnit report: `--junit` never overwrites a shot or anything else.
pub fn check_target(path: &Path) -> Result<()> {
    const OURS: &[u8] = b"<testsuites name=\"campath ";
    super::args::report_target("--junit", path, "a JUnit report", |b| {
        b.starts_with(b"<?xml") && b.windows(OURS.len()).any(|w| w == OURS)
    })
}

/// Writes the report to `path` (through a temporary file and a rename).
pub fn write(path: &Path, name: &str, suites: &[Suite]) -> Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(crate::Error::write(parent))?;
    }
    Ok(crate::output::write_atomic(path, text(name, suites))?)
}

/// Escapes text for an XML attribute or element (or HTML). What XML 1.0 cannot hold at all (the
/// control characters other than tab, LF and CR, and U+FFFE, U+FFFF; a Rust string has no
/// surrogates) is written as its Rust escape, `\u{1b}`; tab, LF and CR as character references,
/// which a parser keeps as they are in an attribute too; `& < > " '` as entities.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\t' | '\n' | '\r' => {
                let _ = write!(out, "&#{};", u32::from(c));
            }
            '\0'..='\u{1f}' | '\u{fffe}' | '\u{ffff}' => {
                let _ = write!(out, "{}", c.escape_unicode());
            }
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every character XML cannot hold comes out as its Rust escape, and the legal text around
    /// it, markup characters and line ends included, is what a parser reads back, in an
    /// attribute and in an element.
    #[test]
    fn escaped_text_is_xml_that_reads_back() {
        let message = "a\u{1}b\u{1b}[31mred\u{fffe}\u{ffff}]]><&\"' x\ty\r\nz\u{10ffff}\u{d7ff}";
        let legal = "a\\u{1}b\\u{1b}[31mred\\u{fffe}\\u{ffff}]]><&\"' x\ty\r\nz\u{10ffff}\u{d7ff}";
        let mut suite = Suite::new(message);
        suite.case("frame 0", Some(message.to_string()));
        let xml = text("campath test", &[suite]);
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let failure = doc
            .descendants()
            .find(|n| n.has_tag_name("failure"))
            .unwrap();
        assert_eq!(failure.attribute("message"), Some(legal));
        assert_eq!(failure.text(), Some(legal));
        let suite = doc
            .descendants()
            .find(|n| n.has_tag_name("testsuite"))
            .unwrap();
        assert_eq!(suite.attribute("name"), Some(legal));
        // Each character outside XML's, one at a time, in a document of its own.
        for c in (0..0x20u32)
            .chain([0xfffe, 0xffff])
            .filter_map(char::from_u32)
        {
            let xml = format!("<a b=\"{0}\">{0}</a>", escape(&c.to_string()));
            let doc = roxmltree::Document::parse(&xml).unwrap();
            let want = match c {
                '\t' | '\n' | '\r' => c.to_string(),
                _ => c.escape_unicode().to_string(),
            };
            assert_eq!(doc.root_element().attribute("b"), Some(want.as_str()));
            assert_eq!(doc.root_element().text(), Some(want.as_str()));
        }
    }
}
