//! Golden frame hashes for every example in animations/: the first, middle and last frame of
//! each, rendered at 96×54 so the test stays fast, with the file's own samples
//! (`<name>.txt`, cast one ray at a time) and with one sample per pixel (`<name>.1spp.txt`,
//! cast in packets).
//!
//! A difference leaves the fresh hashes in `tests/golden/NAME.txt.new` (as
//! `campath::testing::assert_hashes` does). After an intended change of the pictures,
//! `CAMPATH_UPDATE=always cargo test --test it golden::` rewrites them; look at the frames, and
//! commit tests/golden/.
//! New pictures need a new renderer version (`campath::RENDERER_VERSION`, recorded in
//! tests/golden/render_version.txt), so that frames rendered by an older campath are never kept
//! as current: the update refuses changed hashes under the recorded version.

use crate::common::{example, root, EXAMPLES};
use campath::frame_hash;
use campath::frames::{for_each_frame, FrameSet};
use campath::internals::parse_hashes;
use campath::testing::{assert_hashes, Update};
use campath::RENDERER_VERSION as VERSION;

fn hashes(name: &str, one_sample: bool) -> Vec<(u64, campath::FrameHash)> {
    let mut doc = example(name).resized(96, 54).unwrap();
    if one_sample {
        let raster = campath::raster::Raster {
            samples: 1,
            ..*doc.raster()
        };
        doc = doc.with_raster(raster).unwrap();
    }
    let last = doc.animation().frames - 1;
    let mut out = Vec::new();
    for k in [0, last / 2, last] {
        for_each_frame(
            &doc,
            &FrameSet::all(k..k + 1),
            |_| false,
            |frame, _, pixels, hash| {
                // The hash streamed row by row is the hash of the finished frame.
                assert_eq!(hash, frame_hash(pixels), "frame {frame}");
                out.push((frame, hash));
                Ok(())
            },
        )
        .unwrap();
    }
    out
}

#[test]
fn examples_match_their_golden_hashes() {
    let (update, _) = Update::from_env().unwrap();
    let version_path = root().join("tests/golden/render_version.txt");
    let recorded: u32 = std::fs::read_to_string(&version_path)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let mut failures = Vec::new();
    let files = EXAMPLES
        .iter()
        .flat_map(|name| [(*name, ".txt", false), (*name, ".1spp.txt", true)]);
    for (name, suffix, one_sample) in files {
        let path = root().join(format!("tests/golden/{name}{suffix}"));
        let got = hashes(name, one_sample);
        if update == Update::Always {
            let old = std::fs::read_to_string(&path).unwrap_or_default();
            let old = parse_hashes(&path, &old).unwrap();
            assert!(
                old.is_empty() || old == got || recorded < VERSION,
                "{name}: the pictures changed under renderer version {recorded}: \
                 bump campath::RENDERER_VERSION, then update again"
            );
        }
        // Every example is compared before any failure is reported.
        let checked = std::panic::catch_unwind(|| assert_hashes(&path, &got));
        if let Err(e) = checked {
            let message = e.downcast_ref::<String>().cloned().unwrap_or_default();
            failures.push(format!("{name}{suffix}: {message}"));
        }
    }
    if update == Update::Always {
        std::fs::write(&version_path, format!("{VERSION}\n")).unwrap();
    }
    assert_eq!(
        recorded, VERSION,
        "the renderer version changed: CAMPATH_UPDATE=always cargo test --test it golden::"
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
