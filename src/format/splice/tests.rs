use super::*;
use crate::format::{parse, FileSpec, KeySpec, TrackSpec};
use proptest::prelude::*;
use std::fmt::Debug;
use std::path::{Path, PathBuf};

/// A key as RON reads it: its time, and its value and interpolation as Debug writes them.
type Row = (f64, String, String);

fn row<V: Debug>(k: &KeySpec<V>) -> Row {
    (
        k.t,
        format!("{:?}", k.value),
        format!("{:?}", k.interpolation),
    )
}

/// The keys of `mode`'s track as `parse` reads them, or None without the track.
fn keys(spec: &FileSpec, mode: Mode) -> Option<Vec<Row>> {
    let track = spec.animate.iter().find(|tr| tr.mode() == mode)?;
    Some(match track {
        TrackSpec::Observer { keys, .. }
        | TrackSpec::LookAround { keys, .. }
        | TrackSpec::Track { keys, .. } => keys.iter().map(row).collect(),
        TrackSpec::Zoom { keys, .. } | TrackSpec::Roll { keys, .. } => {
            keys.iter().map(row).collect()
        }
        TrackSpec::Distort { keys, .. } => keys.iter().map(row).collect(),
    })
}

/// Everything an edit of `mode`'s keys must leave as it was: the file without those keys (or
/// without the whole track, when the edit adds or removes it) and without the fields' order
/// (which gains `animate` when the edit adds it).
fn rest(spec: &FileSpec, mode: Mode, whole_track: bool) -> String {
    let mut spec = spec.clone();
    spec.order.retain(|f| f != "animate");
    spec.animate
        .retain(|tr| !(whole_track && tr.mode() == mode));
    for track in &mut spec.animate {
        let mine = track.mode() == mode;
        match track {
            TrackSpec::Observer { keys, .. }
            | TrackSpec::LookAround { keys, .. }
            | TrackSpec::Track { keys, .. }
                if mine =>
            {
                keys.clear()
            }
            TrackSpec::Zoom { keys, .. } | TrackSpec::Roll { keys, .. } if mine => keys.clear(),
            TrackSpec::Distort { keys, .. } if mine => keys.clear(),
            _ => {}
        }
    }
    format!("{spec:?}")
}

/// A value text for `mode`'s track that Debug writes the same way once RON has read it.
fn value(mode: Mode) -> &'static str {
    match mode {
        Mode::Zoom => "-2.25",
        Mode::Roll => "22.5",
        Mode::Distort => "(0.25, -0.5)",
        _ => "(1.0, 2.0, -3.0)",
    }
}

/// The example files and the shots, as (path, text).
fn files() -> Vec<(PathBuf, String)> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "ron") {
                out.push(path);
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut paths: Vec<PathBuf> = std::fs::read_dir(root.join("animations"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    walk(&root.join("tests/shots"), &mut paths);
    paths.sort();
    assert!(paths.len() >= 10, "{paths:?}");
    let read = |p: PathBuf| (std::fs::read_to_string(&p).unwrap(), p);
    paths.into_iter().map(read).map(|(t, p)| (p, t)).collect()
}

/// The inside of the `[…]` that follows byte `from`, by counting brackets: the test's own
/// reading, enough for files whose comments there hold no brackets.
fn inside(text: &str, from: usize) -> Range<usize> {
    let open = from + text[from..].find('[').unwrap();
    let mut depth = 0;
    for (i, c) in text[open..].char_indices() {
        match c {
            '[' => depth += 1,
            ']' if depth == 1 => return open + 1..open + i,
            ']' => depth -= 1,
            _ => {}
        }
    }
    panic!("no ] after {from}")
}

/// The bytes of `before` that differ from `after`: all before them and after them is shared.
fn changed(before: &str, after: &str) -> Range<usize> {
    let (a, b) = (before.as_bytes(), after.as_bytes());
    let p = a.iter().zip(b).take_while(|(x, y)| x == y).count();
    let most = a.len().min(b.len()) - p;
    let q = a.iter().rev().zip(b.iter().rev()).take(most);
    p..a.len() - q.take_while(|(x, y)| x == y).count()
}

/// Applies `edit` and checks the result: it parses, `mode`'s keys are `expected` (None: no
/// track), everything else parses as before, and the text changed only within `within`.
fn check(
    path: &Path,
    before: &str,
    mode: Mode,
    edit: &KeyEdit,
    expected: Option<Vec<Row>>,
    within: Range<usize>,
) -> String {
    let what = format!("{}: {mode} {edit:?}", path.display());
    let after = edit_keys(before, mode, edit).unwrap_or_else(|e| panic!("{what}: {e}"));
    let (a, b) = (parse(path, before).unwrap(), parse(path, &after));
    let b = b.unwrap_or_else(|e| panic!("{what}: {e}\n{after}"));
    assert_eq!(keys(&b, mode), expected, "{what}\n{after}");
    let whole = keys(&a, mode).is_none() || expected.is_none();
    assert_eq!(rest(&a, mode, whole), rest(&b, mode, whole), "{what}");
    let at = changed(before, &after);
    assert!(
        within.start <= at.start && at.end <= within.end,
        "{what}: changed {at:?} outside {within:?}\n{after}"
    );
    after
}

/// Every example file and shot takes sets, moves and deletes in every mode, with the result
/// RON reads as the expected change and the text outside the keys (or `animate`) untouched;
/// inserting then deleting a key, and moving one there and back, give the text back.
#[test]
fn every_file_takes_every_edit() {
    for (path, text) in files() {
        let p = path.as_path();
        let spec = parse(p, &text).unwrap();
        let animate = inside(&text, text.find("animate:").unwrap());
        for mode in Mode::ALL {
            let v = value(mode).to_string();
            let new = |t: f64| (t, v.clone(), "None".to_string());
            let Some(old) = keys(&spec, mode) else {
                let set = KeyEdit::Set {
                    t: 0.5,
                    value: v.clone(),
                };
                let added = check(p, &text, mode, &set, Some(vec![new(0.5)]), animate.clone());
                let back = edit_keys(&added, mode, &KeyEdit::Delete { index: 0 });
                assert_eq!(back.as_deref(), Ok(text.as_str()));
                for edit in [
                    KeyEdit::Move { index: 0, t: 1.0 },
                    KeyEdit::Delete { index: 0 },
                ] {
                    let e = edit_keys(&text, mode, &edit);
                    assert_eq!(e, Err(SpliceError::NoTrack { track: mode.name() }));
                }
                continue;
            };
            let span = inside(&text, text.find(&format!("{}(keys:", mode.name())).unwrap());
            let n = old.len();
            let (first, last) = (old[0].0, old[n - 1].0);
            let edit = |e: &KeyEdit, expected: Option<Vec<Row>>, within: &Range<usize>| {
                check(p, &text, mode, e, expected, within.clone())
            };
            let back = |edited: &str, e: KeyEdit| {
                assert_eq!(
                    edit_keys(edited, mode, &e).as_deref(),
                    Ok(text.as_str()),
                    "{e:?}"
                );
            };

            // Set on a key's time: its value replaced, its interpolation kept.
            let mut expected = old.clone();
            expected[0].1 = v.clone();
            edit(
                &KeyEdit::Set {
                    t: first,
                    value: v.clone(),
                },
                Some(expected),
                &span,
            );

            // Set at new times before, between and after: inserted in order, and deleted again.
            let mut times = vec![(first - 0.5, 0), (last + 1.0, n)];
            if n >= 2 {
                times.push(((old[0].0 + old[1].0) / 2.0, 1));
            }
            for (t, at) in times {
                let mut expected = old.clone();
                expected.insert(at, new(t));
                let set = KeyEdit::Set {
                    t,
                    value: v.clone(),
                };
                let added = edit(&set, Some(expected), &span);
                back(&added, KeyEdit::Delete { index: at });
            }

            // Move the first key past the last and back, and the last to the front and back.
            let mut expected = old.clone();
            let mut moved = expected.remove(0);
            moved.0 = last + 0.5;
            expected.push(moved);
            let there = edit(
                &KeyEdit::Move {
                    index: 0,
                    t: last + 0.5,
                },
                Some(expected),
                &span,
            );
            back(
                &there,
                KeyEdit::Move {
                    index: n - 1,
                    t: first,
                },
            );
            let mut expected = old.clone();
            let mut moved = expected.remove(n - 1);
            moved.0 = first - 1.0;
            expected.insert(0, moved);
            let there = edit(
                &KeyEdit::Move {
                    index: n - 1,
                    t: first - 1.0,
                },
                Some(expected),
                &span,
            );
            back(&there, KeyEdit::Move { index: 0, t: last });

            // Delete the first and the last; a track's only key takes the track with it.
            for index in [0, n - 1] {
                let mut expected = old.clone();
                expected.remove(index);
                if expected.is_empty() {
                    edit(&KeyEdit::Delete { index }, None, &animate);
                } else {
                    edit(&KeyEdit::Delete { index }, Some(expected), &span);
                }
            }

            // What cannot be done.
            let count = n;
            let e = edit_keys(&text, mode, &KeyEdit::Delete { index: n });
            let track = mode.name();
            assert_eq!(
                e,
                Err(SpliceError::NoKey {
                    track,
                    index: n,
                    count
                })
            );
            if n >= 2 {
                let e = edit_keys(
                    &text,
                    mode,
                    &KeyEdit::Move {
                        index: 0,
                        t: old[1].0,
                    },
                );
                assert!(matches!(e, Err(SpliceError::TimeTaken { .. })), "{e:?}");
            }
        }
    }
}

/// A keyframe file with comments in and around its keys, brackets in its strings and a
/// byte-order mark.
const COMMENTED: &str = "\u{feff}// top (
(
    camera: (tp: (0.0, 0.0, 0.0)),
    animate: [
        // the path ]
        Observer(
            interpolation: Linear, // per track
            keys: [
                // start
                (t: 0.0, value: (0.0, 0.0, -5.0)),
                // middle /* ] */
                (value: (1.0, 0.0, -5.0) /* x */, t: 1.0, interpolation: Some(Cosine)),
                /* before /* nested */ the end */
                (t: 2.0, value: (2.0, 0.0, -5.0)), // end
            ],
        ),
    ],
    scene: (sphere_files: [\"a]\\\".ron\", r#\"b\"]\"#]), // ] in strings
)
";

const COMMENTS: [&str; 8] = [
    "// top (",
    "// the path ]",
    "// per track",
    "// start",
    "// middle /* ] */",
    "/* x */",
    "/* before /* nested */ the end */",
    "// end",
];

/// Every comment but those inside a deleted key survives every edit, and the edits are what
/// RON reads.
#[test]
fn comments_survive() {
    let p = Path::new("commented.ron");
    let text = COMMENTED;
    let spec = parse(p, text).unwrap();
    let old = keys(&spec, Mode::Observer).unwrap();
    assert_eq!(old.len(), 3);
    let all = 0..text.len();
    let v = value(Mode::Observer);
    let new = (0.5, v.to_string(), "None".to_string());
    let edits = [
        (
            KeyEdit::Set {
                t: 0.5,
                value: v.into(),
            },
            vec![old[0].clone(), new, old[1].clone(), old[2].clone()],
        ),
        (
            KeyEdit::Set {
                t: 1.0,
                value: v.into(),
            },
            {
                let mut k = old.clone();
                k[1].1 = v.into();
                k
            },
        ),
        (KeyEdit::Move { index: 1, t: 3.0 }, {
            let mut k = vec![old[0].clone(), old[2].clone(), old[1].clone()];
            k[2].0 = 3.0;
            k
        }),
        (
            KeyEdit::Delete { index: 0 },
            vec![old[1].clone(), old[2].clone()],
        ),
        (
            KeyEdit::Delete { index: 1 },
            vec![old[0].clone(), old[2].clone()],
        ),
        (
            KeyEdit::Delete { index: 2 },
            vec![old[0].clone(), old[1].clone()],
        ),
    ];
    for (edit, expected) in edits {
        let after = check(p, text, Mode::Observer, &edit, Some(expected), all.clone());
        assert!(after.starts_with("\u{feff}// top"), "{edit:?}");
        let lost = |c: &&str| *c == "/* x */" && edit == KeyEdit::Delete { index: 1 };
        for comment in COMMENTS.iter().filter(|c| !lost(c)) {
            assert!(after.contains(comment), "{edit:?} lost {comment}:\n{after}");
        }
    }
    // The last key deleted where comments sit before it, with and without a trailing comma.
    let two = edit_keys(text, Mode::Observer, &KeyEdit::Delete { index: 0 }).unwrap();
    let one = edit_keys(&two, Mode::Observer, &KeyEdit::Delete { index: 1 }).unwrap();
    assert!(
        one.contains("the end */\n                 // end\n            ],"),
        "{one}"
    );
    let no_comma = two.replace("(2.0, 0.0, -5.0)), // end", "(2.0, 0.0, -5.0)) // end");
    let one = edit_keys(&no_comma, Mode::Observer, &KeyEdit::Delete { index: 1 }).unwrap();
    let kept = "Some(Cosine))\n                /* before /* nested */ the end */\n                 // end\n";
    assert!(one.contains(kept), "{one}");
    parse(p, &one).unwrap();
    // Round trips.
    let set = KeyEdit::Set {
        t: 1.5,
        value: v.into(),
    };
    let added = edit_keys(text, Mode::Observer, &set).unwrap();
    assert_eq!(
        edit_keys(&added, Mode::Observer, &KeyEdit::Delete { index: 2 }).unwrap(),
        text
    );
    let moved = edit_keys(text, Mode::Observer, &KeyEdit::Move { index: 1, t: -1.0 }).unwrap();
    assert!(moved.contains("(value: (1.0, 0.0, -5.0) /* x */, t: -1.0, interpolation: Some(Cosine)),\n                // middle"), "{moved}");
    let back = edit_keys(&moved, Mode::Observer, &KeyEdit::Move { index: 0, t: 1.0 });
    assert_eq!(back.unwrap(), text);
}

/// New keys, tracks and `animate` itself take the style of what is already there.
#[test]
fn additions_follow_the_style_around_them() {
    let zoom = |text: &str, t: f64| {
        let set = KeyEdit::Set {
            t,
            value: "-1.5".into(),
        };
        let after = edit_keys(text, Mode::Zoom, &set).unwrap();
        parse(Path::new("x.ron"), &after).unwrap_or_else(|e| panic!("{e}\n{after}"));
        after
    };
    let cam = "camera: (tp: (0.0, 0.0, 0.0))";
    // No `animate`: a field after the last, with its indentation and trailing comma or none.
    assert_eq!(
        zoom(&format!("(\n    frames: 2,\n    {cam},\n)"), 1.0),
        format!(
            "(\n    frames: 2,\n    {cam},\n    animate: [Zoom(keys: [(t: 1.0, value: -1.5)])],\n)"
        )
    );
    assert_eq!(
        zoom(&format!("(frames: 2, {cam})"), 1.0),
        format!("(frames: 2, {cam}, animate: [Zoom(keys: [(t: 1.0, value: -1.5)])])")
    );
    // An empty list, a one-line list, a list one key a line.
    assert_eq!(
        zoom(&format!("({cam}, animate: [Zoom(keys: [])])"), 2.0),
        format!("({cam}, animate: [Zoom(keys: [(t: 2.0, value: -1.5)])])")
    );
    assert_eq!(
        zoom(&format!("({cam}, animate: [])"), 2.0),
        format!("({cam}, animate: [Zoom(keys: [(t: 2.0, value: -1.5)])])")
    );
    let one_line = format!("({cam}, animate: [Zoom(interpolation: Linear, keys: [(t: 0.0, value: -1.0),(t: 3.0, value: -2.0)])])");
    assert_eq!(
        zoom(&one_line, 1e-7),
        one_line.replace("-1.0),", "-1.0),(t: 1e-7, value: -1.5),")
    );
    let lines = format!("({cam}, animate: [\n  Zoom(keys: [\n    (t: 0.0, value: -1.0),\n    (t: 3.0, value: -2.0),\n  ]),\n])");
    assert_eq!(
        zoom(&lines, 4.0),
        lines.replace("-2.0),\n", "-2.0),\n    (t: 4.0, value: -1.5),\n")
    );
    // A second track: one a line after the first, or after ", ".
    let look = format!(
        "({cam}, animate: [\n    LookAround(keys: [(t: 0.0, value: (0.0, 0.0, 1.0))]),\n])"
    );
    assert_eq!(
        zoom(&look, 1.0),
        look.replace("]),\n", "]),\n    Zoom(keys: [(t: 1.0, value: -1.5)]),\n")
    );
    let look = format!("({cam}, animate: [LookAround(keys: [(t: 0.0, value: (0.0, 0.0, 1.0))])])");
    assert_eq!(
        zoom(&look, 1.0),
        look.replace("])])", "]), Zoom(keys: [(t: 1.0, value: -1.5)])])")
    );
    // The struct's name, an attribute and a raw identifier are passed over.
    let named = format!("#![enable(implicit_some)]\nfile(r#frames: 2, {cam})");
    let set = KeyEdit::Set {
        t: 0.0,
        value: "-1.5".into(),
    };
    let after = edit_keys(&named, Mode::Zoom, &set).unwrap();
    parse(Path::new("x.ron"), &after).unwrap();
    assert_eq!(
        after,
        format!("#![enable(implicit_some)]\nfile(r#frames: 2, {cam}, animate: [Zoom(keys: [(t: 0.0, value: -1.5)])])")
    );
}

/// What cannot be edited is refused with where and why.
#[test]
fn errors_say_where_and_why() {
    let set = |t: f64, value: &str| KeyEdit::Set {
        t,
        value: value.into(),
    };
    let cases: [(&str, KeyEdit, &str); 12] = [
        (
            "(animate: [Observer(keys: 3)])",
            set(0.0, "(0.0, 0.0, 0.0)"),
            "line 1: the Observer track's keys are not a list",
        ),
        (
            "(\n animate: [Observer(keys: []),\n Observer(keys: [])])",
            set(0.0, "(0.0, 0.0, 0.0)"),
            "line 3: the Observer track appears a second time (first on line 2)",
        ),
        (
            "(animate: [Zoom(keys: [(t: 0.0, value: -1.0)])])",
            KeyEdit::Delete { index: 3 },
            "the Zoom track has no key 3: it has 1",
        ),
        (
            "(animate: [Zoom(keys: [(t: 0.0, value: -1.0), (t: 1.0, value: -1.0)])])",
            KeyEdit::Move { index: 0, t: 1.0 },
            "line 1: the Zoom track already has a key at t = 1.0 s",
        ),
        (
            "(animate: [])",
            KeyEdit::Move { index: 0, t: 1.0 },
            "the file has no Zoom track",
        ),
        (
            "(\n\n /* a /* b */ (",
            set(0.0, "-1.0"),
            "line 3: the block comment is not closed",
        ),
        (
            "(frames: \"2)",
            set(0.0, "-1.0"),
            "line 1: the string is not closed",
        ),
        (
            "[1, 2]",
            set(0.0, "-1.0"),
            "the text is not a RON struct `(…)`",
        ),
        (
            "(\nanimate: [Zoom(keys: [(t: x, value: -1.0)])])",
            set(0.0, "-1.0"),
            "line 2: key 0 of the Zoom track has a t that is not a number",
        ),
        (
            "(animate: [Zoom(keys: [)])",
            set(0.0, "-1.0"),
            "line 1: `)` is not expected here",
        ),
        (
            "(animate: [])",
            set(f64::NAN, "-1.0"),
            "t = NaN is not a finite time in seconds",
        ),
        (
            "(animate: [])",
            set(0.0, "-1.0) // x"),
            "`-1.0) // x` is not one RON value",
        ),
    ];
    for (text, edit, message) in cases {
        let mode = if text.contains("Observer") {
            Mode::Observer
        } else {
            Mode::Zoom
        };
        let e = edit_keys(text, mode, &edit).map_err(|e| e.to_string());
        assert_eq!(e, Err(message.to_string()), "{text}");
    }
    let deep = format!("({}", "[".repeat(1000));
    assert_eq!(
        edit_keys(&deep, Mode::Zoom, &set(0.0, "-1.0")),
        Err(SpliceError::TooDeep { line: 1 })
    );
}

/// `number` reads back as the same f64, as a float, and never as "-0".
#[test]
fn numbers_read_back() {
    for (x, text) in [
        (2.0, "2.0"),
        (0.1, "0.1"),
        (-1.5, "-1.5"),
        (1e-7, "1e-7"),
        (-0.0, "0.0"),
        (1e300, "1e300"),
        (2.4583333333333335, "2.4583333333333335"),
    ] {
        assert_eq!(number(x), text);
    }
    let mut rng = crate::splitmix::SplitMix(7);
    let mut bits =
        || ((rng.unit() * 4294967296.0) as u64) << 32 | (rng.unit() * 4294967296.0) as u64;
    let mut values = vec![
        f64::MIN_POSITIVE,
        f64::MAX,
        f64::MIN,
        5e-324,
        1.0 / 3.0,
        123456789.0,
        1e15,
        1e16,
        1e-4,
        1e-5,
    ];
    values.extend(
        (0..4000)
            .map(|_| f64::from_bits(bits()))
            .filter(|x| x.is_finite()),
    );
    values.extend((0..2000).map(|k| (k as f64 - 1000.0) / 24.0));
    for x in values {
        let text = number(x);
        assert_eq!(text.parse::<f64>().unwrap(), x, "{text}");
        assert!(text.contains('.') || text.contains('e'), "{text}");
        assert!(!text.starts_with("-0") || text.starts_with("-0."), "{text}");
    }
    assert_ne!(number(-0.0), "-0.0");
}

/// An edit for the property tests.
fn any_edit() -> impl Strategy<Value = (Mode, KeyEdit)> {
    let mode = prop::sample::select(Mode::ALL.to_vec());
    let t = prop_oneof![-3.0..5.0f64, Just(0.0), Just(1.0), Just(f64::NAN)];
    let value = prop::sample::select(vec![
        "-1.5",
        "(1.0, 2.0, 3.0)",
        "(0.1, 0.0)",
        "(",
        "1 // x",
        "",
    ]);
    let edit = prop_oneof![
        (t.clone(), value).prop_map(|(t, v)| KeyEdit::Set {
            t,
            value: v.to_string()
        }),
        (0..5usize, t).prop_map(|(index, t)| KeyEdit::Move { index, t }),
        (0..5usize).prop_map(|index| KeyEdit::Delete { index }),
    ];
    (mode, edit)
}

/// Pieces of RON's syntax, to build texts and mutations likely to reach deep into the scanner.
const PIECES: [&str; 30] = [
    "(", ")", "[", "]", "{", "}", ",", ":", " ", "\n", "\"", "'", "\\", "/*", "*/", "//", "r#\"",
    "\"#", "#!", "b'", "t", "keys", "animate", "value", "Observer", "Zoom", "1.0", "-", "é",
    "\u{feff}",
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 1500, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5911CE), failure_persistence: None, ..ProptestConfig::default() })]

    /// Any text at all: an answer, never a panic.
    #[test]
    fn any_text_is_answered(text in ".*", (mode, edit) in any_edit()) {
        let _ = edit_keys(&text, mode, &edit);
    }

    /// Texts of RON's pieces: an answer, never a panic.
    #[test]
    fn any_pieces_are_answered(pieces in prop::collection::vec(prop::sample::select(PIECES.to_vec()), 0..40), (mode, edit) in any_edit()) {
        let _ = edit_keys(&pieces.concat(), mode, &edit);
    }

    /// The example files with a piece cut out and others put in: an answer, never a panic;
    /// and where the result is still RON, a key set in it is RON's too.
    #[test]
    fn mutated_files_are_answered(
        file in 0..10usize,
        at in 0.0..1.0f64,
        cut in 0..20usize,
        put in prop::collection::vec(prop::sample::select(PIECES.to_vec()), 0..4),
        (mode, edit) in any_edit(),
    ) {
        thread_local!(static FILES: Vec<String> = files().into_iter().map(|f| f.1).collect());
        let text = FILES.with(|f| f[file % f.len()].clone());
        let boundary = |mut i: usize| { while !text.is_char_boundary(i) { i -= 1 } i };
        let start = boundary((at * text.len() as f64) as usize);
        let end = boundary((start + cut).min(text.len()));
        let mutated = format!("{}{}{}", &text[..start], put.concat(), &text[end..]);
        let _ = edit_keys(&mutated, mode, &edit);
        let (p, t) = (Path::new("mutated.ron"), (at * 8.0 - 2.0).round() / 4.0);
        let set = KeyEdit::Set { t, value: value(mode).to_string() };
        if let (Ok(_), Ok(after)) = (parse(p, &mutated), edit_keys(&mutated, mode, &set)) {
            let spec = parse(p, &after).map_err(|e| TestCaseError::fail(format!("{e}\n{after}")))?;
            let key = (t, value(mode).to_string());
            let keys = keys(&spec, mode).unwrap_or_default();
            prop_assert!(keys.iter().any(|k| (k.0, k.1.clone()) == key), "{keys:?}\n{after}");
        }
    }
}
