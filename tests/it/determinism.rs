//! Frame bytes do not depend on the thread count. (Debug against release: .ci/run runs the
//! golden test in both profiles against the same committed hashes.)

use crate::common::{campath, example, root, stdout};
use campath::frames::hashes;

#[test]
fn same_hashes_with_one_two_and_three_threads_in_process() {
    let mut doc = example("flythrough");
    doc.raster.width = 160;
    doc.raster.height = 90;
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

#[test]
fn same_hashes_with_rayon_num_threads_1_and_default() {
    let file = root().join("animations/distort.ron");
    let file = file.to_str().unwrap();
    let args = ["hash", file, "--frames", "10..12"];
    let one = campath(&root(), &args, &[("RAYON_NUM_THREADS", "1")]);
    let default = campath(&root(), &args, &[]);
    let four = campath(&root(), &args, &[("RAYON_NUM_THREADS", "4")]);
    assert!(one.status.success());
    assert_eq!(stdout(&one).lines().count(), 2);
    assert_eq!(stdout(&one), stdout(&default));
    assert_eq!(stdout(&one), stdout(&four));
}
