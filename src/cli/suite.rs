//! `campath test [DIR]`: every shot under DIR against its golden, one line per shot and a
//! summary. A failing shot leaves a pending golden for `campath review` (or, with `--update`,
//! is approved); `--junit` reports to CI, `--review` writes a page of the differences, and
//! `--unreferenced` finds goldens whose shot is gone.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use super::error::{CliError, Result};
use super::failures;
use super::junit;
use super::review::{self, ReviewFrame, ReviewShot};
use crate::key::VERSION;
use crate::output::{write_png, Compression};
use crate::testing::pictures::{difference, pixels_of};
use crate::testing::{
    golden_dir, shell_word, stem_of_golden, Difference, Options, Shot, ShotRun, Update, Verdict,
};
use crate::Error;

/// The options of `campath test`.
#[derive(clap::Args)]
pub struct TestArgs {
    /// The folder of shots, searched recursively.
    #[arg(default_value = "shots")]
    pub dir: PathBuf,
    /// Approve in place: write the golden of every shot that differs or has none (its
    /// hashes.txt, small pictures, and its frames when the golden keeps frames); passing
    /// goldens are left untouched. As CAMPATH_UPDATE=always.
    #[arg(long, conflicts_with_all = ["pending", "no_pending"])]
    pub update: bool,
    /// Write a pending golden NAME.golden.new beside the golden of every failing shot, for
    /// `campath review` (the default, as CAMPATH_UPDATE=new; under CI the default is
    /// --no-pending).
    #[arg(long, conflicts_with = "no_pending")]
    pub pending: bool,
    /// Write nothing: compare only (as CAMPATH_UPDATE=no).
    #[arg(long)]
    pub no_pending: bool,
    /// With --update, keep every frame's PNG in the goldens it writes, not only hashes.txt
    /// and the small pictures.
    #[arg(long, requires = "update")]
    pub keep_frames: bool,
    /// List goldens and pending goldens with no shot beside them; =delete removes them.
    #[arg(long, value_name = "delete", num_args = 0..=1, require_equals = true, default_missing_value = "list", value_parser = ["list", "delete"])]
    pub unreferenced: Option<String>,
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

/// Every entry of the folders searched for shots under `dir`, as (folder, name, path): hidden
/// folders, goldens and pending goldens are not entered, and a folder reached twice through
/// symbolic links is searched once.
fn entries_under(dir: &Path) -> Result<Vec<(PathBuf, std::ffi::OsString, PathBuf)>> {
    let (mut all, mut folders) = (Vec::new(), vec![dir.to_path_buf()]);
    let mut seen = std::collections::BTreeSet::new();
    while let Some(folder) = folders.pop() {
        if !seen.insert(folder.canonicalize().map_err(Error::read(&folder))?) {
            continue;
        }
        for e in std::fs::read_dir(&folder)
            .map_err(Error::read(&folder))?
            .flatten()
        {
            let (name, path) = (e.file_name(), e.path());
            let shown = name.to_string_lossy();
            let golden = stem_of_golden(&shown).is_some();
            if path.is_dir() && !shown.starts_with('.') && !golden {
                folders.push(path.clone());
            }
            all.push((folder.clone(), name, path));
        }
    }
    Ok(all)
}

/// Every `*.ron` under `dir`, recursively, in name order, in the folders [`entries_under`]
/// searches.
pub fn shots(dir: &Path) -> Result<Vec<PathBuf>> {
    let entries = entries_under(dir)?.into_iter();
    let ron = |(_, name, path): &(PathBuf, std::ffi::OsString, PathBuf)| {
        !path.is_dir() && name.to_string_lossy().ends_with(".ron")
    };
    let mut found: Vec<PathBuf> = entries.filter(ron).map(|(.., path)| path).collect();
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
    if let Some(what) = &a.unreferenced {
        return unreferenced(&a.dir, what == "delete", out);
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
    let (update, keep_frames) = match (a.update, a.pending, a.no_pending) {
        (true, ..) => (Update::Always, a.keep_frames),
        (_, true, _) => (Update::New, false),
        (.., true) => (Update::No, false),
        _ => Update::from_env().map_err(CliError::Usage)?,
    };
    let options = Options {
        update,
        keep_frames,
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
    let approved = runs.iter().filter(|r| r.updated).count();
    let pending = runs.iter().filter(|r| r.pending.is_some()).count();
    let open = runs.iter().filter(|r| !r.updated);
    let count = |is: &dyn Fn(Verdict) -> bool| open.clone().filter(|r| is(r.verdict())).count();
    let passed = count(&|v| v == Verdict::Passed);
    let new = count(&|v| v == Verdict::NoGolden);
    let differ = runs.len() - approved - passed - new;
    // Goldens of a newer campath: this one never writes them, so approving is no answer.
    let newer = count(&|v| matches!(v, Verdict::OtherRenderer(v) if v > VERSION));
    let ok = differ + new + bad == 0;
    let mut summary = format!(
        "test result: {}. {} shot(s): {passed} passed, {differ} differ, {new} new",
        if ok { "ok" } else { "FAILED" },
        shots.len()
    );
    if bad > 0 {
        summary += &format!(", {bad} could not be checked");
    }
    summary += &format!("; {pending} pending golden(s) written, {approved} approved");
    let dir = shell_word(&a.dir.display().to_string());
    if pending > 0 {
        summary += &format!(
            "\nLook at the differences and accept or reject them: `campath review {dir}`."
        );
    } else if differ + new > newer && update == Update::No {
        summary += &format!(
            "\nNothing was written (--no-pending, CAMPATH_UPDATE=no, or CI is set). To look at \
             the differences: `campath test {dir} --pending`, then `campath review {dir}`."
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
        let d = shell_word(&a.dir.display().to_string());
        let how = match update {
            Update::New => format!(
                "Accept every shot: campath review {d} --accept (one: add --shot NAME). Reject: \
                 campath review {d} --reject. On a terminal, campath review {d} asks shot by shot."
            ),
            _ => format!(
                "This run wrote no pending golden. To approve: campath test {d} --pending, then \
                 campath review {d}; or campath test {d} --update to approve every shot."
            ),
        };
        let title = format!(
            "campath test: {} of {} shot(s) failed",
            shown.len(),
            shots.len()
        );
        let page = review::write(dir, &shown, &title, &how)?;
        writeln!(out, "review: {}", page.display()).map_err(Error::stdout)?;
    }
    if bad > 0 {
        return Err(CliError::Usage(format!(
            "{bad} of {} shot(s) could not be checked (see above)",
            shots.len()
        )));
    }
    Ok(differ + new == 0)
}

/// `--unreferenced`: the goldens and pending goldens under `dir` with no `NAME.ron` beside
/// them, listed, and with `delete` removed.
fn unreferenced(dir: &Path, delete: bool, out: &mut dyn Write) -> Result<bool> {
    let mut found = Vec::new();
    for (folder, name, path) in entries_under(dir)? {
        // A name that is not UTF-8 is never taken for an unreferenced golden.
        let Some(name) = name
            .to_str()
            .filter(|n| path.is_dir() && !n.starts_with('.'))
        else {
            continue;
        };
        if stem_of_golden(name).is_some_and(|stem| !folder.join(format!("{stem}.ron")).is_file()) {
            found.push(path);
        }
    }
    found.sort();
    for path in &found {
        if delete {
            std::fs::remove_dir_all(path).map_err(Error::write(path))?;
            writeln!(out, "removed {}", path.display()).map_err(Error::stdout)?;
        } else {
            writeln!(out, "{}", path.display()).map_err(Error::stdout)?;
        }
    }
    let n = found.len();
    let d = shell_word(&dir.display().to_string());
    let line = match (n, delete) {
        (0, _) => "no unreferenced golden".to_string(),
        (_, true) => format!("{n} unreferenced golden(s) removed"),
        (_, false) => format!(
            "{n} unreferenced golden(s); remove them: `campath test {d} --unreferenced=delete`"
        ),
    };
    writeln!(out, "{line}").map_err(Error::stdout)?;
    Ok(true)
}

/// Renders and compares one shot; with a review folder, writes its differing frames' pictures
/// there as they are found.
fn check(index: usize, shot: &Path, options: Options, review: Option<&Path>) -> Checked {
    let mut frames = Vec::new();
    let run = Shot::open(shot, options).and_then(|shot| {
        let size = (shot.doc.raster.width, shot.doc.raster.height);
        let golden_frames = shot.golden_frames.clone();
        let thumbs = crate::testing::thumbs_in(&golden_dir(&shot.path));
        shot.run(options, |d: &Difference, pixels| {
            let Some(dir) = review else { return Ok(()) };
            let name = |what: &str| review::file_name(index, d.frame, what);
            let new = name("new");
            write_png(&dir.join(&new), pixels, size, Compression::Fast)?;
            let mut f = ReviewFrame::of(d);
            f.new = Some(new);
            let golden = golden_frames.get(&d.frame).and_then(|p| pixels_of(p, size));
            if let (None, Some(thumb)) = (&golden, thumbs.get(&d.frame)) {
                // The golden's small picture, beside the new frame.
                let g = name("golden");
                std::fs::copy(thumb, dir.join(&g)).map_err(Error::write(dir.join(&g)))?;
                f.golden = Some(g);
            }
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
