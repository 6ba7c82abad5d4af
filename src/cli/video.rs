//! `campath video`: the sequence as a video, encoded by ffmpeg from raw RGB frames on a pipe.
//!
//! The frames are rendered first into the render folder (keeping those still valid), so the
//! video holds exactly the frames of `hashes.txt`: each PNG is decoded and checked against its
//! manifest hash on the way to ffmpeg. H.264 in MP4 (yuv420p, playable by browsers and phones)
//! by default; `--lossless` writes FFV1 RGB in Matroska, whose decoded frames hash to the
//! manifest's hashes. The video is written under a temporary name and renamed when ffmpeg has
//! finished, so a killed encode leaves no video under the final name.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use super::args::{default_out_dir, NoWait, Quiet, Shot};
use super::error::{CliError, Result};
use super::progress::Progress;
use crate::document::Document;
use crate::frames::FrameSet;
use crate::output::sequence::{self, Event, RenderOptions};
use crate::output::{
    check, folder_of, frame_path, resolved, temp_beside, video_path, within, Refusal, Use, HASHES,
};
use crate::{frame_hash, Error, FrameHash};

/// The options of `campath video`.
#[derive(clap::Args)]
pub struct VideoArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// The video [default: out/<file stem>/<file stem>.mp4, or .mkv with --lossless].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Lossless RGB (FFV1 in Matroska): decoded frames hash exactly to hashes.txt.
    #[arg(long)]
    pub lossless: bool,
    /// H.264 quality: 0 (best, largest) to 51 (worst); 18 looks lossless to most eyes.
    #[arg(long, default_value_t = 18, value_parser = clap::value_parser!(u8).range(0..=51), conflicts_with = "lossless")]
    pub crf: u8,
    #[command(flatten)]
    pub quiet: Quiet,
    #[command(flatten)]
    pub no_wait: NoWait,
}

/// ffmpeg could not be started: missing, most likely.
fn ffmpeg_missing(e: std::io::Error) -> CliError {
    let message = format!("cannot run it ({e}); install the Debian package ffmpeg");
    CliError::Tool("ffmpeg", message)
}

pub fn run(a: VideoArgs, out: &mut dyn Write) -> Result<()> {
    let started = Instant::now();
    let file = &a.shot.file;
    // The render folder the frames go into first.
    let frames_dir = &default_out_dir(file);
    let (quiet, no_wait) = (a.quiet.on, a.no_wait.on);
    let (ext, what) = match a.lossless {
        true => ("mkv", "--lossless writes FFV1 in Matroska"),
        false => (
            "mp4",
            "the video is H.264 in MP4 (--lossless: FFV1 in .mkv)",
        ),
    };
    // Before anything else: a video name that says the container, and is not a folder.
    if let Some(video) = &a.out {
        if video.is_dir() {
            return Err(CliError::Usage(format!(
                "--out {} is a folder: name the video file (.mp4, or .mkv with --lossless)",
                video.display()
            )));
        }
        crate::output::golden_of(folder_of(video))
            .map_err(|r| CliError::refused("--out", video, &r))?;
        super::args::check_extension("--out", video, &[ext], what)?;
    }
    let doc = Document::load(file)?;
    // Matroska stamps frames in milliseconds: above 1000 fps two frames would share a time.
    if a.lossless && doc.animation.fps > 1000.0 {
        return Err(CliError::Usage(format!(
            "{}: --lossless writes Matroska, whose timestamps are milliseconds, so it holds at \
             most 1000 fps, not {}; nothing was written",
            file.display(),
            doc.animation.fps
        )));
    }
    let own = video_path(frames_dir, file, ext);
    let video = a.out.clone().unwrap_or_else(|| own.clone());
    // In the frames folder a video has the file's name, the one a run that changes the frames
    // removes; any other goes outside it (a folder made inside it would be a file campath did
    // not write there).
    let parent = folder_of(&video);
    if within(parent, frames_dir) && resolved(&video) != resolved(&own) {
        return Err(CliError::Usage(format!(
            "--out {}: in the frames folder {} the video is {}; put another name outside it; \
             nothing was written",
            video.display(),
            frames_dir.display(),
            own.display()
        )));
    }
    // Nor in another render's frames folder: there it would pass for that render's video.
    if !within(parent, frames_dir) {
        match check(&video, Use::File) {
            Err(Refusal::InFrames { frames: theirs, .. }) => {
                return Err(CliError::Usage(format!(
                    "--out {}: {} is the frames folder of another render, where a video would \
                     pass for its own; nothing was written (put it outside, or leave out --out \
                     for {})",
                    video.display(),
                    theirs.display(),
                    own.display()
                )))
            }
            refused => refused.map_err(|r| CliError::refused("--out", &video, &r))?,
        }
    }
    // Before rendering anything: is there an ffmpeg to hand the frames to?
    Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .status()
        .map_err(ffmpeg_missing)?;

    let total = doc.animation.frames;
    let mut progress = Progress::new(quiet);
    let set = FrameSet::all(0..total);
    // Held until the video is written: the frames are read back for ffmpeg.
    let lock = super::progress::with_wait(no_wait, quiet, |wait| {
        sequence::lock(&doc, frames_dir, &set, wait)
    })?;
    // Before rendering: that the video can be written where it goes.
    super::args::check_writable(&video)?;
    let options = RenderOptions::default();
    let summary = sequence::render(&doc, &lock, &set, options, &mut |e| progress.event(e))?;
    progress.finish();
    let entries = summary.manifest.entries.into_iter();
    let hashes: BTreeMap<u64, FrameHash> = entries.map(|e| (e.frame, e.hash)).collect();
    // ffmpeg writes over a temporary file of its own, removed unless renamed into place.
    let tmp = temp_beside(&video)?;
    // As a `file:` URL: a name that begins with `-` is not an option to ffmpeg.
    let mut url = std::ffi::OsString::from("file:");
    url.push(tmp.path());
    // Ctrl-C from here on stops the encode and removes what it wrote: the frames stop going to
    // ffmpeg, and the temporary video is removed once ffmpeg has ended. ffmpeg, in the same
    // process group, stops on a Ctrl-C of its own. (Another signal ends campath as before; the
    // next render that changes the frames removes what it left.)
    let stop = super::progress::ctrl_c_flag()?;
    let mut child = Command::new("ffmpeg")
        .args(ffmpeg_args(&doc, a.lossless, a.crf))
        .arg(url)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(ffmpeg_missing)?;
    let mut stdin = child.stdin.take().expect("piped");
    let mut progress = Progress::new(quiet);
    progress.begin(total, 0, "encode");
    let fed = feed(frames_dir, total, &hashes, &mut stdin, &mut progress, &stop);
    drop(stdin);
    progress.finish();
    let result = child.wait_with_output().map_err(ffmpeg_missing)?;
    if stop.load(Ordering::SeqCst) {
        drop(tmp);
        return Err(CliError::Stopped(format!(
            "the encode of {} was stopped; the partial video was removed",
            video.display()
        )));
    }
    // ffmpeg's own failure explains a pipe it stopped reading.
    if !result.status.success() {
        let stderr = String::from_utf8_lossy(&result.stderr);
        let message = format!("failed ({}): {}", result.status, stderr.trim());
        return Err(CliError::Tool("ffmpeg", message));
    }
    fed?;
    tmp.persist(&video)
        .map_err(|e| Error::write(&video)(e.error))?;
    if !quiet {
        let (w, h) = (doc.raster.width, doc.raster.height);
        // yuv420p needs even sides (`ffmpeg_args`).
        let (crf, even_w, even_h) = (a.crf, w + w % 2, h + h % 2);
        let what = if a.lossless {
            "FFV1 lossless RGB".to_string()
        } else if (even_w, even_h) != (w, h) {
            format!("H.264 yuv420p, crf {crf}, padded to {even_w}×{even_h} with black, as 4:2:0 needs even sides")
        } else {
            format!("H.264 yuv420p, crf {crf}")
        };
        let fps = match frame_rate(doc.animation.fps) {
            ntsc if ntsc.contains('/') => format!("{} ({ntsc})", doc.animation.fps),
            _ => doc.animation.fps.to_string(),
        };
        writeln!(
            out,
            "wrote {} ({total} frame(s) of {w}×{h} at {fps} fps, {what}) in {:.2} s",
            video.display(),
            started.elapsed().as_secs_f64()
        )
        .map_err(Error::stdout)?;
    }
    Ok(())
}

/// The video's frame rate as ffmpeg reads it: a rate within 0.005 of an NTSC one, N × 1000/1001
/// (23.976, 23.98, 29.97, 59.94, …), as that fraction, which players and editors expect
/// (ffmpeg would store 23.976 as 2997/125); any other as written.
fn frame_rate(fps: f64) -> String {
    let n = (fps * 1.001).round();
    if n >= 1.0 && fps.fract() != 0.0 && (fps - n * 1000.0 / 1001.0).abs() <= 0.005 {
        format!("{}/1001", n as u64 * 1000)
    } else {
        fps.to_string()
    }
}

/// ffmpeg's arguments, up to the output path: raw RGB frames on standard input.
fn ffmpeg_args(doc: &Document, lossless: bool, crf: u8) -> Vec<String> {
    let size = format!("{}x{}", doc.raster.width, doc.raster.height);
    let input = format!(
        "-hide_banner -loglevel error -y -f rawvideo -pix_fmt rgb24 -video_size {size} \
         -framerate {} -i - -an",
        frame_rate(doc.animation.fps)
    );
    let codec = if lossless {
        // FFV1 stores RGB exactly; bgr0 is its packed RGB input.
        "-c:v ffv1 -level 3 -pix_fmt bgr0 -f matroska".to_string()
    } else {
        // yuv420p needs even sides: pad odd ones by a pixel. The sRGB levels go to Y'CbCr by
        // BT.709's matrix in limited range, and the stream says so (untagged, players guess,
        // and HD players guess BT.709 where ffmpeg's default matrix is BT.601's).
        format!(
            "-c:v libx264 -vf pad=ceil(iw/2)*2:ceil(ih/2)*2,scale=out_color_matrix=bt709:\
             out_range=tv:flags=accurate_rnd+full_chroma_int,format=yuv420p -colorspace bt709 \
             -color_primaries bt709 -color_trc iec61966-2-1 -color_range tv \
             -movflags +faststart -f mp4 -crf {crf}"
        )
    };
    // No argument holds a space: the frame rate, the size and the filter are single words.
    (input + " " + &codec)
        .split(' ')
        .map(String::from)
        .collect()
}

/// Decodes every frame's PNG, checks it against the manifest, and writes its RGB to ffmpeg.
fn feed(
    dir: &Path,
    total: u64,
    hashes: &BTreeMap<u64, FrameHash>,
    stdin: &mut impl Write,
    progress: &mut Progress,
    stop: &AtomicBool,
) -> Result<()> {
    for frame in 0..total {
        if stop.load(Ordering::SeqCst) {
            return Ok(());
        }
        let path = frame_path(dir, frame, total);
        let pixels = image::open(&path)
            .map_err(Error::encode(&path))?
            .to_rgb8()
            .into_raw();
        if hashes.get(&frame) != Some(&frame_hash(&pixels)) {
            return Err(Error::Manifest {
                path: dir.join(HASHES),
                message: format!("frame {frame}: {} does not match its hash", path.display()),
            }
            .into());
        }
        if let Err(e) = stdin.write_all(&pixels) {
            // ffmpeg stopped reading: its own message says why.
            let message = format!("stopped reading frames at frame {frame} ({e})");
            return Err(CliError::Tool("ffmpeg", message));
        }
        progress.event(Event::Written(frame));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::frame_rate;

    #[test]
    fn ntsc_rates_are_their_exact_fractions() {
        for (fps, want) in [
            (23.976, "24000/1001"),
            (23.98, "24000/1001"),
            (24000.0 / 1001.0, "24000/1001"),
            (29.97, "30000/1001"),
            (47.952, "48000/1001"),
            (59.94, "60000/1001"),
            (119.88, "120000/1001"),
            (24.0, "24"),
            (25.0, "25"),
            (1000.0, "1000"),
            (12.5, "12.5"),
            (23.9, "23.9"),
            (29.9, "29.9"),
            (0.5, "0.5"),
        ] {
            assert_eq!(frame_rate(fps), want, "{fps}");
        }
    }
}
