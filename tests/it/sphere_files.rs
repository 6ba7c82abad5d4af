//! Sphere files: the same spheres inline, as ASCII PLY, binary PLY, CSV and XYZ in the forms
//! tools write (columns in any order, other names, extra columns, no radius, rules for a
//! radius and a colour) hash alike; `check` counts each file's spheres and names the columns
//! it reads past; editing a sphere file renders its frames again. (Bad files are
//! data cases in tests/data/bad, run by `cli::bad_input_cases_are_refused_with_their_messages`.)

use std::fmt::Write as _;
use std::path::Path;

use crate::common::{campath, stderr, stdout};
use campath::internals::SplitMix;

/// A sphere: centre, radius and colour as bytes (0–255).
type S = ([f64; 3], f64, [u8; 3]);

fn spheres(n: usize) -> Vec<S> {
    let mut rng = SplitMix(0x5F11E5);
    (0..n)
        .map(|_| {
            let c = [
                (rng.unit() - 0.5) * 8.0,
                rng.unit() * 2.0,
                (rng.unit() - 0.5) * 8.0,
            ];
            let rgb = [0, 1, 2].map(|_| (rng.unit() * 255.0) as u8);
            (c, 0.1 + 0.5 * rng.unit(), rgb)
        })
        .collect()
}

/// The shot with `inline` sphere lines and these sphere files.
fn shot(inline: &str, files: &[&str]) -> String {
    let files: Vec<String> = files.iter().map(|f| format!("{f:?}")).collect();
    format!(
        "(frames: 3, fps: 3.0, image: (width: 64, height: 36),
    camera: (vrp: (0.0, 3.0, -9.0), tp: (0.0, 0.5, 0.0)),
    animate: [Observer(keys: [(t: 0.0, value: (0.0, 3.0, -9.0)), (t: 1.0, value: (4.0, 3.0, -8.0))])],
    scene: (lights: [(direction: (-1.0, -2.0, 1.0))], spheres: [{inline}], sphere_files: [{}]))",
        files.join(", ")
    )
}

/// A colour byte as RON writes the same value: k/255, printed to round-trip.
fn unit(k: u8) -> f64 {
    f64::from(k) / 255.0
}

fn ron_line(s: &S) -> String {
    let ([x, y, z], r, [cr, cg, cb]) = *s;
    format!(
        "(center: ({x:?}, {y:?}, {z:?}), radius: {r:?}, color: ({:?}, {:?}, {:?})),",
        unit(cr),
        unit(cg),
        unit(cb)
    )
}

fn ply_header(format: &str, n: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment campath test\nelement vertex {n}\nproperty double x\nproperty double y\nproperty double z\nproperty double radius\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

fn write_files(dir: &Path, all: &[S]) {
    let mut ascii = ply_header("ascii", all.len());
    let mut binary = ply_header("binary_little_endian", all.len()).into_bytes();
    let mut csv = String::from("x,y,z,radius,r,g,b\n");
    for s in all {
        let ([x, y, z], r, [cr, cg, cb]) = *s;
        let _ = writeln!(ascii, "{x:?} {y:?} {z:?} {r:?} {cr} {cg} {cb}");
        for v in [x, y, z, r] {
            binary.extend(v.to_le_bytes());
        }
        binary.extend([cr, cg, cb]);
        let _ = writeln!(
            csv,
            "{x:?},{y:?},{z:?},{r:?},{:?},{:?},{:?}",
            unit(cr),
            unit(cg),
            unit(cb)
        );
    }
    std::fs::create_dir_all(dir.join("clouds")).unwrap();
    std::fs::write(dir.join("clouds/a.ply"), ascii).unwrap();
    std::fs::write(dir.join("clouds/b.ply"), binary).unwrap();
    std::fs::write(dir.join("clouds/c.csv"), csv).unwrap();
}

fn hash(dir: &Path, file: &str) -> String {
    let o = campath(dir, &["hash", file], &[]);
    assert!(o.status.success(), "{file}: {}", stderr(&o));
    stdout(&o)
}

#[test]
fn ply_and_csv_spheres_hash_like_the_same_spheres_inline() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let all = spheres(60);
    write_files(t, &all);
    let lines: String = all.iter().map(ron_line).collect();
    std::fs::write(t.join("inline.ron"), shot(&lines, &[])).unwrap();
    let want = hash(t, "inline.ron");
    for file in ["clouds/a.ply", "clouds/b.ply", "clouds/c.csv"] {
        std::fs::write(t.join("f.ron"), shot("", &[file])).unwrap();
        assert_eq!(hash(t, "f.ron"), want, "{file}");
    }
    // Files follow the inline spheres, in the order listed: the first 20 inline, the rest
    // from the files (the files hold all 60; the scene is 20 + 60 + 60 spheres).
    let first: String = all[..20].iter().map(ron_line).collect();
    let mixed_inline = format!("{first}{lines}{lines}");
    std::fs::write(t.join("m1.ron"), shot(&mixed_inline, &[])).unwrap();
    std::fs::write(
        t.join("m2.ron"),
        shot(&first, &["clouds/b.ply", "clouds/c.csv"]),
    )
    .unwrap();
    assert_eq!(hash(t, "m1.ron"), hash(t, "m2.ron"));
    // Paths are relative to the keyframe file, not the working folder.
    std::fs::create_dir(t.join("elsewhere")).unwrap();
    let o = campath(&t.join("elsewhere"), &["check", "../m2.ron"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("clouds/b.ply: 60 sphere(s)")
            && stdout(&o).contains("clouds/c.csv: 60 sphere(s)"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn editing_a_sphere_file_renders_its_frames_again() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let mut all = spheres(10);
    write_files(t, &all);
    std::fs::write(t.join("s.ron"), shot("", &["clouds/c.csv"])).unwrap();
    let render = || {
        let o = campath(t, &["render", "s.ron", "--out", "out"], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        stdout(&o)
    };
    let first = render();
    assert!(first.contains("rendered 3 frame(s)"), "{first}");
    let again = render();
    assert!(
        again.contains("rendered 0 frame(s)") && again.contains("3 kept"),
        "{again}"
    );
    // One sphere turns white in the CSV: every frame is rendered again, to the new hashes.
    all[0].2 = [255, 255, 255];
    write_files(t, &all);
    let edited = render();
    assert!(edited.contains("rendered 3 frame(s)"), "{edited}");
    let manifest = std::fs::read_to_string(t.join("out/hashes.txt")).unwrap();
    let listed: String = crate::common::frame_lines(&manifest)
        .iter()
        .map(|l| l.split(' ').take(2).collect::<Vec<_>>().join(" ") + "\n")
        .collect();
    assert_eq!(listed, hash(t, "s.ron"));
}

/// A binary body of several blocks, read on the pool: its bad vertices are named, each once,
/// in file order, however the blocks fall; a body that also ends early names only the cut.
#[test]
fn bad_vertices_across_binary_blocks_are_named_in_file_order() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    // Three blocks of vertices of 4 doubles and 3 bytes.
    let n = 2 * campath::internals::BLOCK_BYTES / 35 + 1000;
    let mut all = spheres(n);
    all[7].1 = 0.0;
    all[n / 2].0[0] = f64::NAN;
    all[n - 2].1 = -0.5;
    write_files(t, &all);
    std::fs::write(t.join("b.ron"), shot("", &["clouds/b.ply"])).unwrap();
    let o = campath(t, &["check", "b.ron"], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let named: Vec<&str> = err.lines().filter(|l| l.contains(": vertex ")).collect();
    assert_eq!(named.len(), 3, "{err}");
    for (line, want) in named.iter().zip([
        "scene.sphere_files[0] (clouds/b.ply: vertex 7): radius: must be greater than 0, got 0".to_string(),
        format!(
            "scene.sphere_files[0] (clouds/b.ply: vertex {}): center: must be finite numbers within ±1e150, got (NaN, ",
            n / 2
        ),
        format!(
            "scene.sphere_files[0] (clouds/b.ply: vertex {}): radius: must be greater than 0, got -0.5",
            n - 2
        ),
    ]) {
        assert!(line.trim_start().starts_with(&want), "{want:?} in:\n{err}");
    }
    // Cut inside the last vertex: the spheres before the cut are named, then the cut.
    let bytes = std::fs::read(t.join("clouds/b.ply")).unwrap();
    std::fs::write(t.join("clouds/b.ply"), &bytes[..bytes.len() - 1]).unwrap();
    let o = campath(t, &["check", "b.ron"], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let want = format!(
        "scene.sphere_files[0] (clouds/b.ply: vertex {}): truncated: the body ends inside vertex {} of the header's {n}",
        n - 1,
        n - 1
    );
    let named: Vec<&str> = err.lines().filter(|l| l.contains("vertex ")).collect();
    assert_eq!(named.len(), 4, "{err}");
    assert!(named[0].contains(": vertex 7): radius"), "{err}");
    assert!(named[3].contains(&want), "{want:?} in:\n{err}");
}

/// A float PLY (f32 centres and radii, byte colours: its blocks of good vertices are packed
/// as they are read) hashes as the same values written as doubles, and its bad vertices are
/// named as theirs are, in file order, wherever the blocks fall.
#[test]
fn a_float_ply_reads_as_the_same_values_in_doubles() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    // Three blocks of vertices of 4 floats and 3 bytes.
    let n = 2 * campath::internals::BLOCK_BYTES / 19 + 1000;
    let narrow = |v: f64| f64::from(v as f32);
    let mut all: Vec<S> = (spheres(n).into_iter())
        .map(|(c, r, rgb)| (c.map(narrow), narrow(r), rgb))
        .collect();
    let write = |all: &[S]| {
        let floats =
            "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
        let header = ply_header("binary_little_endian", all.len());
        let mut binary = header
            .replace(
                "property double x\nproperty double y\nproperty double z\nproperty double radius\n",
                floats,
            )
            .into_bytes();
        for s in all {
            let ([x, y, z], r, rgb) = *s;
            for v in [x, y, z, r] {
                binary.extend((v as f32).to_le_bytes());
            }
            binary.extend(rgb);
        }
        write_files(&t.join("doubles"), all);
        std::fs::create_dir_all(t.join("floats/clouds")).unwrap();
        std::fs::write(t.join("floats/clouds/b.ply"), binary).unwrap();
        for side in ["doubles", "floats"] {
            std::fs::write(t.join(side).join("b.ron"), shot("", &["clouds/b.ply"])).unwrap();
        }
    };
    write(&all);
    let floats = hash(&t.join("floats"), "b.ron");
    assert_eq!(floats, hash(&t.join("doubles"), "b.ron"));
    // The spheres moved by a third of a pixel hash otherwise: the comparison can fail.
    let mut off = all.clone();
    for s in &mut off {
        s.0[0] += 0.05;
    }
    write_files(&t.join("doubles"), &off);
    assert_ne!(floats, hash(&t.join("doubles"), "b.ron"));
    all[7].1 = 0.0;
    all[n / 2].0[0] = f64::NAN;
    all[n / 2 + 1].0[2] = f64::INFINITY;
    all[n - 2].1 = -0.5;
    write(&all);
    let named = |side: &str| {
        let o = campath(&t.join(side), &["check", "b.ron"], &[]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        let err = stderr(&o);
        let lines: Vec<String> = (err.lines())
            .filter(|l| l.contains(": vertex "))
            .map(str::to_string)
            .collect();
        lines
    };
    let want = named("doubles");
    assert_eq!(want.len(), 4, "{want:?}");
    assert_eq!(named("floats"), want);
}

/// Every problem of a file is named, in file order: rows that cannot be read do not hide the
/// problems before or after them, in CSV and in ASCII PLY (whose vertices keep their numbers).
#[test]
fn rows_that_cannot_be_read_hide_no_other_problem() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::write(
        t.join("a.csv"),
        "x,y,z,radius\n0,0,0,-1\n0,0,0,1\nfoo,0,0,1\n0,0,0,-2\n0,0\n",
    )
    .unwrap();
    std::fs::write(
        t.join("b.ply"),
        "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n\
         property float z\nproperty float radius\nend_header\n0 0 0 -1\n0 0 0 1\n0 0 zz 1\n\
         0 0 0 -3\n0 0\n",
    )
    .unwrap();
    std::fs::write(t.join("k.ron"), shot("", &["a.csv", "b.ply"])).unwrap();
    let o = campath(t, &["check", "k.ron"], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let named: Vec<String> = err
        .lines()
        .filter(|l| l.contains(".csv") || l.contains(".ply"))
        .map(|l| l.trim().to_string())
        .collect();
    let want = [
        "scene.sphere_files[0] (a.csv: line 2): radius: must be greater than 0, got -1",
        "scene.sphere_files[0] (a.csv: line 4): column 1 (x): not a number: \"foo\"",
        "scene.sphere_files[0] (a.csv: line 5): radius: must be greater than 0, got -2",
        "scene.sphere_files[0] (a.csv: line 6): expected 4 fields (x,y,z,radius), got 2",
        "scene.sphere_files[1] (b.ply: vertex 0): radius: must be greater than 0, got -1",
        "scene.sphere_files[1] (b.ply: line 11): vertex 2: z: not a number: \"zz\"",
        "scene.sphere_files[1] (b.ply: vertex 3): radius: must be greater than 0, got -3",
        "scene.sphere_files[1] (b.ply: line 13): vertex 4: a short row: no value for z",
    ];
    assert_eq!(named.len(), want.len(), "{err}");
    for (line, want) in named.iter().zip(want) {
        assert!(line.starts_with(want), "{want:?} in:\n{err}");
    }
}

/// A file of many bad spheres: the message names the first hundred, in file order, and
/// counts the rest, not a line for each.
#[test]
fn many_bad_spheres_are_named_first_and_counted() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let mut csv = String::from("x,y,z,radius\n");
    for i in 0..250 {
        writeln!(csv, "{i},0,0,-1").unwrap();
    }
    std::fs::write(t.join("bad.csv"), csv).unwrap();
    std::fs::write(t.join("b.ron"), shot("", &["bad.csv"])).unwrap();
    let o = campath(t, &["check", "b.ron"], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("250 problem(s)"), "{err}");
    let named: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("bad.csv: line "))
        .collect();
    assert_eq!(named.len(), campath::internals::PROBLEMS_SHOWN, "{err}");
    assert!(named[0].contains("bad.csv: line 2): radius"), "{err}");
    assert!(named[99].contains("bad.csv: line 101): radius"), "{err}");
    assert!(err.trim_end().ends_with("… and 150 more"), "{err}");
}

/// The shot with `inline` sphere lines and `entries` as `sphere_files`' text.
fn shot_with(inline: &str, entries: &str) -> String {
    let lines = shot(inline, &[]);
    lines.replace("sphere_files: []", &format!("sphere_files: [{entries}]"))
}

/// A sphere's RON line with this radius and colour (None: white).
fn ron_sphere(c: [f64; 3], r: f64, color: Option<[f64; 3]>) -> String {
    let [x, y, z] = c;
    let color = color.map_or(String::new(), |[a, b, c]| {
        format!(", color: ({a:?}, {b:?}, {c:?})")
    });
    format!("(center: ({x:?}, {y:?}, {z:?}), radius: {r:?}{color}),")
}

/// An 8-bit sRGB level as linear light, by the sRGB standard's formula.
fn srgb_linear(k: u8) -> f64 {
    let c = f64::from(k) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        // libm's pow, as campath's (the standard library's may round its last bit otherwise).
        libm::pow((c + 0.055) / 1.055, 2.4)
    }
}

#[test]
fn every_form_tools_write_hashes_like_the_same_spheres_inline() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let all = spheres(40);
    let colour = |s: &S| Some(s.2.map(unit));
    let inline = |line: &dyn Fn(&S) -> String| -> String {
        let lines: String = all.iter().map(line).collect();
        std::fs::write(t.join("inline.ron"), shot(&lines, &[])).unwrap();
        hash(t, "inline.ron")
    };
    let mut cases: Vec<(&str, String, String)> = Vec::new();
    let file = |name: &str, text: Vec<u8>| std::fs::write(t.join(name), text).unwrap();

    // CSV with other names, extra columns, columns in any order, quotes and a comment mark.
    let rows = |f: &dyn Fn(&S) -> String| -> String { all.iter().map(f).collect() };
    let csv_full = |s: &S| {
        let ([x, y, z], r, c) = *s;
        let [a, b, cc] = c.map(unit);
        format!("{x:?},{y:?},{z:?},{r:?},{a:?},{b:?},{cc:?}\n")
    };
    file(
        "long.csv",
        format!("x,y,z,radius,red,green,blue\n{}", rows(&csv_full)).into_bytes(),
    );
    let with_id = |s: &S| format!("{},7\n", csv_full(s).trim_end());
    file(
        "id.csv",
        format!("x,y,z,radius,r,g,b,id\n{}", rows(&with_id)).into_bytes(),
    );
    let shuffled = |s: &S| {
        let ([x, y, z], r, c) = *s;
        let [a, b, cc] = c.map(unit);
        format!("3,\"{cc:?}\",{x:?},{r:?},{z:?},{y:?},{b:?},{a:?},\"a, note\"\n")
    };
    file(
        "shuffled.csv",
        format!("//\"id\",\"B\",x,Radius,Z,y,G,R,note\n{}", rows(&shuffled)).into_bytes(),
    );
    let mapped = |s: &S| csv_full(s);
    file(
        "mapped.csv",
        format!("PosX,PosY,PosZ,Size,cr,cg,cb\n{}", rows(&mapped)).into_bytes(),
    );
    let full = inline(&|s: &S| ron_sphere(s.0, s.1, colour(s)));
    cases.push(("long.csv", "\"long.csv\"".into(), full.clone()));
    cases.push(("id.csv", "\"id.csv\"".into(), full.clone()));
    cases.push(("shuffled.csv", "\"shuffled.csv\"".into(), full.clone()));
    cases.push((
        "mapped.csv",
        "(path: \"mapped.csv\", columns: (x: \"posx\", y: \"POSY\", z: \"PosZ\", radius: \"Size\", red: \"cr\", green: \"cg\", blue: \"cb\"))".into(),
        full.clone(),
    ));

    // `X,Y,Z,R`: R is the radius; white.
    let xyzr = |s: &S| {
        let ([x, y, z], r, _) = *s;
        format!("{x:?},{y:?},{z:?},{r:?}\n")
    };
    file(
        "upper.csv",
        format!("X,Y,Z,R\n{}", rows(&xyzr)).into_bytes(),
    );
    let white = inline(&|s: &S| ron_sphere(s.0, s.1, None));
    cases.push(("upper.csv", "\"upper.csv\"".into(), white));

    // `x,y,z`: the entry's radius and colour.
    let xyz = |s: &S| {
        let [x, y, z] = s.0;
        format!("{x:?},{y:?},{z:?}\n")
    };
    file("points.csv", format!("x,y,z\n{}", rows(&xyz)).into_bytes());
    let given = inline(&|s: &S| ron_sphere(s.0, 0.25, Some([0.5, 0.25, 1.0])));
    cases.push((
        "points.csv",
        "(path: \"points.csv\", radius: 0.25, color: (0.5, 0.25, 1.0))".into(),
        given,
    ));

    // PLY without a radius: binary with doubles and byte colours, and ASCII floats alone (a
    // float is the f32 nearest the text, as a binary file holds it).
    let mut bin = format!("ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty int id\nend_header\n", all.len()).into_bytes();
    let mut ascii = format!("ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n", all.len());
    for s in &all {
        for v in s.0 {
            bin.extend(v.to_le_bytes());
        }
        bin.extend(s.2);
        bin.extend(9i32.to_le_bytes());
        let [x, y, z] = s.0.map(|v| v as f32);
        ascii.push_str(&format!("{x} {y} {z}\n"));
    }
    file("norad.ply", bin);
    file("cloud.ply", ascii.into_bytes());
    let bin_want = inline(&|s: &S| ron_sphere(s.0, 0.25, colour(s)));
    cases.push((
        "norad.ply",
        "(path: \"norad.ply\", radius: 0.25)".into(),
        bin_want,
    ));
    let f32s = inline(&|s: &S| ron_sphere(s.0.map(|v| f64::from(v as f32)), 0.1, None));
    cases.push((
        "cloud.ply",
        "(path: \"cloud.ply\", radius: 0.1)".into(),
        f32s,
    ));

    // Extended XYZ with a radius and colours, and plain XYZ by species.
    let mut ext = format!(
        "{}\nLattice=\"10 0 0 0 10 0 0 0 10\" Properties=species:S:1:pos:R:3:radius:R:1:color:R:3:id:I:1 pbc=\"T T T\"\n",
        all.len()
    );
    let mut plain = format!("{}\nwater, plain\n", all.len());
    for (k, s) in all.iter().enumerate() {
        let ([x, y, z], r, c) = *s;
        let [a, b, cc] = c.map(unit);
        ext.push_str(&format!(
            "C {x:?} {y:?}\t{z:?} {r:?} {a:?} {b:?} {cc:?} {k}\n"
        ));
        let species = ["O", "H", "H"][k % 3];
        plain.push_str(&format!("{species} {x:?} {y:?} {z:?}\n"));
    }
    file("ext.xyz", ext.into_bytes());
    file("plain.xyz", plain.into_bytes());
    cases.push(("ext.xyz", "\"ext.xyz\"".into(), full.clone()));
    let by_species = inline(&|s: &S| {
        let k = all.iter().position(|o| o == s).unwrap();
        match k % 3 {
            0 => ron_sphere(s.0, 0.6, Some([0.9, 0.1, 0.1])),
            _ => ron_sphere(s.0, 0.3, Some([1.0, 1.0, 1.0])),
        }
    });
    cases.push((
        "plain.xyz",
        "(path: \"plain.xyz\", radius_by: Types(column: \"species\", radii: {\"O\": 0.6, \"H\": 0.3}), color_by: Types(column: \"SPECIES\", colors: {\"O\": (0.9, 0.1, 0.1), \"H\": (1.0, 1.0, 1.0)}))".into(),
        by_species,
    ));

    // A colormap's ends (viridis: #440154 and #fde725), and values past them held there; a
    // radius over a range.
    let ends = |s: &S| {
        let ([x, y, z], r, _) = *s;
        let speed = if s.2[0] < 128 { -1.0 - r } else { 2.0 + r };
        format!("{x:?},{y:?},{z:?},{speed:?},{r:?}\n")
    };
    file(
        "speed.csv",
        format!("x,y,z,speed,mass\n{}", rows(&ends)).into_bytes(),
    );
    let viridis = inline(&|s: &S| {
        let rgb = match s.2[0] < 128 {
            true => [0x44, 0x01, 0x54],
            false => [0xfd, 0xe7, 0x25],
        };
        let t = ((s.1 - 0.1) / (0.6 - 0.1)).clamp(0.0, 1.0);
        let radius = (1.0 - t) * 0.1 + t * 0.3;
        ron_sphere(s.0, radius, Some(rgb.map(srgb_linear)))
    });
    cases.push((
        "speed.csv",
        "(path: \"speed.csv\", color_by: Colormap(column: \"speed\", map: \"viridis\", range: (0.0, 1.0)), radius_by: Range(column: \"mass\", range: (0.1, 0.6), radii: (0.1, 0.3)))".into(),
        viridis,
    ));

    for (name, entry, want) in &cases {
        std::fs::write(t.join("f.ron"), shot_with("", entry)).unwrap();
        assert_eq!(&hash(t, "f.ron"), want, "{name}: {entry}");
    }
    // `check` names the columns each file reads past, once.
    std::fs::write(
        t.join("f.ron"),
        shot_with(
            "",
            "\"shuffled.csv\", (path: \"norad.ply\", radius: 0.25), \"ext.xyz\"",
        ),
    )
    .unwrap();
    let o = campath(t, &["check", "f.ron"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.contains("shuffled.csv: 40 sphere(s) (columns read past: \"id\", \"note\")"),
        "{out}"
    );
    assert!(
        out.contains("norad.ply: 40 sphere(s) (columns read past: \"id\")"),
        "{out}"
    );
    assert!(
        out.contains("ext.xyz: 40 sphere(s) (columns read past: \"species\", \"id\")"),
        "{out}"
    );
}
