//! Helpers shared by the integration tests.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use campath::document::Document;

/// The examples in animations/, by file stem.
pub const EXAMPLES: [&str; 7] = [
    "observer",
    "look_around",
    "track",
    "zoom",
    "distort",
    "flythrough",
    "dolly_zoom",
];

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Loads `animations/<name>.ron`.
pub fn example(name: &str) -> Document {
    Document::load(&root().join("animations").join(format!("{name}.ron"))).unwrap()
}

/// Checks RON text as if it were the file `test.ron`.
pub fn doc(text: &str) -> Document {
    Document::from_str(Path::new("test.ron"), text).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs the campath binary in `dir` with `args` and optional environment.
pub fn campath(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_campath"));
    cmd.current_dir(dir).args(args);
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("campath runs")
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The frame lines of a manifest: every line but the `#` lines (renderer, part header,
/// `# complete`).
pub fn frame_lines(text: &str) -> Vec<&str> {
    text.lines().filter(|l| !l.starts_with('#')).collect()
}

/// Whether an outside program the test needs is on PATH. When it is missing, `cargo test` skips
/// the check with a printed reason; with `CAMPATH_REQUIRE_TOOLS=1` (set by `.ci/run`) a missing
/// program fails the test instead.
pub fn have_tool(program: &str, package: &str) -> bool {
    let found = Command::new(program)
        .arg("--version")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok();
    if !found {
        let why = format!("{program} is not on PATH (Debian package {package})");
        if std::env::var_os("CAMPATH_REQUIRE_TOOLS").is_some_and(|v| v == "1") {
            panic!("{why}, and CAMPATH_REQUIRE_TOOLS=1 makes this check mandatory");
        }
        // Straight to stderr, past the test harness's capture, so the skip is seen.
        let _ = writeln!(
            std::io::stderr(),
            "skipped: {why}; .ci/run installs it and makes this check mandatory"
        );
    }
    found
}
