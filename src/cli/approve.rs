//! `campath review [DIR]`: the pending goldens that failing runs left under DIR, a shot at a
//! time: which frames differ and by how much, golden and new side by side, and on a terminal
//! a key to accept, reject or skip each, as `cargo insta review` does. `--accept` and
//! `--reject` act off a terminal; `--page` writes the review page.

use std::io::{IsTerminal, Read, Write};
use std::path::{Path, PathBuf};

use super::error::{CliError, Result};
use super::review::{self, ReviewFrame, ReviewShot};
use crate::golden::Golden;
use crate::output::{frame_path, frames_in};
use crate::testing::pictures::{difference, pixels_of, shrink, thumbnail};
use crate::testing::{self, golden_dir, pending_dir, shell_word, thumbs_in, PictureDiff};
use crate::Error;

/// The options of `campath review`.
#[derive(clap::Args)]
pub struct ReviewArgs {
    /// The folder of shots, searched recursively.
    #[arg(default_value = "shots")]
    pub dir: PathBuf,
    /// Accept every pending golden (or those of --shot): each becomes its shot's golden.
    #[arg(long, conflicts_with = "reject")]
    pub accept: bool,
    /// Reject every pending golden (or those of --shot): each is removed.
    #[arg(long)]
    pub reject: bool,
    /// Only this shot: its file name (orbit.ron), stem (orbit) or path. May be repeated.
    #[arg(long, value_name = "NAME")]
    pub shot: Vec<String>,
    /// Write a review page of the pending goldens, DIR/index.html: golden and new side by
    /// side with their difference, and how to accept.
    #[arg(long, value_name = "DIR")]
    pub page: Option<PathBuf>,
}

/// A pending golden and how it differs from the golden.
struct Pending {
    shot: PathBuf,
    new: Golden,
    frames: Vec<Frame>,
}

/// A frame of a pending golden that differs from the golden.
struct Frame {
    frame: u64,
    golden: Option<crate::FrameHash>,
    new: Option<crate::FrameHash>,
    /// The golden's picture of it: its full frame, else its small picture.
    golden_picture: Option<PathBuf>,
    /// The new full frame, in the pending golden.
    new_picture: Option<PathBuf>,
    diff: Option<PictureDiff>,
}

fn pending_of(shot: &Path) -> Result<Option<Pending>> {
    let Some(new) = testing::load_pending(shot)? else {
        return Ok(None);
    };
    let dir = golden_dir(shot);
    let golden = Golden::find(&dir)?;
    let (full, thumbs) = (frames_in(&dir), thumbs_in(&dir));
    let new_frames = frames_in(&pending_dir(shot));
    let old = golden
        .as_ref()
        .map(|g| g.hashes.clone())
        .unwrap_or_default();
    let frames = (new.hashes.keys().chain(old.keys()))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .map(|&frame| (frame, old.get(&frame).copied(), new.hash(frame)))
        .filter(|(_, g, n)| g != n)
        .map(|(frame, golden, new)| {
            let new_picture = new_frames.get(&frame).cloned();
            let pixels = new_picture
                .as_ref()
                .and_then(|p| image::open(p).ok()?.to_rgb8().into());
            let (golden_picture, diff) = match (full.get(&frame), thumbs.get(&frame), &pixels) {
                (Some(g), _, Some(n)) => {
                    let g_px = pixels_of(g, n.dimensions());
                    let diff = g_px.map(|g_px| PictureDiff {
                        diff: difference(&g_px, n.as_raw()).1,
                        small: false,
                    });
                    (Some(g.clone()), diff)
                }
                (None, Some(t), Some(n)) => {
                    let small = thumbnail(n.as_raw(), n.dimensions());
                    let diff = pixels_of(t, small.size).map(|g_px| PictureDiff {
                        diff: difference(&g_px, &small.pixels).1,
                        small: small.size != n.dimensions(),
                    });
                    (Some(t.clone()), diff)
                }
                (g, t, _) => (g.or(t).cloned(), None),
            };
            Frame {
                frame,
                golden,
                new,
                golden_picture,
                new_picture,
                diff,
            }
        })
        .collect();
    Ok(Some(Pending {
        shot: shot.to_path_buf(),
        new,
        frames,
    }))
}

pub fn run(a: ReviewArgs, out: &mut dyn Write) -> Result<bool> {
    if !a.dir.is_dir() {
        return Err(CliError::Usage(format!(
            "{} is not a folder of shots",
            a.dir.display()
        )));
    }
    let chosen = |shot: &Path| {
        let rel = shot.strip_prefix(&a.dir).unwrap_or(shot);
        a.shot.is_empty()
            || a.shot.iter().any(|s| {
                let s = Path::new(s);
                [shot, rel].contains(&s)
                    || shot.file_name() == Some(s.as_os_str())
                    || shot.file_stem() == Some(s.as_os_str())
            })
    };
    let shots: Vec<PathBuf> = super::suite::shots(&a.dir)?;
    let mut pending = Vec::new();
    for shot in shots.iter().filter(|s| chosen(s)) {
        if let Some(p) = pending_of(shot)? {
            pending.push(p);
        }
    }
    let dir = shell_word(&a.dir.display().to_string());
    if pending.is_empty() {
        let line =
            format!(
            "no pending golden under {}{} (`campath test {dir}` leaves one for each failing shot)",
            a.dir.display(),
            if a.shot.is_empty() { "" } else { " for the chosen shot(s)" }
        );
        writeln!(out, "{line}").map_err(Error::stdout)?;
        return Ok(true);
    }
    if let Some(page) = &a.page {
        let path = write_page(page, &pending, &dir)?;
        writeln!(out, "review page: {}", path.display()).map_err(Error::stdout)?;
    }
    let terminal = std::io::stdin().is_terminal();
    let pictures = std::io::stdout().is_terminal();
    let (n, mut left) = (pending.len(), 0);
    for (i, p) in pending.iter().enumerate() {
        let mut text = format!("\n[{}/{n}] {}\n", i + 1, describe(p));
        if terminal && !a.accept && !a.reject && pictures {
            text += &side_by_side(p);
        }
        out.write_all(text.as_bytes()).map_err(Error::stdout)?;
        let choice = match (a.accept, a.reject, terminal) {
            (true, ..) => b'a',
            (_, true, _) => b'r',
            (.., true) => {
                write!(out, "a accept, r reject, s skip, q quit: ").map_err(Error::stdout)?;
                out.flush().map_err(Error::stdout)?;
                let key = read_key().map_err(|e| Error::read("standard input")(e))?;
                writeln!(out, "{}", key.map_or('q', char::from)).map_err(Error::stdout)?;
                key.unwrap_or(b'q')
            }
            _ => b's',
        };
        let line = match choice {
            b'a' | b'A' if testing::accept(&p.shot, Some(&p.new))? => {
                format!(
                    "accepted: {} is the golden now",
                    golden_dir(&p.shot).display()
                )
            }
            b'r' | b'R' if testing::reject(&p.shot)? => {
                format!("rejected: {} removed", pending_dir(&p.shot).display())
            }
            b'a' | b'A' | b'r' | b'R' => "another run took it meanwhile; left as it is".into(),
            b'q' | b'Q' | 3 | 4 => {
                left += n - i;
                break;
            }
            _ => {
                left += 1;
                "skipped".into()
            }
        };
        writeln!(out, "{line}").map_err(Error::stdout)?;
    }
    if left > 0 {
        writeln!(
            out,
            "\n{left} pending golden(s) left. Accept them: `campath review {dir} --accept` \
             (one: add --shot NAME); reject them: `campath review {dir} --reject`."
        )
        .map_err(Error::stdout)?;
    }
    Ok(true)
}

/// What a pending golden holds, in a few lines: the frames that differ, by how much.
fn describe(p: &Pending) -> String {
    let total = p.new.hashes.len();
    if !golden_dir(&p.shot).join(crate::output::HASHES).exists() {
        return format!(
            "{}: new shot, {total} frame(s), no golden yet",
            p.shot.display()
        );
    }
    let mut text = format!(
        "{}: {} of {total} frame(s) differ from the golden",
        p.shot.display(),
        p.frames.len(),
    );
    for f in p.frames.iter().take(8) {
        let what = match (f.golden, f.new, &f.diff) {
            (_, None, _) => "in the golden, past the animation's end".to_string(),
            (None, ..) => "new".to_string(),
            (_, _, Some(d)) if d.small => format!("{} (on the small pictures)", d.diff),
            (_, _, Some(d)) => d.diff.to_string(),
            _ => "hash differs; the golden keeps no picture of it".to_string(),
        };
        text += &format!("\n  frame {}: {what}", f.frame);
    }
    if p.frames.len() > 8 {
        text += &format!("\n  … and {} more", p.frames.len() - 8);
    }
    text
}

/// The first differing frame, golden and new side by side in colour, two pixels to a
/// character cell.
fn side_by_side(p: &Pending) -> String {
    let Some(f) = p.frames.iter().find(|f| f.new_picture.is_some()) else {
        return String::new();
    };
    let load = |path: &Option<PathBuf>| {
        let img = image::open(path.as_ref()?).ok()?.to_rgb8();
        let size = img.dimensions();
        let cols = 38u32.min(size.0);
        let rows = ((u64::from(size.1) * u64::from(cols) / u64::from(size.0)).max(2) as u32) & !1;
        Some((shrink(img.as_raw(), size, (cols, rows)), (cols, rows)))
    };
    let (golden, new) = (load(&f.golden_picture), load(&f.new_picture));
    let lines = |pic: &Option<(Vec<u8>, (u32, u32))>, row: u32| -> String {
        let Some((px, (w, h))) = pic else {
            return " ".repeat(38);
        };
        if row * 2 >= *h {
            return " ".repeat(*w as usize);
        }
        let at = |x: u32, y: u32| {
            let i = ((y * w + x) * 3) as usize;
            (px[i], px[i + 1], px[i + 2])
        };
        let mut s = String::new();
        for x in 0..*w {
            let ((r, g, b), (r2, g2, b2)) = (at(x, row * 2), at(x, row * 2 + 1));
            s += &format!("\x1b[38;2;{r};{g};{b}m\x1b[48;2;{r2};{g2};{b2}m▀");
        }
        s + "\x1b[0m"
    };
    let height = [&golden, &new]
        .iter()
        .filter_map(|p| p.as_ref())
        .map(|p| p.1 .1 / 2)
        .max();
    let mut text = format!(
        "  frame {}: golden{} | new\n",
        f.frame,
        if golden.is_none() { " (none)" } else { "" }
    );
    for row in 0..height.unwrap_or(0) {
        text += &format!("  {} {}\n", lines(&golden, row), lines(&new, row));
    }
    text
}

/// One key from the terminal, without waiting for Enter; None at the end of input.
fn read_key() -> std::io::Result<Option<u8>> {
    #[cfg(target_os = "linux")]
    let _raw = Raw::enter();
    let mut byte = [0u8];
    loop {
        if std::io::stdin().read(&mut byte)? == 0 {
            return Ok(None);
        }
        if !byte[0].is_ascii_whitespace() {
            return Ok(Some(byte[0]));
        }
    }
}

/// The terminal reading key by key and not echoing, while it lives.
#[cfg(target_os = "linux")]
struct Raw(Option<rustix::termios::Termios>);

#[cfg(target_os = "linux")]
impl Raw {
    fn enter() -> Raw {
        use rustix::termios::{tcgetattr, tcsetattr, LocalModes, OptionalActions};
        let stdin = std::io::stdin();
        let Ok(old) = tcgetattr(&stdin) else {
            return Raw(None);
        };
        let mut raw = old.clone();
        // Ctrl-C arrives as a key (quit), so the terminal is always restored.
        raw.local_modes -= LocalModes::ICANON | LocalModes::ECHO | LocalModes::ISIG;
        let _ = tcsetattr(&stdin, OptionalActions::Now, &raw);
        Raw(Some(old))
    }
}

#[cfg(target_os = "linux")]
impl Drop for Raw {
    fn drop(&mut self) {
        if let Some(old) = &self.0 {
            let stdin = std::io::stdin();
            let _ = rustix::termios::tcsetattr(&stdin, rustix::termios::OptionalActions::Now, old);
        }
    }
}

/// The review page of the pending goldens, with its pictures copied beside it.
fn write_page(page: &Path, pending: &[Pending], dir: &str) -> Result<PathBuf> {
    let goldens: Vec<PathBuf> = pending.iter().map(|p| golden_dir(&p.shot)).collect();
    let _claimed =
        super::failures::claim(None, Some(page), "--page", &goldens, review::is_review_file)?;
    let mut shots = Vec::new();
    for (index, p) in pending.iter().enumerate() {
        let mut frames = Vec::new();
        for f in &p.frames {
            let name = |what: &str| review::file_name(index, f.frame, what);
            let mut r = ReviewFrame {
                frame: f.frame,
                golden_hash: f.golden,
                fresh_hash: f.new,
                pixels: f.diff.map(|d| d.diff),
                ..Default::default()
            };
            let copy = |from: &Option<PathBuf>, what: &str| -> Result<Option<String>> {
                let Some(from) = from else { return Ok(None) };
                let to = name(what);
                std::fs::copy(from, page.join(&to)).map_err(Error::write(page.join(&to)))?;
                Ok(Some(to))
            };
            r.new = copy(&f.new_picture, "new")?;
            r.golden = copy(&f.golden_picture, "golden")?;
            let total = p.new.hashes.len() as u64;
            let diff = frame_path(&pending_dir(&p.shot), f.frame, total).with_extension("diff.png");
            r.diff = copy(&Some(diff).filter(|d| d.exists()), "diff")?;
            frames.push(r);
        }
        shots.push(ReviewShot {
            shot: p.shot.display().to_string(),
            summary: (describe(p).lines().next().unwrap_or(""))
                .split_once(": ")
                .map_or(String::new(), |(_, what)| what.to_string()),
            frames,
        });
    }
    let how = format!(
        "Accept every shot: campath review {dir} --accept (one: add --shot NAME). Reject: \
         campath review {dir} --reject. On a terminal, campath review {dir} asks shot by shot."
    );
    let title = format!("campath review: {} pending golden(s)", pending.len());
    review::write(page, &shots, &title, &how)
}
