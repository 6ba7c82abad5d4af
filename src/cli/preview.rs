//! `campath preview`: a contact sheet PNG and an animated GIF at a small size, to look over a
//! sequence quickly. The camera and window are the file's; only the raster shrinks.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::args::{default_out_dir, Shot};
use super::chart::draw_error;
use super::error::{CliError, Result};
use crate::document::Document;
use crate::frames::{for_each_frame, FrameSet};
use crate::output::{write_png_atomic, Compression, Use};
use crate::render::Raster;
use crate::Error;

/// Columns of the contact sheet.
pub const COLUMNS: u32 = 4;
/// Pixels between tiles.
pub const GAP: u32 = 2;
/// Pixels of the band under each tile that holds its frame number.
pub const LABEL: u32 = 16;
/// Most frames in the GIF; longer sequences are sampled evenly.
pub const GIF_FRAMES: u64 = 120;

/// The options of `campath preview`.
#[derive(clap::Args)]
pub struct PreviewArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// Output folder [default: out/<file stem>/].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Width of each small frame in pixels, up to the file's width [default: 240, or the
    /// file's width if smaller].
    #[arg(long)]
    pub width: Option<u32>,
    /// Frames on the contact sheet, spread evenly, up to the file's frame count [default: 12,
    /// or every frame if fewer].
    #[arg(long)]
    pub count: Option<u64>,
}

/// `campath preview`: the sheet and the GIF, written into the output folder under its lock.
pub fn run(a: PreviewArgs, out: &mut dyn std::io::Write) -> Result<()> {
    let doc = Document::load(&a.shot.file)?;
    let dir = a.out.unwrap_or_else(|| default_out_dir(&a.shot.file));
    let width = a.width.unwrap_or(doc.raster.width.min(240));
    let count = a.count.unwrap_or(doc.animation.frames.min(12));
    check(&doc, width, count)?;
    doc.check_path()?;
    // As render: a golden or a folder of other files is refused, and a folder is written by one
    // run at a time.
    crate::output::check(&dir, Use::Frames).map_err(|r| CliError::refused("--out", &dir, &r))?;
    let _lock = super::progress::lock_whole(&dir, false)?;
    let png = write(&doc, &dir, width, count, true)?;
    let gif = dir.join(crate::output::pictures::GIF);
    Ok(writeln!(out, "wrote {} and {}", png.display(), gif.display()).map_err(Error::stdout)?)
}

/// The small raster: `width` pixels wide, the file's aspect, one sample per pixel.
pub fn small_raster(doc: &Document, width: u32) -> Raster {
    let r = doc.raster;
    let width = width.clamp(1, r.width);
    let height = ((r.height as f64 * width as f64 / r.width as f64).round() as u32).max(1);
    Raster {
        width,
        height,
        samples: 1,
        adaptive: false,
    }
}

/// `count` frame numbers spread evenly over the animation, first and last included.
pub fn sheet_frames(frames: u64, count: u64) -> Vec<u64> {
    let count = count.clamp(1, frames);
    (0..count)
        .map(|k| k * (frames - 1) / (count - 1).max(1))
        .collect()
}

/// Refuses a `width` outside 1 to the file's width, or a `count` outside 1 to its frame count.
pub fn check(doc: &Document, width: u32, count: u64) -> Result<()> {
    let frames = doc.animation.frames;
    if !(1..=doc.raster.width).contains(&width) {
        return Err(CliError::Usage(format!(
            "--width {width}: the preview is 1 to {} pixels wide (the file's width)",
            doc.raster.width
        )));
    }
    if !(1..=frames).contains(&count) {
        return Err(CliError::Usage(format!(
            "--count {count}: the contact sheet shows 1 to {frames} frames (the file's frame count)"
        )));
    }
    Ok(())
}

/// Writes `dir/preview.png` (a sheet of `count` frames) and, with `gif`, `dir/preview.gif`
/// (at most [`GIF_FRAMES`] frames, evenly spaced); returns the sheet's path. Only the frames shown are
/// rendered. The caller holds the folder's lock; `width` and `count` are as [`check`] takes them.
pub fn write(doc: &Document, dir: &Path, width: u32, count: u64, gif: bool) -> Result<PathBuf> {
    check(doc, width, count)?;
    let frames = doc.animation.frames;
    std::fs::create_dir_all(dir).map_err(Error::write(dir.to_path_buf()))?;
    let raster = small_raster(doc, width);
    let small = Document {
        raster,
        ..doc.clone()
    };
    let sheet_at = sheet_frames(frames, count);
    // At most GIF_FRAMES frames, and at most 50 a second: browsers show a GIF frame of less
    // than 2 centiseconds for 10.
    let step = frames
        .div_ceil(GIF_FRAMES)
        .max((doc.animation.fps / 50.0).ceil() as u64)
        .max(1);
    let (w, h) = (raster.width, raster.height);
    let rows = (sheet_at.len() as u32).div_ceil(COLUMNS);
    let cols = (sheet_at.len() as u32).min(COLUMNS);
    // A tile's slot is as wide as its frame number, when that is wider than the tile.
    let slot_w = w.max(label_width(&sheet_at, w));
    let (row_h, sheet_w) = (h + LABEL, cols * slot_w + (cols - 1) * GAP);
    let sheet_h = rows * row_h + (rows - 1) * GAP;
    let mut sheet = vec![255u8; (sheet_w * sheet_h * 3) as usize];
    // The GIF, encoded as its frames come: its bytes are all it holds.
    let gif_path = dir.join(crate::output::pictures::GIF);
    let mut bytes = Vec::new();
    let mut encoder = gif.then(|| image::codecs::gif::GifEncoder::new_with_speed(&mut bytes, 10));
    if let Some(e) = &mut encoder {
        e.set_repeat(image::codecs::gif::Repeat::Infinite)
            .map_err(Error::encode(gif_path.clone()))?;
    }
    // GIF frame k is shown from centisecond `at(k)` (GIF's unit) on: each delay rounds the
    // times, not the step, so a long GIF keeps the file's pace.
    let at = |k: u64| (100.0 * (k * step) as f64 / doc.animation.fps).round();
    for_each_frame(
        &small,
        &FrameSet::all(0..frames),
        |frame| !(sheet_at.contains(&frame) || gif && frame % step == 0),
        |frame, _, pixels, _| {
            if let Some(slot) = sheet_at.iter().position(|f| *f == frame) {
                let (cx, cy) = tile(slot, slot_w, row_h);
                for (y, row) in (0..).zip(pixels.chunks(w as usize * 3)) {
                    let dst = (((cy + y) * sheet_w + cx) * 3) as usize;
                    sheet[dst..dst + row.len()].copy_from_slice(row);
                }
            }
            if let Some(encoder) = encoder.as_mut().filter(|_| frame % step == 0) {
                let rgb = image::RgbImage::from_raw(w, h, pixels.to_vec());
                let img = image::DynamicImage::from(rgb.expect("w×h pixels")).into_rgba8();
                let k = frame / step;
                // GIF's longest delay is 655.35 s.
                let centis = ((at(k + 1) - at(k)).clamp(2.0, 65535.0) as u32).max(2);
                let delay = image::Delay::from_numer_denom_ms(10 * centis, 1);
                encoder
                    .encode_frame(image::Frame::from_parts(img, 0, 0, delay))
                    .map_err(Error::encode(gif_path.clone()))?;
            }
            Ok(())
        },
    )?;
    drop(encoder);
    let (png, size) = (dir.join(crate::output::pictures::SHEET), (sheet_w, sheet_h));
    // Each tile's frame number, in the band under it.
    let root = BitMapBackend::with_buffer(&mut sheet, size).into_drawing_area();
    let font = label_font(w).color(&BLACK);
    for (slot, frame) in sheet_at.iter().enumerate() {
        let (x, y) = tile(slot, slot_w, row_h);
        let at = (x as i32 + 2, (y + h + 3) as i32);
        let label = Text::new(format!("{frame}"), at, font.clone());
        root.draw(&label).map_err(draw_error(&png))?;
    }
    root.present().map_err(draw_error(&png))?;
    drop(root);
    write_png_atomic(&png, &sheet, size, Compression::Default)?;
    if gif {
        // Through a temporary file, as every picture: a run stopped half-way leaves the last GIF.
        crate::output::write_atomic(&gif_path, &bytes)?;
    }
    Ok(png)
}

/// The top-left pixel of the sheet's tile `slot`, of slots `slot_w` wide and rows `row_h` high.
fn tile(slot: usize, slot_w: u32, row_h: u32) -> (u32, u32) {
    let (col, row) = (slot as u32 % COLUMNS, slot as u32 / COLUMNS);
    (col * (slot_w + GAP), row * (row_h + GAP))
}

/// The font of the frame numbers under tiles `w` pixels wide.
fn label_font(w: u32) -> FontDesc<'static> {
    super::chart::register_font();
    let size = (LABEL as f64 * 0.8).min(f64::from(w) / 4.0).max(6.0);
    ("sans-serif", size).into_font()
}

/// The width the widest frame number of `frames` needs under tiles `w` pixels wide, with its
/// margin.
fn label_width(frames: &[u64], w: u32) -> u32 {
    let font = label_font(w);
    frames
        .iter()
        .filter_map(|f| font.box_size(&f.to_string()).ok())
        .map(|(width, _)| width + 4)
        .max()
        .unwrap_or(0)
}
