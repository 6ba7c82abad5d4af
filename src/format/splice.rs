//! Edits to one track's keys made in the keyframe file's text: the studio sets, moves and
//! deletes keys, and everything else in the file (comments, order, the way numbers are
//! written, blank lines) stays byte for byte as the user wrote it. Reading the file into a
//! [`super::FileSpec`] and writing it out again would lose all of that, so the edit is a splice:
//! one range of the text replaced. A small scanner reads RON's lexical structure (comments that
//! nest, strings, raw strings, chars) and its brackets, enough to find the pieces; RON itself
//! judges the result when the file is read.

use crate::mode::Mode;
use std::ops::Range;

/// One edit of one track's keys.
#[derive(Debug, Clone, PartialEq)]
pub enum KeyEdit {
    /// Sets the key at time `t` (seconds): a key whose `t` equals it (as f64) gets `value` as its
    /// value text (its `t` text and other fields are kept); otherwise a new key `(t: T, value: V)`
    /// is inserted in time order. A track the file lacks is added to `animate` (and `animate`
    /// itself to the file when it has none).
    Set { t: f64, value: String },
    /// Moves key `index` (0-based, in the file's order) to time `t`, keeping the keys in time
    /// order; its value text and other fields are kept.
    Move { index: usize, t: f64 },
    /// Deletes key `index`; deleting a track's only key removes the track from `animate`.
    Delete { index: usize },
}

/// Why an edit cannot be made. Lines are counted from 1, as an editor shows them.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpliceError {
    /// A comment, string or bracket the text never closes.
    #[error("line {line}: {what} is not closed")]
    Unclosed { line: usize, what: &'static str },
    /// A token where RON's grammar allows none like it.
    #[error("line {line}: `{found}` is not expected here")]
    Unexpected { line: usize, found: String },
    /// The text ends where a value should follow.
    #[error("the text ends where a value should follow")]
    EndsEarly,
    /// The text is not one struct `(…)` (perhaps named), the form of a keyframe file.
    #[error("the text is not a RON struct `(…)`")]
    NotAStruct,
    /// Brackets nested too deep to be a keyframe file (and to scan without a deep stack).
    #[error("line {line}: brackets nest deeper than {MAX_DEPTH}")]
    TooDeep { line: usize },
    /// A part of the file has the wrong shape for an edit.
    #[error("line {line}: {what}")]
    Malformed { line: usize, what: String },
    /// A field or track written twice: which one to edit is unclear.
    #[error("line {line}: {what} appears a second time (first on line {first})")]
    Twice {
        line: usize,
        first: usize,
        what: String,
    },
    /// A move or delete in a track the file does not have.
    #[error("the file has no {track} track")]
    NoTrack { track: &'static str },
    /// A key index past the track's end.
    #[error("the {track} track has no key {index}: it has {count}")]
    NoKey {
        track: &'static str,
        index: usize,
        count: usize,
    },
    /// A move onto the time of another key: two keys at one time.
    #[error("line {line}: the {track} track already has a key at t = {} s", number(*.t))]
    TimeTaken {
        line: usize,
        track: &'static str,
        t: f64,
    },
    /// A time that is not a finite number of seconds.
    #[error("t = {0} is not a finite time in seconds")]
    BadTime(f64),
    /// A value text that is not exactly one RON value (it would break the file's structure).
    #[error("`{0}` is not one RON value")]
    BadValue(String),
}

type Result<T> = std::result::Result<T, SpliceError>;

/// Nesting deeper than any keyframe file needs; the scanner recurses once per level.
const MAX_DEPTH: usize = 100;

/// The file's text with `edit` applied to `mode`'s track.
pub fn edit_keys(text: &str, mode: Mode, edit: &KeyEdit) -> Result<String> {
    // A byte-order mark is kept as it was, and is no part of what is scanned.
    let (bom, body) = match text.strip_prefix('\u{feff}') {
        Some(body) => ("\u{feff}", body),
        None => ("", text),
    };
    let root = Scan::new(body)?.root()?;
    let Splice(at, with) = plan(body, &root, mode, edit)?;
    Ok([bom, &body[..at.start], &with, &body[at.end..]].concat())
}

/// A number as the file writes it: the shortest text that reads back as the same f64, always
/// with a decimal point or exponent so RON reads it as a float ("2.0", "0.1", "-1.5", "1e-7"),
/// never "-0" (−0.0 is written "0.0"). Used for `t` and by callers for values.
/// Infinities and NaN, which have no such text, are written as RON reads them (`inf`, `NaN`).
pub fn number(x: f64) -> String {
    if x == 0.0 {
        return "0.0".to_string();
    }
    // Debug gives the shortest round-trip digits, with ".0" on whole numbers and an exponent
    // for very large and very small magnitudes.
    format!("{x:?}")
}

/// One replacement: the text in the range becomes the string.
#[derive(Debug)]
struct Splice(Range<usize>, String);

/// An error at byte `at` of `text`.
fn malformed(text: &str, at: usize, what: String) -> SpliceError {
    SpliceError::Malformed {
        line: line(text, at),
        what,
    }
}

/// A value: an atom (number, name, string) or a bracketed group, perhaps named (`Observer(…)`).
#[derive(Debug)]
struct Val {
    at: Range<usize>,
    name: Option<Range<usize>>,
    group: Option<Group>,
}

/// A bracketed group and its comma-separated items.
#[derive(Debug)]
struct Group {
    bracket: u8,
    open: usize,
    items: Vec<Item>,
}

/// One item of a group: `field: value` or a bare value, and the comma after it, if any.
#[derive(Debug)]
struct Item {
    field: Option<Range<usize>>,
    val: Val,
    comma: Option<usize>,
}

impl Item {
    fn start(&self) -> usize {
        self.field.as_ref().map_or(self.val.at.start, |f| f.start)
    }
    fn end(&self) -> usize {
        self.val.at.end
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Tok {
    Open(u8),
    Close(u8),
    Comma,
    Colon,
    Word,
    Str,
}

/// The tokens of a text and a cursor over them.
struct Scan<'a> {
    text: &'a str,
    toks: Vec<(Tok, Range<usize>)>,
    k: usize,
}

/// The 1-based line of byte `at`.
fn line(text: &str, at: usize) -> usize {
    text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&c| c == b'\n')
        .count()
        + 1
}

/// Bytes that end a word: white space, brackets, punctuation, quotes and the start of a comment.
fn ends_word(c: u8) -> bool {
    c.is_ascii_whitespace() || b"()[]{},:\"'/".contains(&c)
}

impl<'a> Scan<'a> {
    /// Splits `text` into tokens, passing over white space and comments.
    fn new(text: &'a str) -> Result<Self> {
        let s = text.as_bytes();
        let unclosed = |at: usize, what| SpliceError::Unclosed {
            line: line(text, at),
            what,
        };
        let (mut toks, mut i) = (Vec::new(), 0);
        while i < s.len() {
            let (c, start) = (s[i], i);
            let tok = match c {
                c if c.is_ascii_whitespace() => {
                    i += 1;
                    continue;
                }
                b'/' if s.get(i + 1) == Some(&b'/') => {
                    i = super::pieces::line_comment_end(s, i);
                    continue;
                }
                b'/' if s.get(i + 1) == Some(&b'*') => {
                    i = super::pieces::block_comment_end(s, i)
                        .ok_or_else(|| unclosed(i, "the block comment"))?;
                    continue;
                }
                b'(' | b'[' | b'{' => Tok::Open(c),
                b')' | b']' | b'}' => Tok::Close(c),
                b',' => Tok::Comma,
                b':' => Tok::Colon,
                b'"' | b'\'' => {
                    i = quoted(s, i).ok_or_else(|| unclosed(start, "the string"))?;
                    toks.push((Tok::Str, start..i));
                    continue;
                }
                b'/' => {
                    return Err(SpliceError::Unexpected {
                        line: line(text, i),
                        found: "/".to_string(),
                    })
                }
                _ => {
                    let prefix = s[i..].iter().take_while(|&&c| c == b'b' || c == b'r');
                    let at = i + prefix.count().min(2);
                    let (end, tok) = match (&s[i..at], s.get(at)) {
                        (b"r" | b"br", Some(b'"' | b'#')) if raw_start(s, at) => (
                            raw_end(s, at).ok_or_else(|| unclosed(start, "the raw string"))?,
                            Tok::Str,
                        ),
                        (b"b", Some(b'"' | b'\'')) => (
                            quoted(s, at).ok_or_else(|| unclosed(start, "the string"))?,
                            Tok::Str,
                        ),
                        // A name, a number, or a raw identifier `r#name`.
                        _ => {
                            let n = s[i..].iter().position(|&c| ends_word(c));
                            (n.map_or(s.len(), |n| i + n), Tok::Word)
                        }
                    };
                    i = end;
                    toks.push((tok, start..i));
                    continue;
                }
            };
            i += 1;
            toks.push((tok, start..i));
        }
        Ok(Scan { text, toks, k: 0 })
    }

    /// The kind of the token `ahead` of the cursor.
    fn peek_at(&self, ahead: usize) -> Option<Tok> {
        self.toks.get(self.k + ahead).map(|t| t.0)
    }

    fn peek(&self) -> Option<Tok> {
        self.peek_at(0)
    }

    fn here(&self) -> usize {
        self.toks.get(self.k).map_or(self.text.len(), |t| t.1.start)
    }

    fn unexpected(&self) -> SpliceError {
        match self.toks.get(self.k) {
            Some((_, at)) => SpliceError::Unexpected {
                line: line(self.text, at.start),
                found: self.text[at.clone()].chars().take(40).collect(),
            },
            None => SpliceError::EndsEarly,
        }
    }

    /// The whole text as the one struct of a keyframe file, after any `#![enable(…)]`.
    fn root(mut self) -> Result<Group> {
        while self.peek() == Some(Tok::Word) && &self.text[self.toks[self.k].1.clone()] == "#!" {
            self.k += 1;
            self.value(0)?;
        }
        if self.peek().is_none() {
            return Err(SpliceError::NotAStruct);
        }
        let root = self.value(0)?;
        if self.k < self.toks.len() {
            return Err(self.unexpected());
        }
        match root.group {
            Some(g) if g.bracket == b'(' => Ok(g),
            _ => Err(SpliceError::NotAStruct),
        }
    }

    /// The value at the cursor: a word or string, a group, or a word naming a `(…)` group.
    fn value(&mut self, depth: usize) -> Result<Val> {
        let (tok, at) = self
            .toks
            .get(self.k)
            .cloned()
            .ok_or_else(|| self.unexpected())?;
        match tok {
            Tok::Word if self.peek_at(1) == Some(Tok::Open(b'(')) => {
                self.k += 1;
                let mut val = self.value(depth)?;
                val.at.start = at.start;
                val.name = Some(at);
                Ok(val)
            }
            Tok::Word | Tok::Str => {
                self.k += 1;
                let (name, group) = (None, None);
                Ok(Val { at, name, group })
            }
            Tok::Open(bracket) => {
                if depth >= MAX_DEPTH {
                    return Err(SpliceError::TooDeep {
                        line: line(self.text, at.start),
                    });
                }
                self.k += 1;
                let mut items = Vec::new();
                loop {
                    match self.peek() {
                        Some(Tok::Close(c)) if c == closer(bracket) => break,
                        Some(Tok::Close(_)) => return Err(self.unexpected()),
                        None => {
                            return Err(SpliceError::Unclosed {
                                line: line(self.text, at.start),
                                what: "this bracket",
                            })
                        }
                        _ => {}
                    }
                    let field = match (self.peek(), self.peek_at(1)) {
                        (Some(Tok::Word | Tok::Str), Some(Tok::Colon)) => {
                            self.k += 2;
                            Some(self.toks[self.k - 2].1.clone())
                        }
                        _ => None,
                    };
                    let val = self.value(depth + 1)?;
                    let comma = (self.peek() == Some(Tok::Comma)).then(|| self.here());
                    match self.peek() {
                        Some(Tok::Comma) => self.k += 1,
                        Some(Tok::Close(_)) => {}
                        _ => return Err(self.unexpected()),
                    }
                    items.push(Item { field, val, comma });
                }
                let end = self.here() + 1;
                self.k += 1;
                Ok(Val {
                    at: at.start..end,
                    name: None,
                    group: Some(Group {
                        bracket,
                        open: at.start,
                        items,
                    }),
                })
            }
            _ => Err(self.unexpected()),
        }
    }
}

fn closer(open: u8) -> u8 {
    match open {
        b'(' => b')',
        b'[' => b']',
        _ => b'}',
    }
}

/// The byte after the string or char literal whose quote is at `i`.
fn quoted(s: &[u8], i: usize) -> Option<usize> {
    let mut j = i + 1;
    while j < s.len() {
        match s[j] {
            b'\\' => j += 2,
            c if c == s[i] => return Some(j + 1),
            _ => j += 1,
        }
    }
    None
}

/// Whether `#`s then `"` start at `at` (a raw string rather than a raw identifier `r#name`).
fn raw_start(s: &[u8], at: usize) -> bool {
    s[at..].iter().find(|&&c| c != b'#') == Some(&b'"')
}

/// The byte after the raw string whose hashes (or quote) start at `at`.
fn raw_end(s: &[u8], at: usize) -> Option<usize> {
    let hashes = s[at..].iter().take_while(|&&c| c == b'#').count();
    let body = at + hashes + 1;
    let mut close = vec![b'"'];
    close.resize(hashes + 1, b'#');
    let n = s
        .get(body..)?
        .windows(close.len())
        .position(|w| w == close)?;
    Some(body + n + close.len())
}

/// A key of the track as written.
struct Key {
    at: Range<usize>,
    t: f64,
    t_at: Range<usize>,
    value_at: Option<Range<usize>>,
}

/// The item of `group` whose field is `name`, if any; a field written twice is an error.
fn field<'g>(text: &str, group: &'g Group, name: &str) -> Result<Option<&'g Item>> {
    let mut found = group
        .items
        .iter()
        .filter(|it| it.field.as_ref().is_some_and(|f| &text[f.clone()] == name));
    let first = found.next();
    match (first, found.next()) {
        (Some(a), Some(b)) => Err(SpliceError::Twice {
            line: line(text, b.start()),
            first: line(text, a.start()),
            what: format!("the field `{name}`"),
        }),
        (first, _) => Ok(first),
    }
}

/// `val` as a `[…]` list, or an error saying what was expected.
fn list<'v>(text: &str, val: &'v Val, what: &str) -> Result<&'v Group> {
    match &val.group {
        Some(g) if g.bracket == b'[' && val.name.is_none() => Ok(g),
        _ => Err(malformed(
            text,
            val.at.start,
            format!("{what} are not a list"),
        )),
    }
}

/// The splice that makes the edit.
fn plan(text: &str, root: &Group, mode: Mode, edit: &KeyEdit) -> Result<Splice> {
    let track = mode.name();
    let set = match *edit {
        KeyEdit::Set { t, .. } | KeyEdit::Move { t, .. } if !t.is_finite() => {
            return Err(SpliceError::BadTime(t))
        }
        KeyEdit::Set { t, ref value } => Some((t, check_value(value)?)),
        KeyEdit::Move { .. } | KeyEdit::Delete { .. } => None,
    };
    let new_track = || {
        let (t, value) = set.ok_or(SpliceError::NoTrack { track })?;
        Ok(format!("{track}(keys: [{}])", key_text(t, value)))
    };
    let Some(animate) = field(text, root, "animate")? else {
        return Ok(add_field(
            text,
            root,
            &format!("animate: [{}]", new_track()?),
        ));
    };
    let tracks = list(text, &animate.val, "the tracks of `animate`")?;
    let named = |it: &&Item| {
        it.val
            .name
            .as_ref()
            .is_some_and(|n| &text[n.clone()] == track)
    };
    let mut mine = tracks.items.iter().enumerate().filter(|(_, it)| named(it));
    let (index_in_animate, entry) = match (mine.next(), mine.next()) {
        (Some((_, a)), Some((_, b))) => {
            return Err(SpliceError::Twice {
                line: line(text, b.start()),
                first: line(text, a.start()),
                what: format!("the {track} track"),
            })
        }
        (None, _) => return Ok(insert(text, tracks, tracks.items.len(), &new_track()?)),
        (Some(found), None) => found,
    };
    let malformed = |at: usize, what: String| malformed(text, at, what);
    let fields =
        entry.val.group.as_ref().ok_or_else(|| {
            malformed(entry.start(), format!("the {track} track is not a struct"))
        })?;
    let keys_item = field(text, fields, "keys")?
        .ok_or_else(|| malformed(entry.start(), format!("the {track} track has no `keys`")))?;
    let keys_list = list(text, &keys_item.val, &format!("the {track} track's keys"))?;
    let keys = keys_list
        .items
        .iter()
        .enumerate()
        .map(|(n, it)| key(text, it, n, &format!("the {track} track")))
        .collect::<Result<Vec<_>>>()?;
    // Where a key at time `t` belongs among `keys`: after every key not later than it.
    let slot = |keys: &[&Key], t: f64| keys.iter().position(|k| k.t > t).unwrap_or(keys.len());
    let no_key = |index| SpliceError::NoKey {
        track,
        index,
        count: keys.len(),
    };
    match *edit {
        KeyEdit::Set { t, ref value } => {
            let value = check_value(value)?;
            if let Some(k) = keys.iter().find(|k| k.t == t) {
                let at = k.value_at.clone().ok_or_else(|| {
                    malformed(
                        k.at.start,
                        format!("a key of the {track} track has no value"),
                    )
                })?;
                return Ok(Splice(at, value.to_string()));
            }
            let p = slot(&keys.iter().collect::<Vec<_>>(), t);
            Ok(insert(text, keys_list, p, &key_text(t, value)))
        }
        KeyEdit::Move { index, t } => {
            let moving = keys.get(index).ok_or_else(|| no_key(index))?;
            if let Some(k) = keys
                .iter()
                .enumerate()
                .find(|&(n, k)| n != index && k.t == t)
            {
                return Err(SpliceError::TimeTaken {
                    line: line(text, k.1.at.start),
                    track,
                    t,
                });
            }
            let moved = format!(
                "{}{}{}",
                &text[moving.at.start..moving.t_at.start],
                number(t),
                &text[moving.t_at.end..moving.at.end]
            );
            let mut others: Vec<&Key> = keys.iter().collect();
            others.remove(index);
            let p = slot(&others, t);
            let mut order: Vec<&str> = others.iter().map(|k| &text[k.at.clone()]).collect();
            order.insert(p, &moved);
            // The keys from the old place to the new take their new order; the separators
            // between them (and any comments there) stay where they are.
            let (lo, hi) = (index.min(p), index.max(p));
            let mut with = String::new();
            for n in lo..=hi {
                with.push_str(order[n]);
                if n < hi {
                    with.push_str(&text[keys[n].at.end..keys[n + 1].at.start]);
                }
            }
            Ok(Splice(keys[lo].at.start..keys[hi].at.end, with))
        }
        KeyEdit::Delete { index } if index >= keys.len() => Err(no_key(index)),
        KeyEdit::Delete { .. } if keys.len() == 1 => Ok(remove(text, tracks, index_in_animate)),
        KeyEdit::Delete { index } => Ok(remove(text, keys_list, index)),
    }
}

/// The `value` text trimmed, once it is known to be exactly one RON value, so that it cannot
/// close brackets of the file or comment out what follows it.
fn check_value(value: &str) -> Result<&str> {
    let v = value.trim();
    let bad = || SpliceError::BadValue(value.to_string());
    let mut scan = Scan::new(v).map_err(|_| bad())?;
    let val = scan.value(0).map_err(|_| bad())?;
    if scan.k < scan.toks.len() || val.at != (0..v.len()) {
        return Err(bad());
    }
    Ok(v)
}

/// The text of a new key.
fn key_text(t: f64, value: &str) -> String {
    format!("(t: {}, value: {value})", number(t))
}

/// Key `n` of `track` ("the Zoom track"): its span, its `t` and where its `t` and value are written.
fn key(text: &str, it: &Item, n: usize, track: &str) -> Result<Key> {
    let malformed = |what: &str| malformed(text, it.start(), format!("key {n} of {track} {what}"));
    let group = match &it.val.group {
        Some(g) if g.bracket == b'(' && it.field.is_none() => g,
        _ => return Err(malformed("is not a struct (t: …, value: …)")),
    };
    let t = field(text, group, "t")?.ok_or_else(|| malformed("has no t"))?;
    let t_at = t.val.at.clone();
    let time = (t.val.group.is_none() && t.val.name.is_none())
        .then(|| text[t_at.clone()].replace('_', "").parse::<f64>().ok())
        .flatten()
        .ok_or_else(|| malformed("has a t that is not a number"))?;
    Ok(Key {
        at: it.start()..it.end(),
        t: time,
        t_at,
        value_at: field(text, group, "value")?.map(|v| v.val.at.clone()),
    })
}

/// The separator between items of `list` in the style it already uses: the first one that is
/// only a comma and white space, else a newline and the first item's indentation when the list
/// starts on a line of its own, else ", ".
fn separator(text: &str, list: &Group) -> String {
    let items = &list.items;
    for pair in items.windows(2) {
        let gap = &text[pair[0].end()..pair[1].start()];
        if gap.trim() == "," {
            return gap.to_string();
        }
    }
    let lead = &text[list.open + 1..items.first().map_or(list.open + 1, Item::start)];
    match lead.rfind('\n') {
        Some(n) if lead[n..].trim().is_empty() => format!(",{}", &lead[n..]),
        _ => ", ".to_string(),
    }
}

/// The splice that makes `item` the `p`th item of `list`.
fn insert(text: &str, list: &Group, p: usize, item: &str) -> Splice {
    let at = |i: usize, with: String| Splice(i..i, with);
    let Some(last) = list.items.last() else {
        return at(list.open + 1, item.to_string());
    };
    let sep = separator(text, list);
    match list.items.get(p) {
        Some(next) => at(next.start(), format!("{item}{sep}")),
        None => at(last.end(), format!("{sep}{item}")),
    }
}

/// The start of the white space that ends `text[..i]`.
fn blank_before(text: &str, i: usize) -> usize {
    text[..i]
        .trim_end_matches(|c: char| c.is_ascii_whitespace())
        .len()
}

/// `start..end` widened to its whole line (with its newline) when nothing else is on it.
fn widen(text: &str, start: usize, end: usize) -> Range<usize> {
    let line_start = text[..start].rfind('\n').map_or(0, |n| n + 1);
    match text[end..].find('\n') {
        Some(n)
            if text[line_start..start].trim().is_empty()
                && text[end..end + n].trim().is_empty() =>
        {
            line_start..end + n + 1
        }
        _ => start..end,
    }
}

/// The splice that removes item `i` of `list` and one separator; comments outside the item
/// and its separator stay.
fn remove(text: &str, list: &Group, i: usize) -> Splice {
    let items = &list.items;
    let it = &items[i];
    let gone = |at: Range<usize>| Splice(at, String::new());
    match (i.checked_sub(1).map(|p| &items[p]), items.get(i + 1)) {
        // The only item: it and its trailing comma, and its line when it had one to itself.
        (None, None) => gone(widen(
            text,
            it.start(),
            it.comma.map_or(it.end(), |c| c + 1),
        )),
        // An item followed by another: it, its comma, and the white space up to what follows.
        (_, Some(_)) => {
            let after = it.comma.map_or(it.end(), |c| c + 1);
            let rest = &text[after..];
            let blank = rest.len()
                - rest
                    .trim_start_matches(|c: char| c.is_ascii_whitespace())
                    .len();
            gone(it.start()..after + blank)
        }
        // The last of several: it and the comma before it...
        (Some(prev), None) => {
            let Some(c) = prev.comma else {
                return gone(it.start()..it.end());
            };
            if text[c + 1..it.start()].trim().is_empty() {
                return gone(blank_before(text, c)..it.end());
            }
            // ...but comments between the two stay: the item's own trailing comma goes instead
            // when it has one, else the comma before it, outside the comments.
            match it.comma {
                Some(own) => gone(widen(text, it.start(), own + 1)),
                None => {
                    let drop = widen(text, it.start(), it.end());
                    Splice(
                        blank_before(text, c)..drop.end,
                        text[c + 1..drop.start].to_string(),
                    )
                }
            }
        }
    }
}

/// The splice that adds `field` (`name: value`) to the top-level struct after its last field,
/// with that field's indentation, keeping the struct's trailing comma or its absence.
fn add_field(text: &str, root: &Group, field: &str) -> Splice {
    let at = |i: usize, with: String| Splice(i..i, with);
    let Some(last) = root.items.last() else {
        return at(root.open + 1, field.to_string());
    };
    let indent = &text[blank_before(text, last.start())..last.start()];
    let indent = if indent.is_empty() { " " } else { indent };
    match last.comma {
        Some(c) => at(c + 1, format!("{indent}{field},")),
        None => at(last.end(), format!(",{indent}{field}")),
    }
}

#[cfg(test)]
mod tests;
