//! A piece of a `spheres` list read without RON, when it is written in the plain forms: RON's
//! own parser spends about 300 ns on each number (it looks for `inf` and `NaN` six ways and
//! copies the digits before converting them), which is most of the time a file of many spheres
//! takes to load.
//!
//! [`spheres`] reads exactly the subset below, and gives `None` for anything else, so that the
//! caller hands the piece to RON; what it does read, it reads to the values RON gives:
//! - white space: space, tab, newline and carriage return (RON allows more);
//! - elements `( field: value, … )` without a struct name, with a comma after the last field
//!   or not, separated by commas, with a comma after the last element or not;
//! - fields `center`, `radius` and `color`, each at most once, `center` and `radius` present;
//! - `center` and a bare `color` are tuples of three numbers without a trailing comma; `color`
//!   is also `None` or `Some(` such a tuple `)`;
//! - a number is what RON takes for one: the longest run of digits, `.`, `e`, `E`, `+` and `-`
//!   (without `_`, `..` or a suffix such as `f64` after it), converted to the value
//!   `f64::from_str` gives, as RON converts it. The conversion is `fast_float2`'s (Lemire's
//!   algorithm, finding the run's end as it reads): a correctly rounded conversion has one
//!   answer, and the tests check the reader against RON's way with `f64::from_str`, over
//!   every short run.

use super::{SphereSpec, Triple};

/// The spheres of `piece` (elements of a `spheres` list, as between its brackets), or `None`
/// when it holds anything outside the forms above.
pub fn spheres(piece: &str) -> Option<Vec<SphereSpec>> {
    let mut r = Reader { text: piece, at: 0 };
    let mut out = Vec::new();
    r.blank();
    while !r.done() {
        out.push(r.sphere()?);
        r.blank();
        if r.done() {
            break;
        }
        r.expect(b',')?;
        r.blank();
    }
    Some(out)
}

struct Reader<'a> {
    text: &'a str,
    at: usize,
}

impl<'a> Reader<'a> {
    fn done(&self) -> bool {
        self.at == self.text.len()
    }

    fn peek(&self) -> Option<u8> {
        self.text.as_bytes().get(self.at).copied()
    }

    fn blank(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\n' | b'\r')) {
            self.at += 1;
        }
    }

    fn expect(&mut self, c: u8) -> Option<()> {
        (self.peek() == Some(c)).then(|| self.at += 1)
    }

    /// `( field: value, … )`.
    fn sphere(&mut self) -> Option<SphereSpec> {
        self.expect(b'(')?;
        let (mut center, mut radius, mut color) = (None, None, None);
        loop {
            self.blank();
            if self.expect(b')').is_some() {
                break;
            }
            let name = self.word();
            self.blank();
            self.expect(b':')?;
            self.blank();
            match name {
                b"center" if center.is_none() => center = Some(self.triple()?),
                b"radius" if radius.is_none() => radius = Some(self.number()?),
                b"color" if color.is_none() => color = Some(self.option()?),
                _ => return None,
            }
            self.blank();
            if self.expect(b',').is_none() {
                self.expect(b')')?;
                break;
            }
        }
        Some(SphereSpec {
            center: center?,
            radius: radius?,
            color: color.flatten(),
        })
    }

    /// An identifier's bytes (empty when none stands here).
    fn word(&mut self) -> &'a [u8] {
        let start = self.at;
        while self
            .peek()
            .is_some_and(|c| c.is_ascii_alphanumeric() || c == b'_')
        {
            self.at += 1;
        }
        &self.text.as_bytes()[start..self.at]
    }

    /// `None`, `Some(triple)` or a bare triple (RON's implicit `Some`).
    fn option(&mut self) -> Option<Option<Triple>> {
        if self.peek() == Some(b'(') {
            return Some(Some(self.triple()?));
        }
        match self.word() {
            b"None" => Some(None),
            b"Some" => {
                self.blank();
                self.expect(b'(')?;
                self.blank();
                let t = self.triple()?;
                self.blank();
                self.expect(b')')?;
                Some(Some(t))
            }
            _ => None,
        }
    }

    /// `(a, b, c)`.
    fn triple(&mut self) -> Option<Triple> {
        self.expect(b'(')?;
        let mut v = [0.0; 3];
        for (k, x) in v.iter_mut().enumerate() {
            if k > 0 {
                self.expect(b',')?;
            }
            self.blank();
            *x = self.number()?;
            self.blank();
        }
        self.expect(b')')?;
        Some((v[0], v[1], v[2]))
    }

    /// A number as RON reads one for an `f64` (see the module's notes), in one pass: the
    /// conversion reads the longest number it can, which is RON's run when the byte after it
    /// cannot continue the run (nor be a `_` or a suffix's `f`); otherwise the piece goes to
    /// RON. A sign must be followed by a digit or a `.`: RON reads `inf` and `NaN` as words,
    /// which the conversion would take.
    fn number(&mut self) -> Option<f64> {
        let rest = &self.text.as_bytes()[self.at..];
        let unsigned = match rest.first()? {
            b'+' | b'-' => &rest[1..],
            _ => rest,
        };
        if !matches!(unsigned.first()?, b'0'..=b'9' | b'.') {
            return None;
        }
        let (value, len) = fast_float2::parse_partial::<f64, _>(rest).ok()?;
        if rest
            .get(len)
            .is_some_and(|&c| in_run(c) || matches!(c, b'_' | b'f'))
        {
            return None;
        }
        self.at += len;
        Some(value)
    }
}

/// Whether `c` continues the run of a number as RON reads it: a digit, `.`, `e`, `E`, `+` or
/// `-`.
fn in_run(c: u8) -> bool {
    c.is_ascii_digit() || matches!(c, b'.' | b'e' | b'E' | b'+' | b'-')
}

#[cfg(test)]
mod tests {
    use super::super::options;
    use super::*;
    use proptest::prelude::*;

    /// RON's reading of the same piece, as `pieces` hands it to RON.
    fn ron(piece: &str) -> Option<Vec<SphereSpec>> {
        options()
            .from_str::<Vec<SphereSpec>>(&format!("[{piece}\n]"))
            .ok()
    }

    fn debug(v: &[SphereSpec]) -> String {
        format!("{v:?}")
    }

    /// Pieces in the forms the reader takes, each checked against RON field by field and bit
    /// by bit (`{:?}` prints each float's shortest round trip).
    #[test]
    fn plain_pieces_are_read_as_ron_reads_them() {
        let pieces = [
            "",
            " \n\t",
            "(center: (0.0, -100000.0, 0.0), radius: 100000.0, color: (0.55, 0.55, 0.5))",
            "(center: (1e-7, 2E+3, -0.0), radius: 5e-324),",
            "(center:(1,2,3),radius:2)\n,\r\n( radius : 1.5 , center : ( -4 , 5.25 , 6e2 ) , )",
            "(color: None, center: (1.0, 2.0, 3.0), radius: 1.0)",
            "(color: Some((0.1, 0.2, 0.3)), center: (1.0, 2.0, 3.0), radius: 1.0),\n",
            "(color: Some( ( 0.1 , 0.2 , 0.3 ) ), center: (+1.0, 2.0, 3.0), radius: 1e400)",
            "(center: (0.30000000000000004, 2.2250738585072014e-308, 1.7976931348623157e308), radius: 0.1)",
            "(center: (123456789012345678901234567890, .5, 5.), radius: 007)",
        ];
        for piece in pieces {
            let quick = spheres(piece).unwrap_or_else(|| panic!("not read: {piece:?}"));
            let ron = ron(piece).unwrap_or_else(|| panic!("RON rejects {piece:?}"));
            assert_eq!(debug(&quick), debug(&ron), "{piece:?}");
        }
    }

    /// A number as RON reads it, the way RON finds it: the longest run of its characters,
    /// refused with `..` in it or a `_` or `f` after it, else converted by `f64::from_str`.
    fn std_number(text: &str) -> Option<(f64, usize)> {
        let len = text.bytes().take_while(|&c| in_run(c)).count();
        let token = &text[..len];
        let after = text.as_bytes().get(len);
        if token.contains("..") || matches!(after, Some(b'_' | b'f')) {
            return None;
        }
        Some((token.parse().ok()?, len))
    }

    /// The reader reads a number where RON's way with `f64::from_str` does, to the bit and
    /// to the byte, and leaves it to RON where that refuses it: every run of up to five of
    /// `0 1 5 9 . e E + -` before a comma, a `_`, an `f` and the end, and of six before a
    /// comma (800,000); words RON reads (`inf`, `NaN`); long digit strings, halfway cases and
    /// the ends of the range.
    #[test]
    fn numbers_are_read_as_f64_from_str_reads_them() {
        let alphabet = b"0159.eE+-";
        let check = |text: &str| {
            let mut r = Reader { text, at: 0 };
            let quick = r.number().map(|v| (v.to_bits(), r.at));
            let std = std_number(text).map(|(v, len)| (v.to_bits(), len));
            assert_eq!(quick, std, "{text:?}");
        };
        for len in 1..=6u32 {
            let ends: &[&str] = if len < 6 {
                &[",", "_", "f", ""]
            } else {
                &[","]
            };
            super::super::tests::each_string(alphabet, len, |token| {
                for end in ends {
                    check(&format!("{token}{end}"));
                }
            });
        }
        for text in [
            "inf,",
            "-inf,",
            "+NaN,",
            "NaN",
            "infinity",
            "-Infinity,",
            "+",
            "-",
            ".",
            "-.,",
            "0.49649129942854364,",
            "-8.080007050571997)",
            "2.2250738585072011e-308",
            "2.2250738585072014e-308",
            "4.9406564584124654e-324",
            "2.4703282292062327e-324",
            "2.4703282292062328e-324",
            "1.7976931348623157e308",
            "1.7976931348623158e308",
            "1.7976931348623159e308",
            "9007199254740993",
            "9007199254740992.5000000000000000000000000000001",
            "123456789012345678901234567890123456789e-20",
            "0.000000000000000000000000000000000000000000001e45",
            "1e400",
            "-1e-400",
            "1e-99999999999999999999",
            "1e99999999999999999999",
            "+.5e+1",
            "-5.e-1",
            "00000000000000000000000000000000000000001.5",
        ] {
            check(text);
        }
    }

    /// Forms outside the subset go to RON, whether RON takes them or not.
    #[test]
    fn other_forms_are_left_to_ron() {
        let pieces = [
            ",",
            "(center: (1.0, 2.0, 3.0), radius: 1.0),,",
            "sphere(center: (1.0, 2.0, 3.0), radius: 1.0)",
            "(center: (1.0, 2.0, 3.0,), radius: 1.0)",
            "(center: (1.0, 2.0, 3.0), radius: 1_000.0)",
            "(center: (1.0, 2.0, 3.0), radius: 1.0f64)",
            "(center: (1.0, 2.0, 3.0), radius: inf)",
            "(center: (1.0, 2.0, 3.0), radius: 1..2)",
            "(center: (1.0, 2.0, 3.0), radius: 1-2)",
            "(center: (1.0, 2.0, 3.0), radius: 1.0, radius: 2.0)",
            "(center: (1.0, 2.0, 3.0))",
            "(center: (1.0, 2.0, 3.0), radius: 1.0, size: 2.0)",
            "(center: (1.0, 2.0, 3.0), radius: 1.0, color: Some(None))",
            "(center: (1.0, 2.0, 3.0), radius: 1.0)\u{0B}",
            "(center: (1.0, 2.0, 3.0), radius: 1.0) (center: (1.0, 2.0, 3.0), radius: 1.0)",
            "(center: (1.0, 2.0, 3.0), radius: 1.0",
        ];
        for piece in pieces {
            assert!(spheres(piece).is_none(), "read: {piece:?}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 4000, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED), failure_persistence: None, ..ProptestConfig::default() })]

        /// Any small edit of a plain piece: whatever the reader reads, RON reads to the same
        /// values; and an unedited piece is read.
        #[test]
        fn an_edited_piece_is_read_only_as_ron_reads_it(
            at in 0.0..1.0f64,
            cut in 0usize..4,
            insert in prop::sample::select(vec![
                "", "(", ")", ",", ":", " ", "\n", "0", "9", ".", "e", "E", "-", "+", "_", "f",
                "..", "1e5", "inf", "NaN", "None", "Some(", "radius: 1.0, ", "center", "\u{0B}",
            ]),
            x in -1e6..1e6f64,
            r in 1e-6..1e3f64,
        ) {
            let piece = format!(
                "(center: ({x:?}, {:?}, {:e}), radius: {r:?}, color: ({:?}, 0.5, 1)),\n\
                 ( radius : {:e} ,center:(1,2,3) ),",
                x * 0.5, x * 1e-3, r / 7.0, r * 3.0,
            );
            prop_assert!(spheres(&piece).is_some(), "{}", piece);
            let i = (at * piece.len() as f64) as usize;
            let edited = format!("{}{insert}{}", &piece[..i], &piece[(i + cut).min(piece.len())..]);
            if let Some(quick) = spheres(&edited) {
                let ron = ron(&edited);
                prop_assert!(ron.is_some(), "read, but RON rejects {:?}", edited);
                prop_assert_eq!(debug(&quick), debug(&ron.unwrap()), "{:?}", edited);
            }
        }
    }
}
