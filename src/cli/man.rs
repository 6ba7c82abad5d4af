//! `campath man`: the manual from the clap definitions, as one page that holds everything (every
//! command with its options, exit status, environment, the file), or with `--dir` as that page
//! and one page per command beside it.

use std::io::Write;
use std::path::Path;

use clap::CommandFactory;
use clap_mangen::Man;

use super::error::Result;
use crate::Error;

/// What the clap definitions do not say: exit status, environment and the file.
const TAIL: &str = r#".SH "EXIT STATUS"
.TP
\fB0\fR
Success.
.TP
\fB1\fR
\fBverify\fR found a frame that differs, or an I/O failure (a file that cannot be read or written).
.TP
\fB2\fR
Bad input or a bad option: a keyframe file with a syntax error, an unknown field, an
out\-of\-range value or a camera that becomes undefined at some frame; an option value that
cannot be used; an output folder held by another run under \fB\-\-no\-wait\fR. Nothing is written.
.TP
\fB3\fR
An outside program (ffmpeg for \fBvideo\fR) is missing or failed; the
message names its Debian package.
.TP
\fB130\fR
\fBvideo\fR was stopped by Ctrl\-C while it encoded; the partial video is removed.
.SH ENVIRONMENT
.TP
\fBCAMPATH_SIMD\fR
The instruction path of the renderer: sse2 (also named scalar), avx2 or avx512 (default: the
widest the CPU runs). Every path gives the same bytes.
.TP
\fBCAMPATH_PROGRESS_SECS\fR
Seconds between progress lines when standard error is not a terminal (default 5; 0: a line per
frame).
.TP
\fBCAMPATH_UPDATE\fR
What \fBtest\fR and assert_shot write for a failing shot: no (nothing), new (a pending golden
\fINAME\fR.golden.new for \fBreview\fR; the default) or always (approve in place). \fBverify\fR
writes the pending golden under new.
.TP
\fBCI\fR
When set and not empty, the default of \fBCAMPATH_UPDATE\fR is no.
.TP
\fBRAYON_NUM_THREADS\fR
Threads to render on (default: every core). The bytes do not depend on it.
.SH FILES
.TP
\fIFILE\fR.ron
The keyframe file, RON in UTF\-8: \fBframes\fR, \fBfps\fR, \fBimage\fR (width, height, samples,
adaptive, motion_blur (shutter, samples)), \fBcamera\fR (vrp, vpn or tp, vuv, cop, window or hfov/vfov, roll), \fBanimate\fR (tracks
Observer, LookAround, Track, Zoom, Distort, Roll with keys (t: seconds, value: ...) and an
interpolation), \fBscene\fR (background, ambient, lights, spheres). Every field and rule:
docs/format.md in campath's sources.
.TP
\fIDIR\fR/frame_NNNN.png, \fIDIR\fR/hashes.txt
The frames, and one line per frame: frame index, SHA\-256 of its RGB8 pixels, frame key.
Shards write hashes.part\-K\-of\-N.txt; \fBmerge\fR joins them.
.TP
\fIDIR\fR/campath.lock
The output folder's lock: one run writes a folder at a time (the shards of one N side by side).
.SH "SEE ALSO"
README.md, docs/format.md, docs/farms.md and docs/exports.md in campath's sources.
"#;

/// The whole manual as one roff page.
pub fn page(out: &mut dyn Write) -> Result<()> {
    let mut cmd = super::Cli::command().disable_help_subcommand(true);
    cmd.build();
    let man = Man::new(cmd.clone());
    let write = |out: &mut dyn Write| -> std::io::Result<()> {
        man.render_title(out)?;
        man.render_name_section(out)?;
        man.render_synopsis_section(out)?;
        man.render_description_section(out)?;
        man.render_options_section(out)?;
        writeln!(out, ".SH COMMANDS")?;
        for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
            let sub_man = Man::new(sub.clone());
            let mut text = Vec::new();
            sub_man.render_synopsis_section(&mut text)?;
            sub_man.render_description_section(&mut text)?;
            sub_man.render_options_section(&mut text)?;
            // Each command is a subsection of COMMANDS: its synopsis as the heading.
            let text = String::from_utf8_lossy(&text)
                .replace(
                    ".SH SYNOPSIS\n",
                    &format!(".SS \"campath {}\"\n", sub.get_name()),
                )
                .replace(".SH DESCRIPTION\n", ".PP\n")
                .replace(".SH OPTIONS\n", ".PP\nOptions:\n");
            out.write_all(text.as_bytes())?;
        }
        out.write_all(TAIL.as_bytes())?;
        man.render_version_section(out)
    };
    Ok(write(out).map_err(Error::stdout)?)
}

/// Writes the whole manual as `dir/campath.1`, and a page per command (`campath-render.1`, …)
/// beside it; returns the pages written.
pub fn write_pages(dir: &Path) -> Result<Vec<std::path::PathBuf>> {
    std::fs::create_dir_all(dir).map_err(Error::write(dir))?;
    let mut cmd = super::Cli::command().disable_help_subcommand(true);
    cmd.build();
    let pages = cmd.get_subcommands().filter(|s| !s.is_hide_set());
    let pages = pages.map(|sub| Man::new(sub.clone()).generate_to(dir));
    let mut written = pages
        .collect::<std::io::Result<Vec<_>>>()
        .map_err(Error::write(dir))?;
    let path = dir.join("campath.1");
    let mut text = Vec::new();
    page(&mut text)?;
    crate::output::write_atomic(&path, &text)?;
    written.insert(0, path);
    Ok(written)
}
