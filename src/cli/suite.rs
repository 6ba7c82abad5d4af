//! `campath test [DIR]`: every shot under DIR against its golden, one line per shot and a
//! summary; `--update` approves, `--junit` reports to CI, `--review` writes a page of the
//! differences.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use super::error::{CliError, Result};
use super::failures::{self, difference, golden_pixels};
use super::junit;
use super::review::{self, ReviewFrame, ReviewShot};
use crate::key::VERSION;
use crate::output::{write_png, Compression};
use crate::testing::{golden_dir, Difference, Options, Shot, ShotRun, Verdict};
use crate::Error;

/// The options of `campath test`.
#[derive(clap::Args)]
pub struct TestArgs {
    /// The folder of shots, searched recursively.
    #[arg(default_value = "shots")]
    pub dir: PathBuf,
    /// Approve: write the golden of every shot that differs or has none (its hashes.txt,
    /// and its frames when the golden keeps frames); passing goldens are left untouched.
    #[arg(long)]
    pub update: bool,
    /// With --update, keep every frame's PNG in the goldens it writes (for review pages),
    /// not only hashes.txt.
    #[arg(long, requires = "update")]
    pub keep_frames: bool,
    /// Also write a JUnit XML report: one test suite per shot, one test case per frame.
    #[arg(long, value_name = "PATH")]
    pub junit: Option<PathBuf>,
    /// Write a review page, DIR/index.html, of every failing frame: golden, new and their
    /// difference, with a slider and a flip between golden and new.
    #[arg(long, value_name = "DIR")]
    pub review: Option<PathBuf>,
    /// Shots checked side by side [default: the number of cores]. The bytes do not change.
    #[arg(long, value_parser = super::args::at_least_one)]
    pub jobs: Option<u64>,
}

/// Every `*.ron` under `dir`, recursively, in name order; golden folders and hidden folders are
/// not searched, and a folder reached twice through symbolic links is searched once.
pub fn shots(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut found = Vec::new();
    let mut folders = vec![dir.to_path_buf()];
    let mut seen = std::collections::BTreeSet::new();
    while let Some(folder) = folders.pop() {
        if !seen.insert(folder.canonicalize().map_err(Error::read(&folder))?) {
            continue;
        }
        let entries = std::fs::read_dir(&folder).map_err(Error::read(&folder))?;
        for e in entries.flatten() {
            let path = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if path.is_dir() {
                if !name.starts_with('.') && !name.ends_with(".golden") {
                    folders.push(path);
                }
            } else if name.ends_with(".ron") {
                found.push(path);
            }
        }
    }
    found.sort();
    // A shot reached twice, with one golden (through a linked folder), is one shot; a linked
    // file has a golden of its own beside it, and is checked against it too. Two shots with
    // one golden (goldens linked to one folder) are refused: each would approve over the other.
    let mut goldens: BTreeMap<PathBuf, (PathBuf, PathBuf)> = BTreeMap::new();
    let mut kept = Vec::new();
    for shot in found {
        let golden = crate::output::resolved(&golden_dir(&shot));
        let file = shot.canonicalize().unwrap_or_else(|_| shot.clone());
        match goldens.get(&golden) {
            None => {
                goldens.insert(golden, (shot.clone(), file));
                kept.push(shot);
            }
            Some((_, same)) if *same == file => {}
            Some((first, _)) => {
                return Err(CliError::Usage(format!(
                    "{} and {} have one golden, {}: each shot needs its own",
                    first.display(),
                    shot.display(),
                    golden.display()
                )))
            }
        }
    }
    Ok(kept)
}

/// A shot checked: its run, or why it could not be; and its review pictures.
struct Checked {
    run: std::result::Result<ShotRun, Error>,
    review: Vec<ReviewFrame>,
}

pub fn run(a: TestArgs, out: &mut dyn Write) -> Result<bool> {
    if !a.dir.is_dir() {
        return Err(CliError::Usage(format!(
            "{} is not a folder of shots (every *.ron under it is a shot, its golden the \
             folder NAME.golden beside it)",
            a.dir.display()
        )));
    }
    let shots = shots(&a.dir)?;
    if shots.is_empty() {
        let message = format!("{} holds no *.ron shot", a.dir.display());
        return Err(CliError::Usage(message));
    }
    let goldens: Vec<PathBuf> = shots.iter().map(|s| golden_dir(s)).collect();
    // The review folder is this run's until it ends.
    let _claimed = failures::claim(
        a.junit.as_deref(),
        a.review.as_deref(),
        "--review",
        &goldens,
        review::is_review_file,
    )?;

    // What killed approvals left beside the goldens, cleared a folder at a time (an approval
    // then does not list the folder again for its shot).
    let folders: std::collections::BTreeSet<&Path> =
        shots.iter().filter_map(|s| s.parent()).collect();
    for folder in folders {
        crate::testing::clear_left_approvals(folder);
    }

    // Shots run side by side; their lines are printed in shot order as soon as each is known.
    let next = AtomicUsize::new(0);
    let results: Mutex<BTreeMap<usize, Checked>> = Mutex::new(BTreeMap::new());
    let ready = std::sync::Condvar::new();
    let options = Options {
        update: a.update,
        keep_frames: a.keep_frames,
        swept: true,
    };
    let mut checked = Vec::with_capacity(shots.len());
    let mut printed = Ok(());
    std::thread::scope(|scope| {
        let jobs = a.jobs.map_or_else(
            || std::thread::available_parallelism().map_or(1, usize::from),
            |j| j as usize,
        );
        for _ in 0..jobs.clamp(1, shots.len()) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(shot) = shots.get(i) else { break };
                let c = check(i, shot, options, a.review.as_deref());
                results.lock().expect("no worker panics").insert(i, c);
                ready.notify_all();
            });
        }
        let mut done = results.lock().expect("no worker panics");
        for (i, shot) in shots.iter().enumerate() {
            while !done.contains_key(&i) {
                done = ready.wait(done).expect("no worker panics");
            }
            let c = done.remove(&i).expect("checked");
            let line = match &c.run {
                Ok(run) => format!("{}: {}", shot.display(), run.summary()),
                Err(e) => format!("{}: cannot check: {e}", shot.display()),
            };
            if printed.is_ok() {
                printed = writeln!(out, "{line}").and_then(|()| out.flush());
            }
            checked.push(c);
        }
    });
    printed.map_err(Error::stdout)?;

    // Shots approved by this run count as neither passed nor failing.
    let runs: Vec<&ShotRun> = checked.iter().filter_map(|c| c.run.as_ref().ok()).collect();
    let bad = checked.len() - runs.len();
    let updated = runs.iter().filter(|r| r.updated).count();
    let open = runs.iter().filter(|r| !r.updated);
    let count = |is: &dyn Fn(Verdict) -> bool| open.clone().filter(|r| is(r.verdict())).count();
    let passed = count(&|v| v == Verdict::Passed);
    let no_golden = count(&|v| v == Verdict::NoGolden);
    let differ = runs.len() - updated - passed - no_golden;
    // Goldens of a newer campath: this one never writes them, so approving is no answer.
    let newer = count(&|v| matches!(v, Verdict::OtherRenderer(v) if v > VERSION));
    let ok = differ + no_golden + bad == 0;
    let mut summary = format!(
        "test result: {}. {} shot(s): {passed} passed, {differ} differ, {no_golden} without \
         golden, {bad} could not be checked",
        if ok { "ok" } else { "FAILED" },
        shots.len()
    );
    if updated > 0 {
        summary += &format!("; {updated} golden(s) written");
    } else if a.update && ok {
        summary += "; no golden needed writing";
    } else if !a.update && differ + no_golden > newer {
        summary += &format!(
            "\nIf the changes are intended, approve them with `campath test {} --update`.",
            shell_word(&a.dir.display().to_string())
        );
    }
    if newer > 0 {
        summary += &format!(
            "\n{newer} golden(s) were made by a newer campath: update campath to check them \
             (this one never writes them)."
        );
    }
    writeln!(out, "{summary}").map_err(Error::stdout)?;

    if let Some(path) = &a.junit {
        let suites: Vec<junit::Suite> = shots
            .iter()
            .zip(&checked)
            .map(|(shot, c)| suite(shot, c))
            .collect();
        junit::write(path, "campath test", &suites)?;
    }
    if let Some(dir) = &a.review {
        let shown: Vec<ReviewShot> = shots
            .iter()
            .zip(&mut checked)
            .filter_map(|(shot, c)| {
                let run = c.run.as_ref().ok()?;
                (!run.ok() || run.updated).then(|| ReviewShot {
                    shot: shot.display().to_string(),
                    summary: run.summary(),
                    frames: std::mem::take(&mut c.review),
                })
            })
            .collect();
        let page = review::write(dir, &shown, shots.len())?;
        writeln!(out, "review: {}", page.display()).map_err(Error::stdout)?;
    }
    if bad > 0 {
        return Err(CliError::Usage(format!(
            "{bad} of {} shot(s) could not be checked (see above)",
            shots.len()
        )));
    }
    Ok(differ + no_golden == 0)
}

/// Renders and compares one shot; with a review folder, writes its differing frames' pictures
/// there as they are found.
fn check(index: usize, shot: &Path, options: Options, review: Option<&Path>) -> Checked {
    let mut frames = Vec::new();
    let run = Shot::open(shot, options).and_then(|shot| {
        let size = (shot.doc.raster.width, shot.doc.raster.height);
        let golden_frames = shot.golden_frames.clone();
        shot.run(options, |d: &Difference, pixels| {
            let Some(dir) = review else { return Ok(()) };
            let name = |what: &str| review::file_name(index, d.frame, what);
            let new = name("new");
            write_png(&dir.join(&new), pixels, size, Compression::Fast)?;
            let mut f = ReviewFrame::of(d);
            f.new = Some(new);
            let golden = golden_frames
                .get(&d.frame)
                .and_then(|p| golden_pixels(p, size));
            if let Some(golden) = golden {
                let (image, p) = difference(&golden, pixels);
                let (g, dname) = (name("golden"), name("diff"));
                write_png(&dir.join(&g), &golden, size, Compression::Fast)?;
                write_png(&dir.join(&dname), &image, size, Compression::Fast)?;
                (f.golden, f.diff, f.pixels) = (Some(g), Some(dname), Some(p));
            }
            frames.push(f);
            Ok(())
        })
    });
    if let Ok(run) = &run {
        // Golden frames past the animation's end: listed, with nothing rendered.
        let past = run.differ.iter().filter(|d| d.actual.is_none());
        frames.extend(past.map(ReviewFrame::of));
    }
    let review = frames;
    Checked { run, review }
}

/// A shot's JUnit suite: one case per frame of the animation or the golden.
fn suite(shot: &Path, c: &Checked) -> junit::Suite {
    let name = shot.display().to_string();
    let run = match &c.run {
        Ok(run) => run,
        Err(e) => return junit::Suite::errored(&name, &e.to_string()),
    };
    let mut s = junit::Suite::new(&name);
    // An approved shot passes: its golden now holds the shot's frames, and only those; else
    // the golden may list frames past the shot's.
    let open = !run.updated;
    let differ: BTreeMap<u64, &Difference> = (run.differ.iter().filter(|_| open))
        .map(|d| (d.frame, d))
        .collect();
    let stale = run.stale.iter().filter(|_| open);
    let stale: std::collections::BTreeSet<u64> = stale.copied().collect();
    let golden = run.golden.iter().filter(|_| open);
    let past = golden.flat_map(|g| g.hashes.range(run.frames..).map(|(&f, _)| f));
    for frame in (0..run.frames).chain(past) {
        let stale_picture = stale.contains(&frame).then(|| {
            "the golden's picture of this frame is missing or not the picture of its hash"
                .to_string()
        });
        let failure = differ.get(&frame).map(|d| match (&d.expected, &d.actual) {
            (_, None) => format!(
                "in the golden, but the animation has only {} frames",
                run.frames
            ),
            (None, Some(_)) if run.golden.is_none() => "no golden".to_string(),
            (None, Some(got)) => format!("not in the golden; got {got}"),
            (Some(want), Some(got)) => format!("expected {want}, got {got}"),
        });
        s.case(&format!("frame {frame}"), failure.or(stale_picture));
    }
    s
}

/// The path `word` as one word of a POSIX shell command that campath reads as a path: as it is
/// when it holds only characters no shell treats specially, else in single quotes (a `'` inside
/// as `'\''`); after `./` when it starts with `-`, which would read as an option. So a printed
/// command can be pasted.
fn shell_word(word: &str) -> String {
    let word = match word.starts_with('-') {
        true => format!("./{word}"),
        false => word.to_string(),
    };
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-./+:=,@%".contains(c);
    if !word.is_empty() && word.chars().all(plain) {
        return word;
    }
    format!("'{}'", word.replace('\'', "'\\''"))
}

#[cfg(test)]
mod tests {
    use super::shell_word;

    #[test]
    fn printed_paths_are_one_shell_word() {
        assert_eq!(shell_word("shots/a-b_c.d"), "shots/a-b_c.d");
        assert_eq!(shell_word("my shots"), "'my shots'");
        assert_eq!(shell_word("ünï cødé"), "'ünï cødé'");
        assert_eq!(shell_word("it's"), "'it'\\''s'");
        assert_eq!(shell_word(""), "''");
        assert_eq!(shell_word("-shots"), "./-shots");
    }
}
