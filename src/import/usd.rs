//! OpenUSD's text form (`.usda`): a time-sampled `Camera` under its transforms.
//!
//! **Why a reader of our own.** The one pure-Rust USD library on crates.io, `openusd`, reads
//! USDA, but its current release (0.8) needs Rust 1.96, past campath's 1.89 (and the toolchain
//! here), and its releases before break their API from one minor version to the next; the
//! other `usd*` crates bind Pixar's C++ library, which is a large build of its own. A camera
//! needs little of the format: the layer's metadata, prims and their attributes, default values
//! and time samples. This file reads that much of USDA 1.0 and says what it does not read.
//!
//! - **Layer.** `upAxis` ("Y", the default, or "Z"), `timeCodesPerSecond` (24 unless given, or
//!   `framesPerSecond` when only that is given, as OpenUSD falls back), `framesPerSecond` (the
//!   source's rate), `startTimeCode` (time 0), and campath's `customLayerData` `imageWidth` and
//!   `imageHeight` (the image size) and `origin` (where the file's origin lies in campath's
//!   world, `campath path --origin`, added back). `metersPerUnit` changes no picture. A sample at time code c
//!   is at (c − startTimeCode) / timeCodesPerSecond seconds, so that campath's own export, whose
//!   frame k is time code k + N with `startTimeCode` N, gives frame 0 at time 0.
//! - **Prims.** `def`, `over` and `class` prims of any type, nested, with metadata in
//!   parentheses; comments, strings (also triple-quoted), asset paths and variant sets are read
//!   over. The cameras are the defined `Camera` prims (a `def` under `def`s, not `active =
//!   false`). Composition arcs (`subLayers`, `references`, `payload`, `inherits`, `specializes`)
//!   are not followed: a camera that has one on its path is refused with OpenUSD's `usdcat
//!   --flatten`, which writes the composed stage as one layer. Binary files (`.usdc`, or `.usd`
//!   in the crate form) are refused with `usdcat file.usdc -o file.usda`.
//! - **Transforms.** On the camera and each ancestor, `xformOpOrder` names the ops, the first the
//!   outermost: `translate`, `scale` (also `translateX`.. and `scaleX`..), `rotateX`, `rotateY`,
//!   `rotateZ`, the six `rotateXYZ`.. orders (degrees; `rotateXYZ` turns about X first), `orient`
//!   (a quaternion (w, x, y, z)), `transform` (a `matrix4d` as USD writes it: row vectors,
//!   the translation in the last row), each with an optional `:suffix` and `!invert!`, and
//!   `!resetXformStack!` (the prim ignores its ancestors'). The world transform is the product
//!   from the root down.
//! - **Lens.** `focalLength`, `horizontalAperture`, `verticalAperture`,
//!   `horizontalApertureOffset`, `verticalApertureOffset` (USD's fallbacks 50, 20.955, 15.2908,
//!   0, 0): the window is the apertures over the focal length and the shift the offsets over it
//!   (their unit cancels). An orthographic `projection` is refused.
//! - **Time.** An attribute with time samples takes them (its default only without); between
//!   samples OpenUSD's linear interpolation (component by component, matrices too; quaternions
//!   by slerp), before the first and after the last the end's value. The samples read are at
//!   every time code at which any of these attributes is sampled; a camera that nothing
//!   animates is one sample at time 0. A blocked sample (`None`) is refused.

use std::collections::BTreeSet;

use glam::{DMat4, DQuat, DVec2, DVec3};

use super::{Sample, Source, Up};

/// The deepest nesting of prims and values read: deeper is refused rather than overflowing the
/// stack on a hostile file.
const MAX_DEPTH: usize = 200;

/// USD's fallback lens (`UsdGeomCamera`): 50 mm on a 35 mm film gate's projector aperture.
const FALLBACK_LENS: [(&str, f64); 5] = [
    ("focalLength", 50.0),
    ("horizontalAperture", 20.955),
    ("verticalAperture", 15.2908),
    ("horizontalApertureOffset", 0.0),
    ("verticalApertureOffset", 0.0),
];

/// A token of USDA and the line it starts on.
#[derive(Debug, Clone, PartialEq)]
enum Token {
    /// One of `( ) [ ] { } = , : ;`.
    Punct(char),
    Str(String),
    Num(f64),
    /// An identifier, keyword or type: letters, digits, `_`, `:` and `.`, and a type's `[]`.
    Word(String),
    /// `</a/b>`.
    Path(String),
    /// `@file.usda@`.
    Asset(String),
}

impl std::fmt::Display for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Token::Punct(c) => write!(f, "'{c}'"),
            Token::Str(s) => write!(f, "the string {s:?}"),
            Token::Num(x) => write!(f, "the number {x}"),
            Token::Word(w) => write!(f, "{w:?}"),
            Token::Path(p) => write!(f, "the path <{p}>"),
            Token::Asset(a) => write!(f, "the asset @{a}@"),
        }
    }
}

/// The tokens of `text` (past its `#usda` line), each with its line number.
fn tokens(text: &str) -> Result<Vec<(Token, usize)>, String> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    let word_char = |c: char| c.is_alphanumeric() || matches!(c, '_' | ':' | '.');
    while i < chars.len() {
        let c = chars[i];
        let start_line = line;
        match c {
            '\n' => {
                line += 1;
                i += 1;
            }
            c if c.is_whitespace() => i += 1,
            '#' => {
                while i < chars.len() && chars[i] != '\n' {
                    i += 1;
                }
            }
            '(' | ')' | '[' | ']' | '{' | '}' | '=' | ',' | ':' | ';' => {
                out.push((Token::Punct(c), line));
                i += 1;
            }
            '"' | '\'' => {
                let triple = chars.get(i..i + 3) == Some(&[c, c, c][..]);
                i += if triple { 3 } else { 1 };
                let mut s = String::new();
                loop {
                    let Some(&d) = chars.get(i) else {
                        return Err(format!("line {start_line}: a string that does not end"));
                    };
                    if triple && chars.get(i..i + 3) == Some(&[c, c, c][..]) {
                        i += 3;
                        break;
                    }
                    if !triple && d == c {
                        i += 1;
                        break;
                    }
                    if !triple && d == '\n' {
                        return Err(format!("line {start_line}: a string that does not end"));
                    }
                    if d == '\n' {
                        line += 1;
                    }
                    if d == '\\' {
                        let e = *chars.get(i + 1).ok_or_else(|| {
                            format!("line {start_line}: a string that does not end")
                        })?;
                        s.push(match e {
                            'n' => '\n',
                            't' => '\t',
                            'r' => '\r',
                            e => e,
                        });
                        i += 2;
                    } else {
                        s.push(d);
                        i += 1;
                    }
                }
                out.push((Token::Str(s), start_line));
            }
            '@' => {
                let fence = if chars.get(i..i + 3) == Some(&['@', '@', '@'][..]) {
                    3
                } else {
                    1
                };
                let from = i + fence;
                let mut j = from;
                while j + fence <= chars.len() && chars[j..j + fence].iter().any(|&d| d != '@') {
                    j += 1;
                }
                if j + fence > chars.len() {
                    return Err(format!("line {line}: an asset path that does not end"));
                }
                out.push((Token::Asset(chars[from..j].iter().collect()), line));
                i = j + fence;
            }
            '<' => {
                let end = (i..chars.len())
                    .find(|&j| chars[j] == '>')
                    .ok_or_else(|| format!("line {line}: a path that does not end ('>')"))?;
                out.push((Token::Path(chars[i + 1..end].iter().collect()), line));
                i = end + 1;
            }
            c if c.is_ascii_digit() || matches!(c, '-' | '+' | '.') => {
                let mut j = i + 1;
                while j < chars.len()
                    && (chars[j].is_ascii_alphanumeric() || matches!(chars[j], '.' | '-' | '+'))
                {
                    j += 1;
                }
                let s: String = chars[i..j].iter().collect();
                let x: f64 = s
                    .parse()
                    .map_err(|_| format!("line {line}: {s:?} is not a number"))?;
                out.push((Token::Num(x), line));
                i = j;
            }
            c if c.is_alphabetic() || c == '_' => {
                let mut j = i + 1;
                while j < chars.len() && word_char(chars[j]) {
                    j += 1;
                }
                // A type's array brackets belong to it: `token[]`.
                if chars.get(j..j + 2) == Some(&['[', ']'][..]) {
                    j += 2;
                }
                let w: String = chars[i..j].iter().collect();
                let token = match w.as_str() {
                    "inf" => Token::Num(f64::INFINITY),
                    "nan" => Token::Num(f64::NAN),
                    _ => Token::Word(w),
                };
                out.push((token, line));
                i = j;
            }
            c => return Err(format!("line {line}: unexpected character {c:?}")),
        }
    }
    Ok(out)
}

/// A value as written: numbers, strings, tuples `( )`, lists `[ ]` and dictionaries `{ }`.
#[derive(Debug, Clone, PartialEq)]
enum Value {
    Num(f64),
    Str(String),
    Word(String),
    Tuple(Vec<Value>),
    List(Vec<Value>),
    Dict(Vec<(String, Value)>),
    Path(String),
}

impl Value {
    /// The numbers in it, tuples flattened in order (a `matrix4d`'s rows one after the other).
    fn numbers(&self, out: &mut Vec<f64>) -> bool {
        match self {
            Value::Num(x) => {
                out.push(*x);
                true
            }
            Value::Tuple(items) => items.iter().all(|v| v.numbers(out)),
            _ => false,
        }
    }

    fn entry(&self, key: &str) -> Option<&Value> {
        match self {
            Value::Dict(entries) => entries.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }
}

/// A prim's specifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Specifier {
    Def,
    Over,
    Class,
}

/// An attribute: its default and its time samples (time code, value; `None` a blocked one).
#[derive(Debug, Default)]
struct Attribute {
    line: usize,
    default: Option<Value>,
    samples: Vec<(f64, Option<Value>)>,
}

#[derive(Debug)]
struct Prim {
    specifier: Specifier,
    type_name: String,
    name: String,
    metadata: Vec<(String, Value)>,
    attributes: Vec<(String, Attribute)>,
    children: Vec<Prim>,
}

impl Prim {
    fn attribute(&self, name: &str) -> Option<&Attribute> {
        self.attributes
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, a)| a)
    }

    fn metadata(&self, key: &str) -> Option<&Value> {
        self.metadata.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }
}

/// The layer: its metadata and root prims.
struct Layer {
    metadata: Vec<(String, Value)>,
    prims: Vec<Prim>,
}

/// A reader over the tokens.
struct Parser {
    tokens: Vec<(Token, usize)>,
    at: usize,
    depth: usize,
}

impl Parser {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.at).map(|(t, _)| t)
    }

    fn line(&self) -> usize {
        self.tokens
            .get(self.at)
            .or(self.tokens.last())
            .map_or(1, |(_, l)| *l)
    }

    fn next(&mut self, what: &str) -> Result<Token, String> {
        let token = self.tokens.get(self.at).map(|(t, _)| t.clone());
        match token {
            Some(t) => {
                self.at += 1;
                Ok(t)
            }
            None => Err(format!(
                "line {}: the file ends where {what} should be",
                self.line()
            )),
        }
    }

    fn unexpected<T>(&self, found: &Token, what: &str) -> Result<T, String> {
        // `next` has moved past the token: its line is the one before.
        let line = self.tokens[self.at.saturating_sub(1)].1;
        Err(format!("line {line}: expected {what}, found {found}"))
    }

    fn punct(&mut self, c: char) -> Result<(), String> {
        match self.next(&format!("'{c}'"))? {
            Token::Punct(d) if d == c => Ok(()),
            t => self.unexpected(&t, &format!("'{c}'")),
        }
    }

    fn is_punct(&self, c: char) -> bool {
        self.peek() == Some(&Token::Punct(c))
    }

    fn word(&mut self, what: &str) -> Result<String, String> {
        match self.next(what)? {
            Token::Word(w) => Ok(w),
            t => self.unexpected(&t, what),
        }
    }

    fn deeper(&mut self) -> Result<(), String> {
        self.depth += 1;
        match self.depth > MAX_DEPTH {
            true => Err(format!(
                "line {}: nested more than {MAX_DEPTH} deep",
                self.line()
            )),
            false => Ok(()),
        }
    }

    fn value(&mut self) -> Result<Value, String> {
        self.deeper()?;
        let value = match self.next("a value")? {
            Token::Num(x) => Value::Num(x),
            Token::Str(s) => Value::Str(s),
            Token::Word(w) => Value::Word(w),
            Token::Path(p) => Value::Path(p),
            // A reference's asset and its prim path, `@a.usda@</x>`, are one value.
            Token::Asset(a) => {
                if let Some(Token::Path(_)) = self.peek() {
                    self.at += 1;
                }
                Value::Str(a)
            }
            Token::Punct('(') => Value::Tuple(self.items(')')?),
            Token::Punct('[') => Value::List(self.items(']')?),
            Token::Punct('{') => Value::Dict(self.dict()?),
            t => return self.unexpected(&t, "a value"),
        };
        self.depth -= 1;
        Ok(value)
    }

    /// Values separated by commas up to `close` (a trailing comma allowed); an item's metadata
    /// (a reference's layer offset) is read over.
    fn items(&mut self, close: char) -> Result<Vec<Value>, String> {
        let mut items = Vec::new();
        loop {
            if self.is_punct(close) {
                self.at += 1;
                return Ok(items);
            }
            items.push(self.value()?);
            if self.is_punct('(') {
                self.metadata()?;
            }
            match self.next(&format!("',' or '{close}'"))? {
                Token::Punct(',') => {}
                Token::Punct(c) if c == close => return Ok(items),
                t => return self.unexpected(&t, &format!("',' or '{close}'")),
            }
        }
    }

    /// A dictionary's entries, `type name = value`, up to `}`.
    fn dict(&mut self) -> Result<Vec<(String, Value)>, String> {
        let mut entries = Vec::new();
        loop {
            match self.next("a dictionary entry or '}'")? {
                Token::Punct('}') => return Ok(entries),
                Token::Punct(';' | ',') => {}
                Token::Word(_) => {
                    let key = match self.next("an entry's name")? {
                        Token::Word(w) | Token::Str(w) => w,
                        t => return self.unexpected(&t, "an entry's name"),
                    };
                    self.punct('=')?;
                    entries.push((key, self.value()?));
                }
                t => return self.unexpected(&t, "a dictionary entry (type name = value)"),
            }
        }
    }

    /// Metadata in parentheses: `key = value` entries (a list edit's `prepend` and the like
    /// before the key), and a bare string, the documentation.
    fn metadata(&mut self) -> Result<Vec<(String, Value)>, String> {
        self.punct('(')?;
        let mut entries = Vec::new();
        loop {
            match self.next("metadata or ')'")? {
                Token::Punct(')') => return Ok(entries),
                Token::Punct(';') => {}
                Token::Str(doc) => entries.push(("doc".into(), Value::Str(doc))),
                Token::Word(w) => {
                    let key = match w.as_str() {
                        "prepend" | "append" | "add" | "delete" | "reorder" => {
                            self.word("a metadata name")?
                        }
                        _ => w,
                    };
                    self.punct('=')?;
                    entries.push((key, self.value()?));
                }
                t => return self.unexpected(&t, "metadata (name = value)"),
            }
        }
    }

    fn layer(&mut self) -> Result<Layer, String> {
        let metadata = match self.is_punct('(') {
            true => self.metadata()?,
            false => Vec::new(),
        };
        let mut prims = Vec::new();
        while let Some(token) = self.peek() {
            match token {
                Token::Word(w) if matches!(w.as_str(), "def" | "over" | "class") => {
                    prims.push(self.prim()?)
                }
                t => {
                    let t = t.clone();
                    self.at += 1;
                    return self.unexpected(&t, "a prim (def, over or class)");
                }
            }
        }
        Ok(Layer { metadata, prims })
    }

    /// `def Type "name" (metadata) { properties and children }`.
    fn prim(&mut self) -> Result<Prim, String> {
        self.deeper()?;
        let specifier = match self.word("def, over or class")?.as_str() {
            "def" => Specifier::Def,
            "over" => Specifier::Over,
            _ => Specifier::Class,
        };
        let (type_name, name) = match self.next("a prim's type or name")? {
            Token::Word(t) => match self.next("a prim's name")? {
                Token::Str(n) => (t, n),
                t => return self.unexpected(&t, "a prim's name (a string)"),
            },
            Token::Str(n) => (String::new(), n),
            t => return self.unexpected(&t, "a prim's type or name"),
        };
        let metadata = match self.is_punct('(') {
            true => self.metadata()?,
            false => Vec::new(),
        };
        self.punct('{')?;
        let mut prim = Prim {
            specifier,
            type_name,
            name,
            metadata,
            attributes: Vec::new(),
            children: Vec::new(),
        };
        loop {
            let line = self.line();
            match self.next("a property, a prim or '}'")? {
                Token::Punct('}') => break,
                Token::Punct(';') => {}
                Token::Word(w) if matches!(w.as_str(), "def" | "over" | "class") => {
                    self.at -= 1;
                    prim.children.push(self.prim()?);
                }
                Token::Word(w) if w == "variantSet" => {
                    // `variantSet "name" = { "variant" (metadata) { ... } ... }`: not composed.
                    self.next("a variant set's name")?;
                    self.punct('=')?;
                    self.skip_braces()?;
                }
                Token::Word(w) if w == "reorder" => {
                    self.word("nameChildren or properties")?;
                    self.punct('=')?;
                    self.value()?;
                }
                Token::Word(w) => self.property(&mut prim, w, line)?,
                t => return self.unexpected(&t, "a property, a prim or '}'"),
            }
        }
        self.depth -= 1;
        Ok(prim)
    }

    /// Reads over `{ ... }`, braces nested inside included.
    fn skip_braces(&mut self) -> Result<(), String> {
        self.punct('{')?;
        let mut open = 1;
        while open > 0 {
            match self.next("'}'")? {
                Token::Punct('{') => open += 1,
                Token::Punct('}') => open -= 1,
                _ => {}
            }
        }
        Ok(())
    }

    /// A property after its first word: `[custom] [uniform] type name[.timeSamples] [= value]
    /// [(metadata)]`, or `rel name [= targets]`.
    fn property(&mut self, prim: &mut Prim, first: String, line: usize) -> Result<(), String> {
        let mut word = first;
        while matches!(
            word.as_str(),
            "custom" | "uniform" | "varying" | "config" | "prepend" | "append" | "add" | "delete"
        ) {
            word = self.word("a property's type")?;
        }
        let relationship = word == "rel";
        let name = self.word("a property's name")?;
        let (name, field) = match name.rsplit_once('.') {
            Some((n, f)) if matches!(f, "timeSamples" | "connect" | "spline") => (n.to_string(), f),
            _ => (name, ""),
        };
        let index = match prim.attributes.iter().position(|(n, _)| *n == name) {
            Some(i) => i,
            None => {
                prim.attributes.push((name.clone(), Attribute::default()));
                prim.attributes.len() - 1
            }
        };
        if self.is_punct('=') {
            self.at += 1;
            match field {
                "timeSamples" => {
                    let samples = self.time_samples()?;
                    prim.attributes[index].1.samples = samples;
                }
                "spline" => {
                    return Err(format!(
                        "line {line}: {name} is a spline, which campath does not read: write \
                         it as time samples"
                    ))
                }
                _ => {
                    let value = self.value()?;
                    if field.is_empty() && !relationship {
                        prim.attributes[index].1.default = Some(value);
                    }
                }
            }
        }
        prim.attributes[index].1.line = line;
        if self.is_punct('(') {
            self.metadata()?;
        }
        Ok(())
    }

    /// `{ code: value, ... }`, sorted by time code.
    fn time_samples(&mut self) -> Result<Vec<(f64, Option<Value>)>, String> {
        self.punct('{')?;
        let mut samples = Vec::new();
        loop {
            match self.next("a time code or '}'")? {
                Token::Punct('}') => break,
                Token::Punct(',') => {}
                Token::Num(code) if code.is_finite() => {
                    self.punct(':')?;
                    let value = self.value()?;
                    let blocked = value == Value::Word("None".into());
                    samples.push((code, (!blocked).then_some(value)));
                }
                t => return self.unexpected(&t, "a time code (a number) or '}'"),
            }
        }
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(samples)
    }
}

/// How a value interpolates between two samples.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Blend {
    /// Component by component.
    Linear,
    /// A quaternion (w, x, y, z), by slerp.
    Slerp,
}

/// An attribute's numbers at `code`, `width` of them, or `None` where it has no value (a
/// declared attribute with neither default nor samples).
fn evaluate(
    name: &str,
    attr: &Attribute,
    code: f64,
    width: usize,
    blend: Blend,
) -> Result<Option<Vec<f64>>, String> {
    let numbers = |value: &Value, at: String| -> Result<Vec<f64>, String> {
        let mut out = Vec::with_capacity(width);
        match value.numbers(&mut out) && out.len() == width {
            true => Ok(out),
            false => Err(format!(
                "line {}: {name}{at} is not {width} number{}",
                attr.line,
                if width == 1 { "" } else { "s" }
            )),
        }
    };
    let sample = |k: usize| -> Result<Vec<f64>, String> {
        let (c, value) = &attr.samples[k];
        let at = format!(" at time code {c}");
        match value {
            Some(v) => numbers(v, at),
            None => Err(format!(
                "line {}: {name}{at} is blocked (None), which campath does not read",
                attr.line
            )),
        }
    };
    let samples = &attr.samples;
    if samples.is_empty() {
        return match &attr.default {
            Some(v) => numbers(v, String::new()).map(Some),
            None => Ok(None),
        };
    }
    // The last sample at or before `code`; held before the first and after the last.
    let after = samples.partition_point(|(c, _)| *c <= code);
    if after == 0 {
        return sample(0).map(Some);
    }
    let (c0, before) = (samples[after - 1].0, sample(after - 1)?);
    if after == samples.len() || c0 == code {
        return Ok(Some(before));
    }
    let (c1, next) = (samples[after].0, sample(after)?);
    let t = (code - c0) / (c1 - c0);
    Ok(Some(match blend {
        Blend::Linear => before
            .iter()
            .zip(&next)
            .map(|(a, b)| a + (b - a) * t)
            .collect(),
        Blend::Slerp => {
            let q = |v: &[f64]| DQuat::from_xyzw(v[1], v[2], v[3], v[0]);
            let r = q(&before).normalize().slerp(q(&next).normalize(), t);
            vec![r.w, r.x, r.y, r.z]
        }
    }))
}

/// An xform op's kind: the numbers it takes, how they blend, and its matrix (column vectors).
fn op_matrix(kind: &str, v: &[f64]) -> Option<DMat4> {
    let axis = |a: char, degrees: f64| {
        let r = degrees.to_radians();
        match a {
            'X' => DMat4::from_rotation_x(r),
            'Y' => DMat4::from_rotation_y(r),
            _ => DMat4::from_rotation_z(r),
        }
    };
    Some(match kind {
        "translate" => DMat4::from_translation(DVec3::new(v[0], v[1], v[2])),
        "translateX" => DMat4::from_translation(DVec3::X * v[0]),
        "translateY" => DMat4::from_translation(DVec3::Y * v[0]),
        "translateZ" => DMat4::from_translation(DVec3::Z * v[0]),
        "scale" => DMat4::from_scale(DVec3::new(v[0], v[1], v[2])),
        "scaleX" => DMat4::from_scale(DVec3::new(v[0], 1.0, 1.0)),
        "scaleY" => DMat4::from_scale(DVec3::new(1.0, v[0], 1.0)),
        "scaleZ" => DMat4::from_scale(DVec3::new(1.0, 1.0, v[0])),
        "rotateX" | "rotateY" | "rotateZ" => axis(kind.chars().nth(6)?, v[0]),
        "orient" => {
            let q = DQuat::from_xyzw(v[1], v[2], v[3], v[0]);
            let length = q.length();
            if !(length > 0.0 && length.is_finite()) {
                return None;
            }
            DMat4::from_quat(q / length)
        }
        // Row vectors in the file: its rows are the columns here.
        "transform" => DMat4::from_cols_array(v.try_into().ok()?),
        _ => {
            // rotateXYZ and the other orders: the first letter's axis turns first, so it
            // stands rightmost. The angles are (x, y, z) whatever the order.
            let order = kind.strip_prefix("rotate")?;
            let mut m = DMat4::IDENTITY;
            for a in order.chars() {
                let degrees = v["XYZ".find(a)?];
                m = axis(a, degrees) * m;
            }
            m
        }
    })
}

/// The numbers an op's kind takes and how they blend, or `None` for a kind that is no op.
fn op_shape(kind: &str) -> Option<(usize, Blend)> {
    Some(match kind {
        "translate" | "scale" => (3, Blend::Linear),
        "translateX" | "translateY" | "translateZ" | "scaleX" | "scaleY" | "scaleZ" | "rotateX"
        | "rotateY" | "rotateZ" => (1, Blend::Linear),
        "orient" => (4, Blend::Slerp),
        "transform" => (16, Blend::Linear),
        k => {
            let order = k.strip_prefix("rotate")?;
            let mut letters: Vec<char> = order.chars().collect();
            letters.sort_unstable();
            match letters == ['X', 'Y', 'Z'] {
                true => (3, Blend::Linear),
                false => return None,
            }
        }
    })
}

/// One op of a prim's `xformOpOrder`.
struct Op<'a> {
    name: &'a str,
    kind: &'a str,
    attr: &'a Attribute,
    invert: bool,
}

/// A prim's ops, outermost first, and whether it resets its ancestors' transform.
fn ops<'a>(prim: &'a Prim, path: &str) -> Result<(bool, Vec<Op<'a>>), String> {
    let Some(order) = prim.attribute("xformOpOrder") else {
        return Ok((false, Vec::new()));
    };
    let names: Vec<&str> = match &order.default {
        None => Vec::new(),
        Some(Value::List(items)) => items
            .iter()
            .map(|v| match v {
                Value::Str(s) | Value::Word(s) => Ok(s.as_str()),
                _ => Err(format!(
                    "line {}: {path}'s xformOpOrder is not a list of names",
                    order.line
                )),
            })
            .collect::<Result<_, _>>()?,
        Some(_) => {
            return Err(format!(
                "line {}: {path}'s xformOpOrder is not a list",
                order.line
            ))
        }
    };
    let mut reset = false;
    let mut out = Vec::new();
    for (i, &full) in names.iter().enumerate() {
        if full == "!resetXformStack!" {
            if i > 0 {
                return Err(format!(
                    "line {}: {path}'s !resetXformStack! is not first in xformOpOrder",
                    order.line
                ));
            }
            reset = true;
            continue;
        }
        let (invert, name) = match full.strip_prefix("!invert!") {
            Some(n) => (true, n),
            None => (false, full),
        };
        let kind = name
            .strip_prefix("xformOp:")
            .map(|k| k.split(':').next().unwrap_or(k))
            .filter(|k| op_shape(k).is_some())
            .ok_or_else(|| {
                format!(
                    "line {}: {path}'s xformOpOrder names {full:?}, which is no transform op \
                     campath reads",
                    order.line
                )
            })?;
        let attr = prim.attribute(name).ok_or_else(|| {
            format!(
                "line {}: {path}'s xformOpOrder names {name:?}, which the prim does not have",
                order.line
            )
        })?;
        out.push(Op {
            name,
            kind,
            attr,
            invert,
        });
    }
    Ok((reset, out))
}

/// The camera's chain of prims from the root, and its path.
struct Found<'a> {
    path: String,
    chain: Vec<&'a Prim>,
}

/// Every defined, active `Camera` prim under `prims`.
fn cameras<'a>(prims: &'a [Prim], parent: &str, chain: &[&'a Prim], out: &mut Vec<Found<'a>>) {
    for prim in prims {
        let active = prim.metadata("active") != Some(&Value::Word("false".into()));
        if prim.specifier != Specifier::Def || !active {
            continue;
        }
        let path = format!("{parent}/{}", prim.name);
        let mut chain = chain.to_vec();
        chain.push(prim);
        if prim.type_name == "Camera" {
            out.push(Found {
                path: path.clone(),
                chain: chain.clone(),
            });
        }
        cameras(&prim.children, &path, &chain, out);
    }
}

/// A layer metadatum as a number.
fn number(layer: &Layer, key: &str) -> Result<Option<f64>, String> {
    match layer.metadata.iter().find(|(k, _)| k == key) {
        None => Ok(None),
        Some((_, Value::Num(x))) if x.is_finite() => Ok(Some(*x)),
        Some((_, v)) => Err(format!("the layer's {key} is {v:?}, not a number")),
    }
}

/// The camera of a USDA stage.
pub fn read(bytes: &[u8], camera: Option<&str>) -> Result<Source, String> {
    if bytes.starts_with(b"PXR-USDC") || bytes.starts_with(b"PK\x03\x04") {
        return Err(
            "a binary USD file (crate or usdz), which campath does not read: convert it \
                    to the text form with OpenUSD's `usdcat file.usdc -o file.usda`"
                .into(),
        );
    }
    let text = std::str::from_utf8(bytes).map_err(|e| format!("not UTF-8 text: {e}"))?;
    let first = text.lines().next().unwrap_or("");
    if !first.starts_with("#usda ") {
        return Err(format!(
            "line 1: {first:?}: a USDA file starts with \"#usda 1.0\""
        ));
    }
    let mut parser = Parser {
        tokens: tokens(text)?,
        at: 0,
        depth: 0,
    };
    let layer = parser.layer()?;

    let up = match layer.metadata.iter().find(|(k, _)| k == "upAxis") {
        None => Up::Y,
        Some((_, Value::Str(s))) if s == "Y" => Up::Y,
        Some((_, Value::Str(s))) if s == "Z" => Up::Z,
        Some((_, v)) => return Err(format!("the layer's upAxis is {v:?}, not \"Y\" or \"Z\"")),
    };
    let fps = number(&layer, "framesPerSecond")?;
    let per_second = number(&layer, "timeCodesPerSecond")?
        .or(fps)
        .unwrap_or(24.0);
    if per_second <= 0.0 {
        return Err(format!(
            "the layer's timeCodesPerSecond is {per_second}: not positive"
        ));
    }
    let start = number(&layer, "startTimeCode")?.unwrap_or(0.0);
    if layer.metadata.iter().any(|(k, _)| k == "subLayers") {
        return Err(
            "the layer has subLayers, which campath does not compose: flatten the \
                    stage with OpenUSD's `usdcat --flatten file.usda -o flat.usda`"
                .into(),
        );
    }
    let custom = layer.metadata.iter().find(|(k, _)| k == "customLayerData");
    // campath's own: where the file's origin lies in campath's world (`path --origin`).
    let origin = match custom.and_then(|(_, data)| data.entry("origin")) {
        Some(v) => {
            let mut xyz = Vec::new();
            match v.numbers(&mut xyz) && xyz.len() == 3 {
                true => DVec3::from_slice(&xyz),
                false => return Err(format!("customLayerData's origin is {v:?}, not (x, y, z)")),
            }
        }
        None => DVec3::ZERO,
    };
    let size = custom.and_then(|(_, data)| {
        let side = |key| match data.entry(key) {
            Some(Value::Num(x)) if *x >= 1.0 && *x <= f64::from(u32::MAX) && x.fract() == 0.0 => {
                Some(*x as u32)
            }
            _ => None,
        };
        Some((side("imageWidth")?, side("imageHeight")?))
    });

    let mut found = Vec::new();
    cameras(&layer.prims, "", &[], &mut found);
    let paths = |found: &[Found]| {
        found
            .iter()
            .map(|f| f.path.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    if found.is_empty() {
        return Err("no Camera prim: the stage defines no camera (def Camera)".into());
    }
    let chosen = match camera {
        Some(name) => {
            let matches: Vec<&Found> = (found.iter())
                .filter(|f| f.path == name || f.path.rsplit('/').next() == Some(name))
                .collect();
            match matches[..] {
                [one] => one,
                [] => {
                    return Err(format!(
                        "no Camera prim {name:?}: the stage's cameras are {}",
                        paths(&found)
                    ))
                }
                _ => {
                    return Err(format!(
                        "several Camera prims are named {name:?}: give the path of one of {}",
                        matches
                            .iter()
                            .map(|f| f.path.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ))
                }
            }
        }
        None if found.len() == 1 => &found[0],
        None => {
            return Err(format!(
                "several Camera prims: {}; choose one with --camera",
                paths(&found)
            ))
        }
    };
    let path = &chosen.path;
    for prim in &chosen.chain {
        for arc in ["references", "payload", "inherits", "specializes"] {
            if prim.metadata(arc).is_some() {
                return Err(format!(
                    "the prim {:?} on the camera's path has {arc}, which campath does not \
                     compose: flatten the stage with OpenUSD's `usdcat --flatten file.usda -o \
                     flat.usda`",
                    prim.name
                ));
            }
        }
    }
    let cam = chosen.chain[chosen.chain.len() - 1];
    if let Some(Value::Str(p) | Value::Word(p)) =
        cam.attribute("projection").and_then(|a| a.default.as_ref())
    {
        if p != "perspective" {
            return Err(format!(
                "{path}: projection {p:?}: campath's camera is perspective"
            ));
        }
    }

    // Each prim's ops, outermost first; from the last prim that resets the stack on.
    let mut chain_ops = Vec::new();
    for (k, prim) in chosen.chain.iter().enumerate() {
        let prim_path: String = chosen.chain[..=k]
            .iter()
            .map(|p| format!("/{}", p.name))
            .collect();
        let (reset, ops) = ops(prim, &prim_path)?;
        if reset {
            chain_ops.clear();
        }
        chain_ops.push((prim_path, ops));
    }
    let lens: Vec<(&str, f64, Option<&Attribute>)> = FALLBACK_LENS
        .iter()
        .map(|&(name, fallback)| (name, fallback, cam.attribute(name)))
        .collect();

    // Every time code at which something that moves the camera or its lens is sampled.
    let mut codes = BTreeSet::new();
    let op_attrs = chain_ops
        .iter()
        .flat_map(|(_, ops)| ops.iter().map(|o| o.attr));
    for attr in op_attrs.chain(lens.iter().filter_map(|l| l.2)) {
        codes.extend(attr.samples.iter().map(|(c, _)| OrderedCode(*c)));
    }
    if codes.is_empty() {
        codes.insert(OrderedCode(start));
    }

    let mut samples = Vec::with_capacity(codes.len());
    for OrderedCode(code) in codes {
        let mut world = DMat4::IDENTITY;
        for (prim_path, ops) in &chain_ops {
            for op in ops {
                let (width, blend) = op_shape(op.kind).unwrap_or((0, Blend::Linear));
                let name = format!("{prim_path}.{}", op.name);
                let values = evaluate(&name, op.attr, code, width, blend)?.ok_or_else(|| {
                    format!(
                        "line {}: {name} has no value (neither default nor time samples)",
                        op.attr.line
                    )
                })?;
                let mut m = op_matrix(op.kind, &values)
                    .ok_or_else(|| format!("line {}: {name} is a zero quaternion", op.attr.line))?;
                if op.invert {
                    if m.determinant() == 0.0 {
                        return Err(format!(
                            "line {}: {name} is inverted (!invert!) but has no inverse",
                            op.attr.line
                        ));
                    }
                    m = m.inverse();
                }
                world *= m;
            }
        }
        let mut l = [0.0; 5];
        for (slot, (name, fallback, attr)) in l.iter_mut().zip(&lens) {
            let value = match attr {
                Some(a) => evaluate(&format!("{path}.{name}"), a, code, 1, Blend::Linear)?,
                None => None,
            };
            *slot = value.map_or(*fallback, |v| v[0]);
        }
        let [focal, h, v, h_offset, v_offset] = l;
        let at = |m: String| format!("{path} at time code {code}: {m}");
        if !(focal > 0.0 && h > 0.0 && v > 0.0 && focal.is_finite()) {
            return Err(at(format!(
                "focal length {focal} and apertures {h} × {v}: a lens needs all three positive"
            )));
        }
        let window = DVec2::new(h, v) / focal;
        let shift = DVec2::new(h_offset, v_offset) / focal;
        let time = (code - start) / per_second;
        let mut sample = Sample::of_matrix(time, world, up, window, shift).map_err(at)?;
        sample.eye += origin;
        if !(sample.window.is_finite() && sample.shift.is_finite()) {
            return Err(at("the lens is not finite".into()));
        }
        samples.push(sample);
    }
    Ok(Source {
        samples,
        fps,
        size,
        camera: path.clone(),
        view_distance: None,
    })
}

/// A time code ordered for a set (time codes are finite: `time_samples` refuses others).
#[derive(Clone, Copy, PartialEq)]
struct OrderedCode(f64);

impl Eq for OrderedCode {}

impl PartialOrd for OrderedCode {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for OrderedCode {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STAGE: &str = r#"#usda 1.0
(
    "a stage" # a comment
    upAxis = "Z"
    timeCodesPerSecond = 10
    startTimeCode = 2
    customLayerData = {
        int imageWidth = 64
        int imageHeight = 48
        dictionary more = { string x = "}" }
    }
)

over "ignored" {}

def Xform "shot" (
    kind = "assembly"
)
{
    double3 xformOp:translate.timeSamples = { 2: (0, 0, 1), 4: (0, 0, 3) }
    uniform token[] xformOpOrder = ["xformOp:translate"]

    def Camera "camera"
    {
        float focalLength = 2
        float horizontalAperture = 4
        float verticalAperture = 3
        float horizontalApertureOffset.timeSamples = { 3: 1 }
        matrix4d xformOp:transform = ( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (5, 0, 0, 1) )
        uniform token[] xformOpOrder = ["xformOp:transform"]
    }
}
"#;

    #[test]
    fn a_stage_reads_its_camera_under_its_parents() {
        let source = read(STAGE.as_bytes(), None).unwrap();
        assert_eq!(source.camera, "/shot/camera");
        assert_eq!(source.size, Some((64, 48)));
        let times: Vec<f64> = source.samples.iter().map(|s| s.time).collect();
        assert_eq!(times, [0.0, 0.1, 0.2]);
        // Z-up (x, y, z) is campath's (x, z, −y); the translation halfway at code 3 is z = 2.
        let eyes: Vec<DVec3> = source.samples.iter().map(|s| s.eye).collect();
        assert!(
            (eyes[1] - DVec3::new(5.0, 2.0, 0.0)).length() < 1e-15,
            "{}",
            eyes[1]
        );
        assert!(
            (eyes[2] - DVec3::new(5.0, 3.0, 0.0)).length() < 1e-15,
            "{}",
            eyes[2]
        );
        let s = source.samples[0];
        assert_eq!(
            (s.window, s.shift),
            (DVec2::new(2.0, 1.5), DVec2::new(0.5, 0.0))
        );
        // Looking down −Z (down, Z-up) is looking down campath's −Y.
        assert!((s.basis.n - DVec3::NEG_Y).length() < 1e-15);
    }

    #[test]
    fn rotation_orders_turn_the_first_axis_first() {
        let m = op_matrix("rotateXYZ", &[90.0, 0.0, 90.0]).unwrap();
        // +Y turns to +Z about X, then to +Z still about Z.
        let y = m.transform_vector3(DVec3::Y);
        assert!((y - DVec3::Z).length() < 1e-15, "{y}");
        let m = op_matrix("rotateZYX", &[90.0, 0.0, 90.0]).unwrap();
        // +Y turns to −X about Z, then stays −X about X.
        let y = m.transform_vector3(DVec3::Y);
        assert!((y - DVec3::NEG_X).length() < 1e-15, "{y}");
    }

    #[test]
    fn no_truncation_panics() {
        for end in 0..STAGE.len() {
            if STAGE.is_char_boundary(end) {
                let _ = read(&STAGE.as_bytes()[..end], None);
            }
        }
    }

    #[test]
    fn binary_files_are_refused_with_usdcat() {
        let e = read(b"PXR-USDC\0\0", None).unwrap_err();
        assert!(e.contains("usdcat"), "{e}");
    }
}
