//! The RON loader under arbitrary and mutated input: it answers Ok or a typed error that says
//! where the problem is, never panics, and answers the same input the same way twice; the
//! checked file's path evaluates. Fixed seeds, so every run tries the same inputs.

use std::path::Path;

use campath::document::Document;
use campath::Error;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0xF022),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Loads `text` as `fuzz.ron`; when it checks, evaluates the path of small animations too.
fn load_once(text: &str) -> campath::Result<Document> {
    let doc = Document::from_str(Path::new("fuzz.ron"), text)?;
    if doc.animation().frames <= 10_000 {
        doc.check_path()?;
    }
    Ok(doc)
}

/// Loads `text` twice and checks the answer: the same both times, and an error that says where
/// its problem is (in `fuzz.ron`, at a line and column inside the text, at a named field, or
/// at one of the file's frames). The error, if any, is returned.
fn load(text: &str) -> Option<Error> {
    let (first, again) = (load_once(text), load_once(text));
    assert_eq!(
        format!("{first:?}"),
        format!("{again:?}"),
        "two answers to {text:?}"
    );
    let e = first.err()?;
    let fuzz = Path::new("fuzz.ron");
    match &e {
        Error::Parse {
            path, line, col, ..
        } => {
            // RON counts lines by '\n'; an error at the very end may sit on the line after it.
            let lines = text.matches('\n').count() + 1;
            assert!(
                path == fuzz && (1..=lines).contains(line) && *col >= 1,
                "{e} for {text:?}"
            );
        }
        Error::Invalid { path, problems } => assert!(
            path == fuzz
                && !problems.0.is_empty()
                && problems.0.iter().all(|p| !p.field.is_empty()),
            "{e} for {text:?}"
        ),
        Error::Frame { path, .. } => assert_eq!(path, fuzz, "{e} for {text:?}"),
        other => panic!("an error of no place in the text: {other} for {text:?}"),
    }
    assert!(e.is_bad_input(), "{e}");
    assert!(e.to_string().starts_with("fuzz.ron:"), "{e}");
    Some(e)
}

#[test]
fn arbitrary_bytes_never_panic() {
    TestRunner::new(config(3000))
        .run(&proptest::collection::vec(any::<u8>(), 0..400), |bytes| {
            load(&String::from_utf8_lossy(&bytes));
            Ok(())
        })
        .unwrap();
}

#[test]
fn mutated_examples_never_panic() {
    let sources: Vec<String> = crate::common::EXAMPLES
        .iter()
        .map(|n| {
            std::fs::read_to_string(crate::common::root().join(format!("animations/{n}.ron")))
                .unwrap()
        })
        .collect();
    // Edits: replace, insert or delete a character at a position; digits and RON punctuation
    // are the interesting replacements.
    let alphabet: Vec<char> = "0123456789.-e()[],:_ aAzZ\"/".chars().collect();
    let edit = (
        0..sources.len(),
        proptest::collection::vec(
            (0..3u8, any::<prop::sample::Index>(), 0..alphabet.len()),
            1..6,
        ),
    );
    TestRunner::new(config(1500))
        .run(&edit, |(which, edits)| {
            let mut chars: Vec<char> = sources[which].chars().collect();
            for (kind, at, c) in edits {
                let i = at.index(chars.len().max(1));
                match kind {
                    0 if i < chars.len() => chars[i] = alphabet[c],
                    1 => chars.insert(i.min(chars.len()), alphabet[c]),
                    _ if i < chars.len() => {
                        chars.remove(i);
                    }
                    _ => {}
                }
            }
            load(&chars.into_iter().collect::<String>());
            Ok(())
        })
        .unwrap();
}

/// Each number of `flythrough.ron`'s first lines replaced by an edge case: an error where the
/// value breaks the file's rules, at the line of the number or naming its field, else Ok.
#[test]
fn number_edge_cases_in_every_numeric_field_are_errors_or_ok() {
    let base =
        std::fs::read_to_string(crate::common::root().join("animations/flythrough.ron")).unwrap();
    // Each number's first place in the file, read off the file: its field, and whether it is a
    // count (an integer) or a float.
    let fields = [
        ("1.0", "camera.vuv", false),
        ("0.0", "camera.vrp", false),
        ("2.0", "camera.vrp", false),
        ("-10.0", "camera.vrp", false),
        ("24.0", "fps", false),
        ("640", "image.width", true),
        ("96", "frames", true),
    ];
    for bad in [
        "inf",
        "-inf",
        "NaN",
        "1e308",
        "-1e308",
        "0.0",
        "-0.0",
        "1e-320",
        "18446744073709551616",
    ] {
        for (needle, field, count) in fields {
            let at = base.find(needle).unwrap();
            let line = base[..at].matches('\n').count() + 1;
            let text = base.replacen(needle, bad, 1);
            let e = load(&text);
            // Every number must be finite and within ±1e150 (format.md); a count must be a
            // whole number in range, which none of these is.
            let must_fail = count || ["inf", "-inf", "NaN", "1e308", "-1e308"].contains(&bad);
            let Some(e) = e else {
                assert!(!must_fail, "{needle} -> {bad}: accepted");
                continue;
            };
            let located = match &e {
                Error::Parse { line: at, .. } => *at == line,
                Error::Invalid { problems, .. } => {
                    problems.0.iter().any(|p| p.field.starts_with(field))
                }
                Error::Frame { .. } => !count,
                _ => false,
            };
            assert!(located, "{needle} -> {bad} (line {line}, {field}): {e}");
        }
    }
}
