//! Frame bytes do not depend on the thread count. (Debug against release: .ci/run runs the
//! golden test in both profiles against the same committed hashes.)

use crate::common::{campath, example, root, stdout};
use campath::frames::hashes;

#[test]
fn same_hashes_with_one_two_and_three_threads_in_process() {
    let doc = example("flythrough").resized(160, 90).unwrap();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| hashes(&doc, 0..4).unwrap())
    };
    let one = run(1);
    assert_eq!(one.len(), 4);
    assert_eq!(run(2), one);
    assert_eq!(run(3), one);
}

/// The distort example at its 640×360 in a release build (`.ci/run` runs this in release on
/// every instruction path); at 320×180, still 45 bands of rows, in a debug build.
#[test]
fn same_hashes_with_rayon_num_threads_1_and_default() {
    let text = std::fs::read_to_string(root().join("animations/distort.ron")).unwrap();
    let size = if cfg!(debug_assertions) {
        "width: 320, height: 180"
    } else {
        "width: 640, height: 360"
    };
    let sized = text.replace("width: 640, height: 360", size);
    assert!(sized.contains(size));
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("distort.ron"), sized).unwrap();
    let args = ["hash", "distort.ron", "--frames", "10..12"];
    let one = campath(tmp.path(), &args, &[("RAYON_NUM_THREADS", "1")]);
    let default = campath(tmp.path(), &args, &[]);
    let four = campath(tmp.path(), &args, &[("RAYON_NUM_THREADS", "4")]);
    assert!(one.status.success());
    assert_eq!(stdout(&one).lines().count(), 2);
    assert_eq!(stdout(&one), stdout(&default));
    assert_eq!(stdout(&one), stdout(&four));
}
