//! `campath test --review DIR`: a page, `DIR/index.html`, of every failing shot's frames: the
//! golden frame (when the golden keeps frames), the new frame and a difference image, with a
//! slider and a flip between golden and new. It is one file with its pictures beside it, and
//! works from `file://` with no server and no network.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::error::Result;
use super::junit::escape;
use crate::testing::PixelDiff;
use crate::FrameHash;

/// A differing frame's pictures in the review folder (file names) and hashes.
#[derive(Default)]
pub struct ReviewFrame {
    pub frame: u64,
    pub golden_hash: Option<FrameHash>,
    pub fresh_hash: Option<FrameHash>,
    /// The new frame; None for a golden frame past the animation's end.
    pub new: Option<String>,
    /// The golden frame, when the golden keeps frames.
    pub golden: Option<String>,
    /// The difference image, beside a golden frame.
    pub diff: Option<String>,
    pub pixels: Option<PixelDiff>,
}

impl ReviewFrame {
    /// A differing frame with its hashes, before its pictures are written.
    pub fn of(d: &crate::testing::Difference) -> ReviewFrame {
        ReviewFrame {
            frame: d.frame,
            golden_hash: d.expected,
            fresh_hash: d.actual,
            ..Default::default()
        }
    }
}

/// A failing shot on the page.
pub struct ReviewShot {
    pub shot: String,
    pub summary: String,
    pub frames: Vec<ReviewFrame>,
}

/// A review picture's file name: shot `index`, `frame`, and `what` (new, golden or diff).
pub fn file_name(index: usize, frame: u64, what: &str) -> String {
    format!("shot{index:04}_frame{frame:06}.{what}.png")
}

/// The files `--review` writes: `index.html` and [`file_name`]s.
pub fn is_review_file(name: &str) -> bool {
    let name = crate::output::final_name(name);
    if name == "index.html" {
        return true;
    }
    let parts = (name.strip_prefix("shot"))
        .and_then(|r| r.strip_suffix(".png")?.split_once('.'))
        .and_then(|(numbers, what)| Some((numbers.split_once("_frame")?, what)));
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    parts.is_some_and(|((shot, frame), what)| {
        digits(shot) && digits(frame) && ["new", "golden", "diff"].contains(&what)
    })
}

const STYLE: &str = "
body { font: 14px/1.4 system-ui, sans-serif; margin: 24px; background: #1d1f24; color: #e6e6e6; }
h1 { font-size: 20px; } .how { font-family: ui-monospace, monospace; background: #2a2d33; padding: 8px 12px; } h2 { font-size: 16px; margin-top: 32px; border-top: 1px solid #444; padding-top: 16px; }
.frame { margin: 16px 0 28px; }
.frame h3 { font-size: 14px; margin: 0 0 6px; font-weight: 600; }
.pictures { display: flex; flex-wrap: wrap; gap: 16px; align-items: flex-start; }
figure { margin: 0; }
figcaption { font-size: 12px; color: #aaa; margin-top: 4px; }
.compare { position: relative; display: inline-block; line-height: 0; outline: 1px solid #555; }
.compare img, figure > img { image-rendering: pixelated; width: min(44vw, 960px); }
.compare img.new { position: absolute; left: 0; top: 0; }
.controls { margin-top: 6px; display: flex; gap: 8px; align-items: center; font-size: 12px; }
.hash { font-family: ui-monospace, monospace; font-size: 11px; color: #999; word-break: break-all; }
.passed { color: #7ec27e; }
";

/// Slide: the new frame is clipped to the slider's right; flip: show golden or new whole.
const SCRIPT: &str = "
function show(c, percent) {
  c.querySelector('img.new').style.clipPath = 'inset(0 0 0 ' + percent + '%)';
  c.dataset.split = percent;
}
document.querySelectorAll('.frame').forEach(function (f) {
  var c = f.querySelector('.compare');
  if (!c) return;
  var slider = f.querySelector('input.slide');
  slider.addEventListener('input', function () { show(c, slider.value); });
  f.querySelector('button.flip').addEventListener('click', function () {
    slider.value = slider.value > 50 ? 0 : 100; show(c, slider.value);
  });
  show(c, slider.value);
});
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  document.body.dataset.images = imgs.length;
  document.body.dataset.loaded = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
});
";

/// Writes `dir/index.html` for the failing `shots` of a run of `total` shots; returns its path.
/// `title` heads the page; `how` says how to approve.
pub fn write(dir: &Path, shots: &[ReviewShot], title: &str, how: &str) -> Result<PathBuf> {
    let mut html =
        String::from("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">");
    let _ = write!(
        html,
        "<title>campath review</title><style>{STYLE}</style></head><body>\n<h1>{}</h1>\n",
        escape(title)
    );
    if shots.is_empty() {
        html += "<p class=\"passed\">Every shot matches its golden.</p>\n";
    } else {
        let _ = writeln!(html, "<p class=\"how\">{}</p>", escape(how));
    }
    for shot in shots {
        let (name, summary) = (escape(&shot.shot), escape(&shot.summary));
        let _ = writeln!(html, "<h2>{name}</h2><p>{summary}</p>");
        for f in &shot.frames {
            frame(&mut html, f);
        }
    }
    let _ = write!(html, "<script>{SCRIPT}</script>\n</body></html>\n");
    let page = dir.join("index.html");
    crate::output::write_atomic(&page, &html)?;
    Ok(page)
}

fn frame(html: &mut String, f: &ReviewFrame) {
    let hash = |h: &Option<FrameHash>| h.map_or_else(|| "none".to_string(), |h| h.to_string());
    let n = f.frame;
    let _ = write!(html, "<div class=\"frame\" id=\"frame-{n}\"><h3>frame {n}");
    if let Some(p) = &f.pixels {
        let _ = write!(html, ": {p}");
    }
    let _ = write!(
        html,
        "</h3><div class=\"hash\">golden {}<br>new&nbsp;&nbsp;&nbsp; {}</div><div class=\"pictures\">",
        hash(&f.golden_hash),
        hash(&f.fresh_hash)
    );
    match (&f.golden, &f.new) {
        (Some(golden), Some(new)) => {
            let _ = write!(
                html,
                "<figure><div class=\"compare\" data-split=\"50\"><img class=\"golden\" src=\"{g}\" alt=\"golden frame {n}\"><img class=\"new\" src=\"{new}\" alt=\"new frame {n}\"></div>\
                 <figcaption>golden | new: <span class=\"controls\"><input class=\"slide\" type=\"range\" min=\"0\" max=\"100\" value=\"50\" aria-label=\"golden or new\"><button class=\"flip\">flip</button></span></figcaption></figure>",
                g = escape(golden),
                new = escape(new)
            );
        }
        (None, Some(new)) => {
            let why = if f.golden_hash.is_some() {
                "the golden keeps no picture of this frame"
            } else {
                "not in the golden"
            };
            let _ = write!(
                html,
                "<figure><img class=\"new\" src=\"{}\" alt=\"new frame {n}\"><figcaption>new ({why})</figcaption></figure>",
                escape(new)
            );
        }
        _ => html.push_str("<p>in the golden, but the animation no longer has this frame</p>"),
    }
    if let Some(diff) = &f.diff {
        let _ = write!(
            html,
            "<figure><img class=\"diff\" src=\"{}\" alt=\"difference, frame {n}\"><figcaption>changed pixels in magenta over the dimmed golden frame</figcaption></figure>",
            escape(diff)
        );
    }
    html.push_str("</div></div>\n");
}
