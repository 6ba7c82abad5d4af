//! The RON loader under arbitrary and mutated input: it answers Ok or a typed error, never
//! panics, and the checked file's path evaluates. Fixed seeds, so every run tries the same
//! inputs.

use std::path::Path;

use campath::document::Document;
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

/// Loads `text`; when it checks, evaluates the path of small animations too.
fn load(text: &str) {
    if let Ok(doc) = Document::from_str(Path::new("fuzz.ron"), text) {
        if doc.animation.frames <= 10_000 {
            let _ = doc.check_path();
        }
    }
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

#[test]
fn number_edge_cases_in_every_numeric_field_are_errors_or_ok() {
    let base =
        std::fs::read_to_string(crate::common::root().join("animations/flythrough.ron")).unwrap();
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
        for needle in ["1.0", "0.0", "2.0", "-10.0", "24.0", "640", "96"] {
            load(&base.replacen(needle, bad, 1));
        }
    }
}
