//! Golden frame hashes for every example in animations/: the first, middle and last frame of
//! each, rendered at 96×54 (the file's own samples) so the test stays fast.
//!
//! Regenerate after an intended change of the pictures with
//! `UPDATE_GOLDEN=1 cargo test --test it golden::`, look at the frames, and commit tests/golden/.
//! New pictures need a new renderer version (`campath::render::key::VERSION`, recorded in
//! tests/golden/render_version.txt), so that frames rendered by an older campath are never kept
//! as current: the update refuses changed hashes under the recorded version.

use crate::common::{example, root, EXAMPLES};
use campath::frames::{for_each_frame, FrameSet};
use campath::manifest::parse_hashes;
use campath::output::frame_hash;
use campath::render::key::VERSION;

fn hashes(name: &str) -> String {
    let mut doc = example(name);
    doc.raster.width = 96;
    doc.raster.height = 54;
    let last = doc.animation.frames - 1;
    let mut out = String::new();
    for k in [0, last / 2, last] {
        for_each_frame(
            &doc,
            &FrameSet::all(k..k + 1),
            |_| false,
            |frame, _, pixels| {
                out += &format!("{frame} {}\n", frame_hash(pixels));
                Ok(())
            },
        )
        .unwrap();
    }
    out
}

#[test]
fn examples_match_their_golden_hashes() {
    let update = std::env::var_os("UPDATE_GOLDEN").is_some();
    let version_path = root().join("tests/golden/render_version.txt");
    let recorded: u32 = std::fs::read_to_string(&version_path)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let mut failures = Vec::new();
    for name in EXAMPLES {
        let path = root().join(format!("tests/golden/{name}.txt"));
        let got = hashes(name);
        if update {
            let old = std::fs::read_to_string(&path).unwrap_or_default();
            assert!(
                old == got || recorded < VERSION,
                "{name}: the pictures changed under renderer version {recorded}: \
                 bump campath::render::key::VERSION, then update again"
            );
            std::fs::write(&path, &got).unwrap();
            std::fs::write(&version_path, format!("{VERSION}\n")).unwrap();
            continue;
        }
        let want = std::fs::read_to_string(&path).unwrap_or_else(|_| {
            panic!(
                "{} is missing: run UPDATE_GOLDEN=1 cargo test --test it golden::",
                path.display()
            )
        });
        let want = parse_hashes(&path, &want).unwrap();
        let got = parse_hashes(&path, &got).unwrap();
        for (w, g) in want.iter().zip(&got) {
            if w != g {
                failures.push(format!("{name} frame {}: golden {} got {}", w.0, w.1, g.1));
            }
        }
        assert_eq!(want.len(), got.len(), "{name}: frame list changed");
    }
    assert_eq!(
        recorded, VERSION,
        "the renderer version changed: UPDATE_GOLDEN=1 cargo test --test it golden::"
    );
    assert!(
        failures.is_empty(),
        "frames differ from tests/golden (UPDATE_GOLDEN=1 to accept):\n{}",
        failures.join("\n")
    );
}
