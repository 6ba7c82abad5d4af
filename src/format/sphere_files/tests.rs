//! The sphere files' readers against hand-made files of every form.

use super::header::HEADER_LINE_BYTES;
use super::text::{text_f32, text_f64};
use super::*;
use crate::error::PROBLEMS_SHOWN;
use crate::format::Triple;
use listing::Location;

/// The CSV form of `bytes`, appending `make(i, sphere)` to `out` for each sphere.
fn read_csv<T: Send>(
    bytes: &[u8],
    out: &mut Vec<T>,
    make: impl Fn(usize, &SphereSpec) -> T,
) -> Listing {
    let spec = SphereFileSpec::default();
    listed(out, |out, listing| {
        csv::csv_from(bytes, &spec, out, &make, listing)
    })
}

/// The PLY form of `bytes`, appending `make(i, sphere)` to `out` for each vertex.
fn read_ply<T: Send>(
    bytes: &[u8],
    out: &mut Vec<T>,
    make: impl Fn(usize, &SphereSpec) -> T + Sync,
) -> Listing {
    let len = bytes.len() as u64;
    let spec = SphereFileSpec::default();
    listed(out, |out, listing| {
        ply_body::ply_from(bytes, len, &spec, out, &make, listing)
    })
}

/// A file's spheres as read, and its listing; or its first problem.
type Read = Result<(Vec<SphereSpec>, Listing), FileProblem>;

fn first(out: Vec<SphereSpec>, listing: Listing) -> Read {
    assert_eq!(out.len(), listing.count);
    match listing.problems.first() {
        Some((_, e)) => Err(e.clone()),
        None => Ok((out, listing)),
    }
}

fn csv(bytes: &[u8]) -> Read {
    let mut out = Vec::new();
    let listing = read_csv(bytes, &mut out, |_, s| s.clone());
    first(out, listing)
}

fn ply(bytes: &[u8]) -> Read {
    let mut out = Vec::new();
    let listing = read_ply(bytes, &mut out, |_, s| s.clone());
    first(out, listing)
}

/// Every problem of a file, with the spheres read before each.
fn problems(listing: Listing) -> Vec<(usize, Option<Location>, String)> {
    (listing.problems.into_iter())
        .map(|(i, e)| (i, e.at, e.message))
        .collect()
}

fn sphere(c: Triple, r: f64, color: Option<Triple>) -> SphereSpec {
    SphereSpec {
        center: c,
        radius: r,
        color,
    }
}

#[test]
fn csv_with_and_without_colours() {
    let (s, listing) = csv(b"x,y,z,radius\n1,2,3,0.5\n\n-1e3, .5, 7., 2\n").unwrap();
    assert_eq!(
        s,
        [
            sphere((1.0, 2.0, 3.0), 0.5, None),
            sphere((-1000.0, 0.5, 7.0), 2.0, None)
        ]
    );
    assert_eq!(listing.location(1), Location::Line(4));
    let (s, listing) = csv(b"x, y, z, radius, r, g, b\r\n0,0,0,1,0.25,0.5,1\r\n").unwrap();
    assert_eq!(s, [sphere((0.0, 0.0, 0.0), 1.0, Some((0.25, 0.5, 1.0)))]);
    assert_eq!(listing.location(0), Location::Line(2));
    for (bad, at) in [
        (&b"x,y,radius\n"[..], Some(Location::Line(1))),
        (b"x,y,z,radius\n1,2,3\n", Some(Location::Line(2))),
        (b"x,y,z,radius\n1,2,3,4\n1,2,x,4\n", Some(Location::Line(3))),
        (b"", None),
    ] {
        assert_eq!(
            csv(bad).unwrap_err().at,
            at,
            "{}",
            String::from_utf8_lossy(bad)
        );
    }
}

/// Quoted fields read as CSV reads them: a quoted header and numbers give the spheres the same
/// file gives unquoted; a comma inside quotes is in its field; a quote not closed on its line,
/// or a space before a quote, is named with what to do.
#[test]
fn csv_quoted_fields() {
    let plain = csv(b"x,y,z,radius,r,g,b\n1.5,2,3,0.5,0,0.5,1\n").unwrap();
    let quoted = csv(b"\"x\",\"y\",z,\" radius\",r,g,\"b\"\r\n\"1.5\",2,\"3\",0.5,0,\"0.5\",1\n");
    assert_eq!(quoted.unwrap(), plain);
    for (text, want) in [
        (&b"x,y,z,radius\n\"1,5\",2,3,4\n"[..], "column 1 (x): not a number: \"1,5\""),
        (
            b"x,y,z,radius\n1, \"2\",3,4\n",
            "column 2 (y): not a number: \"\\\"2\\\"\" (a quoted field starts with its quote: no space before it)",
        ),
        (b"x,y,z,radius\n\"1,2,3,4\n", "a quote is not closed: close it on the same line"),
        (b"x,y,z,radius\n\"1\",2,3\n", "expected 4 fields (x,y,z,radius), got 3"),
    ] {
        let e = csv(text).unwrap_err();
        assert_eq!((e.at, e.message.as_str()), (Some(Location::Line(2)), want));
    }
    let e = csv(b"\"x,y\",z,radius\n").unwrap_err();
    assert!(
        e.message
            .starts_with("no column for x in the header \"x,y,z,radius\""),
        "{e:?}"
    );
    let e = csv(b"1,2,3,4\n").unwrap_err();
    assert!(
        e.message
            .starts_with("no header: the first line must name the columns"),
        "{e:?}"
    );
}

fn header(format: &str, props: &str, n: usize) -> Vec<u8> {
    format!(
        "ply\nformat {format} 1.0\ncomment made by a test\nelement vertex {n}\n{props}end_header\n"
    )
    .into_bytes()
}

#[test]
fn ply_ascii_and_binary_read_the_same_spheres() {
    let props = "property float x\nproperty float y\nproperty double z\nproperty double radius\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty list uchar int extra\n";
    let mut ascii = header("ascii", props, 2);
    ascii.extend_from_slice(b"1.5 -2 3.25 0.5 255 128 0 2 7 8\n0 0 0.1 1 0 0 0 0\n");
    let mut bin = header("binary_little_endian", props, 2);
    for (x, y, z, r, c, list) in [
        (
            1.5f32,
            -2f32,
            3.25f64,
            0.5f64,
            [255u8, 128, 0],
            vec![7i32, 8],
        ),
        (0.0, 0.0, 0.1, 1.0, [0, 0, 0], vec![]),
    ] {
        bin.extend(x.to_le_bytes());
        bin.extend(y.to_le_bytes());
        bin.extend(z.to_le_bytes());
        bin.extend(r.to_le_bytes());
        bin.extend(c);
        bin.push(list.len() as u8);
        for v in list {
            bin.extend(v.to_le_bytes());
        }
    }
    let want = [
        sphere((1.5, -2.0, 3.25), 0.5, Some((1.0, 128.0 / 255.0, 0.0))),
        sphere((0.0, 0.0, 0.1), 1.0, Some((0.0, 0.0, 0.0))),
    ];
    assert_eq!(ply(&ascii).unwrap().0, want);
    assert_eq!(ply(&bin).unwrap().0, want);
    // Truncated: the last byte gone.
    bin.pop();
    let e = ply(&bin).unwrap_err();
    assert_eq!(e.at, Some(Location::Vertex(1)), "{e:?}");
    assert!(e.message.contains("truncated"));
}

#[test]
fn ply_problems_name_what_is_missing() {
    let e = ply(&header(
        "ascii",
        "property float x\nproperty float y\nproperty float z\n",
        0,
    ))
    .unwrap_err();
    assert!(e.message.contains("no radius column"), "{e:?}");
    let props = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
    let mut short = header("ascii", props, 1);
    short.extend_from_slice(b"1 2 3\n");
    let e = ply(&short).unwrap_err();
    assert_eq!(e.at, Some(Location::Line(10)), "{e:?}");
    assert!(e.message.contains("short row"), "{e:?}");
    assert!(ply(&header("binary_big_endian", props, 0))
        .unwrap_err()
        .message
        .contains("binary_big_endian"));
    assert!(ply(b"PLY\n").is_err());
}

/// A binary body of several blocks: every vertex handed over once, with its own index, in
/// file order; a body that ends early names the vertex it ends in, past the first block.
#[test]
fn binary_blocks_keep_file_order_and_name_the_cut_vertex() {
    let props = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
    let n = 2 * BLOCK_BYTES / 16 + 5;
    let mut bin = header("binary_little_endian", props, n);
    let value = |i: usize, k: usize| (i * 4 + k) as f32;
    for i in 0..n {
        for k in 0..4 {
            bin.extend(value(i, k).to_le_bytes());
        }
    }
    let mut out = Vec::new();
    let listing = read_ply(&bin, &mut out, |i, s| (i, s.clone()));
    assert_eq!(listing.problems, []);
    assert_eq!((listing.count, out.len()), (n, n));
    for (k, (i, s)) in out.iter().enumerate() {
        let v = |j| f64::from(value(k, j));
        assert_eq!((*i, s), (k, &sphere((v(0), v(1), v(2)), v(3), None)));
    }
    // Cut inside vertex n - 4, in the third block.
    bin.truncate(bin.len() - 3 * 16 - 1);
    let e = ply(&bin).unwrap_err();
    assert_eq!(e.at, Some(Location::Vertex(n - 4)), "{e:?}");
    assert_eq!(
        e.message,
        format!(
            "truncated: the body ends inside vertex {} of the header's {n}",
            n - 4
        )
    );
}

/// Elements before the vertices are read past, whole records or list by list; a body that
/// ends inside them names the element.
#[test]
fn binary_elements_before_the_vertices_are_read_past() {
    let text = "ply\nformat binary_little_endian 1.0\nelement camera 2\nproperty double t\nproperty uchar k\nelement face 2\nproperty list uchar ushort idx\nproperty char f\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nproperty double radius\nend_header\n";
    let mut bin = text.as_bytes().to_vec();
    for (t, k) in [(0.5f64, 1u8), (1.5, 2)] {
        bin.extend(t.to_le_bytes());
        bin.push(k);
    }
    for list in [&[1u16, 2, 3][..], &[]] {
        bin.push(list.len() as u8);
        for v in list {
            bin.extend(v.to_le_bytes());
        }
        bin.push(7);
    }
    for v in [1.0f64, 2.0, 3.0, 0.25] {
        bin.extend(v.to_le_bytes());
    }
    assert_eq!(ply(&bin).unwrap().0, [sphere((1.0, 2.0, 3.0), 0.25, None)]);
    let camera_end = text.len() + 2 * 9;
    for (cut, want) in [
        (text.len() + 9 + 4, "element camera 1 "),
        (camera_end + 1 + 2, "element face 0 "),
        (camera_end + 1 + 6 + 1 + 1, "element face 1 "),
    ] {
        let e = ply(&bin[..cut]).unwrap_err();
        assert!(e.message.contains(want), "{cut}: {e:?}");
        assert_eq!(e.at, None);
    }
}

/// The unkind forms: a header without `end_header` before a long body, `end_header` at
/// the very end, an element without properties, ASCII values of the declared type (a
/// `float` as a binary body stores it), negative and float list counts, bytes that are not
/// UTF-8 where they are read and where they are not; every message short.
#[test]
fn unkind_ply_and_csv_forms() {
    let short = |e: FileProblem| {
        assert!(e.message.len() < 200, "{e:?}");
        e
    };
    let xyzr = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
    // No end_header: the body's first "line" is cut at HEADER_LINE_BYTES, named, not quoted.
    let mut cut = b"ply\nformat binary_little_endian 1.0\nelement vertex 9\n".to_vec();
    cut.extend(xyzr.as_bytes());
    cut.extend(vec![7u8; 3 * HEADER_LINE_BYTES]);
    cut.push(b'\n');
    let e = short(ply(&cut).unwrap_err());
    assert_eq!(e.at, Some(Location::Line(8)), "{e:?}");
    assert!(e.message.contains("end_header"), "{e:?}");
    assert!(short(ply(&[b'x'; 2 * HEADER_LINE_BYTES]).unwrap_err())
        .message
        .contains("not a PLY file"));
    // end_header ending the file, no newline.
    let mut end = header("binary_little_endian", xyzr, 0);
    end.pop();
    assert_eq!(ply(&end).unwrap().1.count, 0);
    // An element without properties before the vertices takes no line.
    let text = format!(
        "ply\nformat ascii 1.0\nelement marker 3\nelement vertex 1\n{xyzr}end_header\n\n1 2 3 4\n"
    );
    assert_eq!(
        ply(text.as_bytes()).unwrap().0,
        [sphere((1.0, 2.0, 3.0), 4.0, None)]
    );
    // A float in ASCII is the f32 a binary body holds.
    let mut ascii = header("ascii", xyzr, 1);
    ascii.extend(b"0.1 0.2 0.3 0.7\n");
    let mut bin = header("binary_little_endian", xyzr, 1);
    for v in [0.1f32, 0.2, 0.3, 0.7] {
        bin.extend(v.to_le_bytes());
    }
    let f = |v: f32| f64::from(v);
    let want = [sphere((f(0.1), f(0.2), f(0.3)), f(0.7), None)];
    assert_eq!(ply(&ascii).unwrap().0, want);
    assert_eq!(ply(&bin).unwrap().0, want);
    // An integer property takes only integers in its range.
    for (props, row, field) in [
        (
            "property int x\nproperty float y\nproperty float z\nproperty float radius\n",
            "0.5 0 0 1",
            "x: not a value of type int",
        ),
        (
            "property float x\nproperty float y\nproperty float z\nproperty uchar radius\n",
            "0 0 0 300",
            "radius: not a value of type uchar",
        ),
    ] {
        let mut text = header("ascii", props, 1);
        text.extend(row.as_bytes());
        let e = short(ply(&text).unwrap_err());
        assert!(e.message.contains(field), "{e:?}");
    }
    // List counts: negative in binary and ASCII, or of a float type.
    let listed = format!("{xyzr}property list char float extra\n");
    let mut bin = header("binary_little_endian", &listed, 1);
    for v in [0.0f32, 0.0, 0.0, 1.0] {
        bin.extend(v.to_le_bytes());
    }
    bin.push(0xff);
    let e = ply(&bin).unwrap_err();
    assert_eq!(e.at, Some(Location::Vertex(0)), "{e:?}");
    assert!(e.message.contains("negative list count"), "{e:?}");
    let mut ascii = header("ascii", &listed, 1);
    ascii.extend(b"0 0 0 1 -1\n");
    assert!(ply(&ascii).unwrap_err().message.contains("0 or more"));
    let floaty = header(
        "ascii",
        &format!("{xyzr}property list float int extra\n"),
        0,
    );
    assert!(ply(&floaty).unwrap_err().message.contains("integer type"));
    // Bytes that are not UTF-8: named on a vertex's line, not read after the vertices.
    let tail = format!("ply\nformat ascii 1.0\nelement vertex 1\n{xyzr}element note 1\nproperty uchar n\nend_header\n0 0 0 1\n");
    let mut after = tail.into_bytes();
    after.extend(b"\xe9\n");
    assert_eq!(ply(&after).unwrap().1.count, 1);
    let mut inside = header("ascii", xyzr, 2);
    inside.extend(b"0 0 0 1\n0 0 0 1 \xe9\n");
    let e = ply(&inside).unwrap_err();
    assert_eq!(e.at, Some(Location::Line(11)), "{e:?}");
    assert!(e.message.contains("UTF-8"), "{e:?}");
    // With no vertices nothing after the header is read; a CRLF header line of the most
    // bytes is whole; an integer `-0` is 0.
    let mut none = format!("ply\nformat ascii 1.0\nelement vertex 0\n{xyzr}element note 1\nproperty uchar k\nend_header\n").into_bytes();
    none.extend(vec![b'7'; BLOCK_BYTES + 10]);
    assert_eq!(ply(&none).unwrap().1.count, 0);
    let comment = format!("comment {}", "c".repeat(HEADER_LINE_BYTES - 8));
    let mut crlf = format!(
        "ply\r\nformat ascii 1.0\r\n{comment}\r\nelement vertex 1\r\n{}end_header\r\n",
        xyzr.replace('\n', "\r\n")
    )
    .into_bytes();
    crlf.extend(b"1 2 3 4\r\n");
    assert_eq!(ply(&crlf).unwrap().0, [sphere((1.0, 2.0, 3.0), 4.0, None)]);
    let uchar = "property float x\nproperty float y\nproperty float z\nproperty uchar radius\n";
    let mut zero = header("ascii", uchar, 1);
    zero.extend(b"0 0 0 -0\n");
    assert_eq!(ply(&zero).unwrap().0[0].radius, 0.0);
    // Blank is ASCII whitespace alone, before the vertices and among them: a line of a
    // no-break space is a record in both.
    let mut before = format!("ply\nformat ascii 1.0\nelement note 1\nproperty uchar k\nelement vertex 1\n{xyzr}end_header\n").into_bytes();
    before.extend("\u{a0}\n1 2 3 4\n".as_bytes());
    assert_eq!(ply(&before).unwrap().1.count, 1);
    let mut among = header("ascii", xyzr, 2);
    among.extend("1 2 3 4\n\u{a0}\n1 2 3 4\n".as_bytes());
    assert_eq!(ply(&among).unwrap_err().at, Some(Location::Line(11)));
    // A vertex line of a whole block: whole when the file ends with it, else refused.
    let mut long = header("ascii", xyzr, 1);
    let body = long.len();
    long.extend(b"1 2 3 4");
    long.resize(body + BLOCK_BYTES, b' ');
    assert_eq!(ply(&long).unwrap().1.count, 1);
    long.push(b'\n');
    let e = short(ply(&long).unwrap_err());
    assert!(e.message.contains("4 MiB or more"), "{e:?}");
    // CSV: a header line is quoted short, and lines ending in a lone CR are named.
    let mut cr = b"x,y,z,radius".to_vec();
    for _ in 0..1000 {
        cr.extend(b"\r1,2,3,4");
    }
    let e = short(csv(&cr).unwrap_err());
    assert!(e.message.contains("CR alone"), "{e:?}");
}

/// A text body of three blocks, read on the pool: every sphere once, in file order, with
/// its line past blank lines and lines cut by a block's end; the first bad line named
/// however the blocks fall, in CSV and in ASCII PLY; what follows the last vertex of an
/// ASCII PLY never read.
#[test]
fn text_blocks_keep_file_order_and_name_the_first_bad_line() {
    let n = 2 * BLOCK_BYTES / 10 + 1234;
    let blank = |i: usize| i % 1000 == 7;
    let mut csv_text = String::from("x,y,z,radius\n");
    let mut ply_rows = String::new();
    let mut line_of = Vec::new();
    let mut line = 1;
    for i in 0..n {
        if blank(i) {
            csv_text.push_str(" \r\n");
            ply_rows.push('\n');
            line += 1;
        }
        line += 1;
        line_of.push(line);
        csv_text.push_str(&format!("{i},0,0,1\n"));
        ply_rows.push_str(&format!("{i} 0 0 1\n"));
    }
    let (spheres, listing) = csv(csv_text.as_bytes()).unwrap();
    assert_eq!(spheres.len(), n);
    for (i, s) in spheres.iter().enumerate() {
        assert_eq!(s.center.0, i as f64);
        assert_eq!(listing.location(i), Location::Line(line_of[i]));
    }
    // Two bad rows past the first block: the first is named.
    let (a, b) = (n / 2, n - 3);
    let bad = csv_text
        .replacen(&format!("\n{a},0,0,1\n"), &format!("\n{a},0,zero,1\n"), 1)
        .replacen(&format!("\n{b},0,0,1\n"), &format!("\n{b},0\n"), 1);
    let e = csv(bad.as_bytes()).unwrap_err();
    assert_eq!(e.at, Some(Location::Line(line_of[a])), "{e:?}");
    assert_eq!(e.message, "column 3 (z): not a number: \"zero\"");

    let xyzr = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
    let mut ply_text =
        format!("ply\nformat ascii 1.0\nelement vertex {n}\n{xyzr}element note 2\nproperty uchar k\nend_header\n").into_bytes();
    let header_lines = 10;
    ply_text.extend(ply_rows.as_bytes());
    ply_text.extend(b"\xff\xfe not text\nnor this\n");
    let (spheres, listing) = ply(&ply_text).unwrap();
    assert_eq!((spheres.len(), listing.count), (n, n));
    assert!(spheres
        .iter()
        .enumerate()
        .all(|(i, s)| s.center.0 == i as f64));
    // A bad vertex past the first block, named by its line and index.
    let row = format!("\n{a} 0 0 1\n");
    let at = ply_text
        .windows(row.len())
        .position(|w| w == row.as_bytes())
        .unwrap();
    let mut bad = ply_text.clone();
    bad[at + 1] = b'#';
    let e = ply(&bad).unwrap_err();
    assert_eq!(
        e.at,
        Some(Location::Line(header_lines + line_of[a] - 1)),
        "{e:?}"
    );
    assert!(
        e.message
            .starts_with(&format!("vertex {a}: x: not a number")),
        "{e:?}"
    );
    // The last vertex gone: named as missing, not the lines after it as vertices.
    let cut = ply_text.len() - b"\xff\xfe not text\nnor this\n".len();
    let mut short = ply_text[..cut].to_vec();
    short.truncate(short.len() - format!("{} 0 0 1\n", n - 1).len());
    let e = ply(&short).unwrap_err();
    assert_eq!(e.at, Some(Location::Vertex(n - 1)), "{e:?}");
}

/// Rows that cannot be read are named and passed, so every one is found; a CSV's spheres
/// after them keep their lines, an ASCII PLY's vertices their numbers (a stand-in holds
/// the bad vertex's place).
#[test]
fn every_bad_row_is_named_and_the_rest_still_read() {
    let mut out = Vec::new();
    let text = b"x,y,z,radius\n0,0,0,1\nfoo,0,0,1\n\n0,0,0,2\n0,0\n\xe9\n0,0,0,3\n";
    let listing = read_csv(text, &mut out, |_, s| s.radius);
    assert_eq!(out, [1.0, 2.0, 3.0]);
    assert_eq!(
        (1..3).map(|i| listing.location(i)).collect::<Vec<_>>(),
        [Location::Line(5), Location::Line(8)]
    );
    let line = |l| Some(Location::Line(l));
    assert_eq!(
        problems(listing),
        [
            (
                1,
                line(3),
                "column 1 (x): not a number: \"foo\"".to_string()
            ),
            (
                2,
                line(6),
                "expected 4 fields (x,y,z,radius), got 2".to_string()
            ),
            (2, line(7), "not UTF-8 text".to_string()),
        ]
    );
    let xyzr = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
    let mut ascii = header("ascii", xyzr, 5);
    ascii.extend(b"0 0 0 1\n0 0 zz 1\n0 0 0 2\n0 0\n0 0 0 3\n");
    let mut out = Vec::new();
    let listing = read_ply(&ascii, &mut out, |i, s| (i, s.radius));
    assert_eq!(out, [(0, 1.0), (1, 1.0), (2, 2.0), (3, 1.0), (4, 3.0)]);
    assert_eq!(listing.location(4), Location::Vertex(4));
    assert_eq!(
        problems(listing),
        [
            (1, line(11), "vertex 1: z: not a number: \"zz\"".to_string()),
            (
                3,
                line(13),
                "vertex 3: a short row: no value for z".to_string()
            ),
        ]
    );
}

/// What a header may hold once is refused twice; a long comment is read past; nothing
/// may follow the vertices when no element does; a BOM before a blank line, and lines
/// ending in CR alone, are named as such.
#[test]
fn ambiguous_headers_and_stray_data_are_refused() {
    let xyzr = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
    for (text, want) in [
        (
            format!("ply\nformat ascii 1.0\nformat binary_little_endian 1.0\nelement vertex 0\n{xyzr}end_header\n"),
            "a second `format` line (the first is line 2)",
        ),
        (
            format!("ply\nformat ascii 2.0\nelement vertex 0\n{xyzr}end_header\n"),
            "format version \"2.0\": PLY 1.0 is read",
        ),
        (
            format!("ply\nformat ascii 1.0\nelement vertex 0\n{xyzr}element vertex 2\n{xyzr}end_header\n"),
            "a second `element vertex` line (the first is line 3)",
        ),
        (
            format!("ply\nformat ascii 1.0\nelement vertex 0\n{xyzr}property double radius\nend_header\n"),
            "element vertex has a second property \"radius\"",
        ),
        (
            format!("ply\nformat ascii 1.0\nelement vertex 0\n{xyzr}property list uchar int x\nend_header\n"),
            "element vertex has a second property \"x\"",
        ),
        (
            "ply\rformat ascii 1.0\relement vertex 0\rend_header\r".to_string(),
            "its lines end in CR alone",
        ),
    ] {
        let e = ply(text.as_bytes()).unwrap_err();
        assert!(e.message.contains(want), "{want:?}: {e:?}");
    }
    // A comment and an obj_info line of 5,000 bytes, in ASCII and binary.
    let long = |w: &str| format!("{w} {}\n", "{\"meta\":1}".repeat(500));
    for format in ["ascii", "binary_little_endian"] {
        let mut text = format!(
            "ply\nformat {format} 1.0\n{}{}element vertex 1\n{xyzr}end_header\n",
            long("comment"),
            long("obj_info")
        )
        .into_bytes();
        match format {
            "ascii" => text.extend(b"1 2 3 4\n"),
            _ => (1..5).for_each(|v| text.extend((v as f32).to_le_bytes())),
        }
        assert_eq!(ply(&text).unwrap().0, [sphere((1.0, 2.0, 3.0), 4.0, None)]);
    }
    let mut long_element = header("ascii", xyzr, 0);
    long_element.splice(4..4, long("element").bytes());
    assert!(ply(&long_element)
        .unwrap_err()
        .message
        .contains("longer than"));
    // More vertices than the header's count, with no element after them.
    let mut ascii = header("ascii", xyzr, 1);
    ascii.extend(b"1 2 3 4\n\n  \n5 6 7 8\n");
    let e = ply(&ascii).unwrap_err();
    assert_eq!(e.at, Some(Location::Line(13)), "{e:?}");
    assert_eq!(
        e.message,
        "a row past the header's vertex count (1): is the count right?"
    );
    ascii.truncate(ascii.len() - 8);
    assert_eq!(ply(&ascii).unwrap().1.count, 1);
    let mut bin = header("binary_little_endian", xyzr, 1);
    (0..8).for_each(|v| bin.extend((v as f32).to_le_bytes()));
    let e = ply(&bin).unwrap_err();
    assert!(
        e.message
            .contains("goes on past the header's vertex count (1)"),
        "{e:?}"
    );
    // What follows the vertices is the next element's, and not read.
    let mut face = header(
        "binary_little_endian",
        &format!("{xyzr}element face 1\nproperty uchar k\n"),
        1,
    );
    (0..8).for_each(|v| face.extend((v as f32).to_le_bytes()));
    assert_eq!(ply(&face).unwrap().1.count, 1);
    // A comment of exactly the most bytes and one or two more, with LF and with CRLF.
    for len in HEADER_LINE_BYTES - 1..HEADER_LINE_BYTES + 3 {
        for end in ["\n", "\r\n"] {
            let comment = format!("comment {}{end}", "c".repeat(len - 8));
            let mut text =
                format!("ply\nformat ascii 1.0\n{comment}element vertex 1\n{xyzr}end_header\n")
                    .into_bytes();
            text.extend(b"1 2 3 4\n");
            assert_eq!(ply(&text).unwrap().1.count, 1, "{len} {end:?}");
        }
    }
    // Lines that end in CR alone, in a file of many lines.
    let mut cr = format!(
        "ply\rformat ascii 1.0\relement vertex 2000\r{}end_header\r",
        xyzr.replace('\n', "\r")
    )
    .into_bytes();
    (0..2000).for_each(|_| cr.extend(b"1 2 3 4\r"));
    assert!(ply(&cr).unwrap_err().message.contains("CR alone"));
    // A file of many unreadable rows: the first hundred named, the rest counted.
    let mut rows = String::from("x,y,z,radius\n");
    (0..250).for_each(|i| rows.push_str(&format!("{i};0;0;1\n")));
    let mut out = Vec::new();
    let listing = read_csv(rows.as_bytes(), &mut out, |_, s| s.radius);
    let named = problems(listing);
    assert_eq!(named.len(), PROBLEMS_SHOWN);
    assert_eq!(named[98].1, Some(Location::Line(100)));
    assert_eq!(
        named[99],
        (0, None, "and 151 more row(s) that cannot be read".into())
    );
    // A byte-order mark, then a blank line, then the header.
    let (s, _) = csv(b"\xef\xbb\xbf\nx,y,z,radius\n0,0,0,1\n").unwrap();
    assert_eq!(s.len(), 1);
}

/// [`text_f64`] and [`text_f32`] give what `from_str` gives, bit for bit, and refuse what
/// it refuses: every short field of number, infinity and NaN characters, and others.
#[test]
fn text_numbers_are_what_from_str_reads() {
    let check = |field: &str| {
        let std = field.parse::<f64>().ok().map(f64::to_bits);
        assert_eq!(text_f64(field).map(f64::to_bits), std, "{field:?}");
        let std = field.parse::<f32>().ok().map(f32::to_bits);
        assert_eq!(text_f32(field).map(f32::to_bits), std, "{field:?}");
    };
    for (alphabet, longest) in [(&b"0159.eE+-"[..], 6), (b"09.eE+-infatyNIx(", 5)] {
        for len in 0..=longest {
            super::super::tests::each_string(alphabet, len, check);
        }
    }
    for field in [
        "inf",
        "-Infinity",
        "+NaN",
        "nan",
        "0.30000000000000004",
        "2.2250738585072011e-308",
        "4.9406564584124654e-324",
        "1.7976931348623157e308",
        "1.7976931348623159e308",
        "3.4028235e38",
        "3.4028236e38",
        "1e-46",
        "0.1",
        "9007199254740993",
        "18446744073709551616",
        "1e-400",
        "0x10",
        "1_000",
        " 1",
        "١",
        "infinity",
        "-INFINITY",
        "nan(1)",
        "infinit",
    ] {
        check(field);
    }
}

fn read_with(name: &str, bytes: &[u8], spec: &SphereFileSpec) -> Read {
    let mut out = Vec::new();
    let make = |_: usize, s: &SphereSpec| s.clone();
    let listing = listed(&mut out, |out, listing| match name {
        "csv" => csv::csv_from(bytes, spec, out, &make, listing),
        _ => xyz::xyz_from(bytes, spec, out, &make, listing),
    });
    first(out, listing)
}

/// Columns by their usual names, in any order and case: `r` is the radius beside x, y, z
/// alone and red beside `g` and `b`; two columns that could be one field, some colour columns
/// without the rest, and a rule's column the header lacks are each named with the fix.
#[test]
fn columns_are_found_by_name_or_named_with_the_fix() {
    let spec = SphereFileSpec::default();
    let one = |text: &[u8]| read_with("csv", text, &spec).map(|(s, _)| s[0].clone());
    assert_eq!(
        one(b"X,Y,Z,R\n1,2,3,4\n").unwrap(),
        sphere((1.0, 2.0, 3.0), 4.0, None)
    );
    assert_eq!(
        one(b"b,g,r,Radius,z,y,x\n0.25,0.5,1,4,3,2,1\n").unwrap(),
        sphere((1.0, 2.0, 3.0), 4.0, Some((1.0, 0.5, 0.25)))
    );
    assert_eq!(
        one(b"# x,y,z,radius,id\n1,2,3,4,x\n").unwrap(),
        sphere((1.0, 2.0, 3.0), 4.0, None)
    );
    let message =
        |text: &[u8], spec: &SphereFileSpec| read_with("csv", text, spec).unwrap_err().message;
    let m = message(b"x,y,z,radius,X\n", &spec);
    assert!(
        m.starts_with("the header \"x,y,z,radius,X\" names \"x\" twice")
            || m.contains("could both be x"),
        "{m}"
    );
    let twice = SphereFileSpec {
        columns: crate::format::ColumnsSpec {
            x: Some("a".into()),
            y: Some("A".into()),
            ..Default::default()
        },
        ..SphereFileSpec::default()
    };
    let m = message(b"a,z,radius\n", &twice);
    assert!(m.starts_with("column \"a\" would be both x and y"), "{m}");
    let m = message(b"x,y,z,radius,radii\n", &spec);
    assert!(m.starts_with("columns \"radius\" and \"radii\" could both be radius: name one with columns: (radius:"), "{m}");
    let m = message(b"x,y,z,radius,red,green\n", &spec);
    assert!(m.contains("has some colour columns but no blue"), "{m}");
    let m = message(b"x,y,z\n", &spec);
    assert!(
        m.contains("no radius column") && m.contains("radius: …"),
        "{m}"
    );
    let named = SphereFileSpec {
        columns: crate::format::ColumnsSpec {
            x: Some("PosX".into()),
            ..Default::default()
        },
        ..SphereFileSpec::default()
    };
    let m = message(b"x,y,z,radius\n", &named);
    assert!(
        m.starts_with("columns.x names \"PosX\", which the header"),
        "{m}"
    );
    let by = SphereFileSpec {
        radius: Some(1.0),
        color_by: Some(crate::format::ColorBySpec::Colormap {
            column: "speed".into(),
            map: "viridis".into(),
            range: (0.0, 1.0),
        }),
        ..SphereFileSpec::default()
    };
    let m = message(b"x,y,z\n", &by);
    assert!(
        m.starts_with("color_by's column \"speed\" is not in the header"),
        "{m}"
    );
    // A colormap over a value that is not finite.
    let e = read_with("csv", b"x,y,z,speed\n1,2,3,inf\n", &by).unwrap_err();
    assert_eq!(e.message, "column 4 (speed): not a finite number: inf");
}

/// Extended XYZ: `Properties=` among other keys with quoted and braced values, in any case,
/// widths giving `name[k]` columns; a plain file's species and position; a row that does not
/// match its properties, a bad property and a short file are named.
#[test]
fn xyz_reads_its_properties() {
    let spec = SphereFileSpec {
        radius: Some(0.5),
        ..SphereFileSpec::default()
    };
    let ext = b"2\nLattice=\"1 0 0 0 1 0 0 0 1\" info={a b} properties=species:S:1:pos:R:3:Color:R:3 pbc=\"T T T\"\nO 1 2 3 1 0 0\nH\t4 5 6 0 1 0\n";
    let (s, listing) = read_with("xyz", ext, &spec).unwrap();
    assert_eq!(s[1], sphere((4.0, 5.0, 6.0), 0.5, Some((0.0, 1.0, 0.0))));
    assert_eq!(listing.ignored, ["species"]);
    let (s, _) = read_with("xyz", b"1\n\nC 1 2 3\n2\nnext frame\n", &spec).unwrap();
    assert_eq!(s, [sphere((1.0, 2.0, 3.0), 0.5, None)]);
    let bad = |text: &[u8]| {
        let e = read_with("xyz", text, &spec).unwrap_err();
        (e.at, e.message)
    };
    assert_eq!(
        bad(b"2\nProperties=species:S:1:pos:R:3:radius:R:1\nO 0 0 0 1\nH 1 1 1\n"),
        (
            Some(Location::Line(4)),
            "expected 5 values (species pos[0] pos[1] pos[2] radius), got 4: does Properties= on line 2 match the rows?".to_string()
        )
    );
    assert_eq!(
        bad(b"1\nProperties=species:S:1:pos:X:3\nO 0 0 0\n"),
        (
            Some(Location::Line(2)),
            "property \"pos\": type \"X\" is not R, I, S or L".to_string()
        )
    );
    assert_eq!(
        bad(b"1\nProperties=species:S:1:pos:R\nO 0 0 0\n").1,
        "Properties=\"species:S:1:pos:R\" is not name:type:width triples"
    );
    assert_eq!(
        bad(b"3\n\nO 0 0 0\n").1,
        "truncated: the file ends at atom 1 of the 3 its first line gives"
    );
    let text_x = SphereFileSpec {
        columns: crate::format::ColumnsSpec {
            x: Some("species".into()),
            ..Default::default()
        },
        ..spec.clone()
    };
    let e = read_with("xyz", b"1\n\nO 0 0 0\n", &text_x).unwrap_err();
    assert_eq!(
        e.message,
        "column \"species\" holds text, not the numbers x needs"
    );
    assert_eq!(
        bad(b"atoms\n").1,
        "the first line must be the number of atoms, got \"atoms\""
    );
    assert_eq!(
        bad(b"1\n\nO 0 0\n").1,
        "expected 4 values (species pos[0] pos[1] pos[2]), got 3: name the columns with Properties= on the comment line"
    );
    // A plain file's values past its four are read past.
    let (s, _) = read_with("xyz", b"1\n\nO 0 0 0 -0.8 1.5\n", &spec).unwrap();
    assert_eq!(s, [sphere((0.0, 0.0, 0.0), 0.5, None)]);
}

/// A binary PLY whose every vertex names a type the table lacks: the first ones named in
/// vertex order, the rest counted, however the pool's tasks met them.
#[test]
fn a_million_unknown_types_cost_no_message_each() {
    let n = 3 * PROBLEMS_SHOWN + 7;
    let mut bin = header(
        "binary_little_endian",
        "property float x\nproperty float y\nproperty float z\nproperty int kind\n",
        n,
    );
    for i in 0..n {
        for v in [i as f32, 0.0, 0.0] {
            bin.extend(v.to_le_bytes());
        }
        bin.extend(5i32.to_le_bytes());
    }
    let spec = SphereFileSpec {
        radius: Some(1.0),
        color_by: Some(crate::format::ColorBySpec::Types {
            column: "kind".into(),
            colors: [("1".to_string(), (1.0, 0.0, 0.0))].into(),
        }),
        ..SphereFileSpec::default()
    };
    let mut out = Vec::new();
    let len = bin.len() as u64;
    let listing = listed(&mut out, |out, listing| {
        ply_body::ply_from(
            &bin[..],
            len,
            &spec,
            out,
            &|_, s: &SphereSpec| s.clone(),
            listing,
        )
    });
    assert_eq!(out.len(), n);
    let p = problems(listing);
    assert_eq!(p.len(), PROBLEMS_SHOWN);
    for (k, (i, at, m)) in p[..PROBLEMS_SHOWN - 1].iter().enumerate() {
        assert_eq!((*i, *at), (k, Some(Location::Vertex(k))));
        assert_eq!(
            m,
            "column 4 (kind): type \"5\" is not in color_by's colors (\"1\"): add it"
        );
    }
    let more = n - (PROBLEMS_SHOWN - 1);
    assert_eq!(
        p[PROBLEMS_SHOWN - 1].2,
        format!("and {more} more row(s) that cannot be read")
    );
}

/// A sink that takes every block of plain rows, keeping them; or (`take` false) none, so the
/// rows go through `make`.
struct Plain {
    rows: Vec<PlainSphere>,
    specs: Vec<SphereSpec>,
    take: bool,
    blocks: usize,
}

impl Sink<SphereSpec> for Plain {
    fn count(&self) -> usize {
        self.rows.len() + self.specs.len()
    }

    fn room(&mut self, _: usize) {}

    fn put(&mut self, item: SphereSpec) {
        self.specs.push(item);
    }

    fn put_all(&mut self, items: impl IndexedParallelIterator<Item = SphereSpec>) {
        self.specs.par_extend(items);
    }

    fn put_plain(&mut self, count: usize, row: impl Fn(usize) -> PlainSphere + Sync) -> bool {
        self.blocks += 1;
        if self.take {
            self.rows.extend((0..count).map(row));
        }
        self.take
    }
}

/// The bits of a spec's numbers: NaN's too.
fn spec_bits(s: &SphereSpec) -> [u64; 7] {
    let (x, y, z) = s.center;
    let (r, g, b) = s.color.expect("a colour");
    [x, y, z, s.radius, r, g, b].map(f64::to_bits)
}

/// A binary PLY of f32 x, y, z and radius and byte colours (among other columns, read past)
/// hands its vertices as plain rows, a block at a time, each row's spec the very spec (to the
/// bit, NaN, −0, subnormals and the largest f32 among them) that the same vertex gives through
/// the columns' rules; any other type or rule hands none.
#[test]
fn float_ply_vertices_are_plain_rows_of_the_same_specs() {
    let props = "property float x\nproperty float y\nproperty int id\nproperty float z\nproperty float radius\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n";
    let stride = 4 * 5 + 3;
    let n = 2 * BLOCK_BYTES / stride + 777;
    let odd = [
        0.0,
        -0.0,
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        f32::MAX,
        -f32::MAX,
        f32::NAN,
        f32::INFINITY,
        1.0e-3,
        -7.25,
    ];
    let mut rng = crate::splitmix::SplitMix(0x9_1a1e);
    let mut body = header("binary_little_endian", props, n);
    for i in 0..n {
        let mut f = [0.0f32; 4].map(|_| (rng.unit() * 200.0 - 100.0) as f32);
        f[3] = f[3].abs();
        if i % 97 == 0 {
            f[i / 97 % 4] = odd[i / 97 % odd.len()];
        }
        let [x, y, z, r] = f;
        for v in [x, y] {
            body.extend(v.to_le_bytes());
        }
        body.extend((i as i32).to_le_bytes());
        for v in [z, r] {
            body.extend(v.to_le_bytes());
        }
        body.extend([0, 1, 2].map(|_| (rng.unit() * 256.0) as u8));
    }
    let read = |take: bool| {
        let mut out = Plain {
            rows: Vec::new(),
            specs: Vec::new(),
            take,
            blocks: 0,
        };
        let len = body.len() as u64;
        let spec = SphereFileSpec::default();
        let make = |_: usize, s: &SphereSpec| s.clone();
        let listing = listed(&mut out, |out, listing| {
            ply_body::ply_from(&body[..], len, &spec, out, &make, listing)
        });
        assert!(listing.problems.is_empty(), "{:?}", listing.problems);
        out
    };
    let (plain, made) = (read(true), read(false));
    assert_eq!((plain.blocks, made.blocks), (3, 3), "a block at a time");
    assert_eq!((plain.rows.len(), plain.specs.len()), (n, 0));
    assert_eq!(made.specs.len(), n);
    for (i, (row, spec)) in plain.rows.iter().zip(&made.specs).enumerate() {
        assert_eq!(spec_bits(&row.spec()), spec_bits(spec), "vertex {i}");
    }
    // Not plain: a double, colours in floats, a rule for the radius; and (the control) the
    // same columns as above.
    let others = [
        (
            props.replace("float z", "double z"),
            SphereFileSpec::default(),
            0,
        ),
        (
            props.replace("uchar", "float"),
            SphereFileSpec::default(),
            0,
        ),
        (
            props.to_string(),
            SphereFileSpec {
                radius_by: Some(crate::format::RadiusBySpec::Range {
                    column: "id".into(),
                    range: (0.0, 10.0),
                    radii: (1.0, 2.0),
                }),
                ..SphereFileSpec::default()
            },
            0,
        ),
        (props.to_string(), SphereFileSpec::default(), 1),
    ];
    for (props, spec, blocks) in others {
        let mut body = header("binary_little_endian", &props, 5);
        for i in 0..5u8 {
            for line in props.lines() {
                match line.split(' ').nth(1) {
                    Some("float") => body.extend((f32::from(i) + 1.0).to_le_bytes()),
                    Some("double") => body.extend((f64::from(i) + 1.0).to_le_bytes()),
                    Some("int") => body.extend(i32::from(i).to_le_bytes()),
                    _ => body.push(i),
                }
            }
        }
        let mut out = Plain {
            rows: Vec::new(),
            specs: Vec::new(),
            take: true,
            blocks: 0,
        };
        let len = body.len() as u64;
        let make = |_: usize, s: &SphereSpec| s.clone();
        let listing = listed(&mut out, |out, listing| {
            ply_body::ply_from(&body[..], len, &spec, out, &make, listing)
        });
        assert!(
            listing.problems.is_empty(),
            "{props}: {:?}",
            listing.problems
        );
        assert_eq!((out.blocks, out.count()), (blocks, 5), "{props}");
    }
}
