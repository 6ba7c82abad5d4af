//! `campath import`: a camera from another program as a keyframe file, with the fewest keys
//! that reproduce it within a tolerance in pixels (`crate::import`).

use std::io::Write;
use std::path::PathBuf;

use super::error::{CliError, Result};
use crate::import::fit::{self, Options};
use crate::output::Use;

/// `campath import`'s options.
#[derive(clap::Args)]
pub struct ImportArgs {
    /// The camera's source: campath's `path` CSV or JSON, nerfstudio's camera_path.json,
    /// OpenUSD's .usda, glTF's .gltf or .glb.
    pub source: PathBuf,
    /// Where the keyframe file (.ron) goes [default: standard output].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The largest error allowed at any sample: pixels of the file's image.
    #[arg(long, default_value_t = fit::TOLERANCE, value_parser = positive)]
    pub tolerance: f64,
    /// The camera to read, where the source has several (its name or path).
    #[arg(long)]
    pub camera: Option<String>,
    /// The image's width in pixels [default: the source's, or 1920].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: Option<u32>,
    /// The image's height in pixels [default: the source's, or the width in the field of
    /// view's aspect].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: Option<u32>,
    /// Frames per second [default: the source's, or 24].
    #[arg(long, value_parser = positive)]
    pub fps: Option<f64>,
    /// The nearest distance from the camera, in world units, at which the picture must hold.
    #[arg(long, default_value_t = 1.0, value_parser = positive)]
    pub near: f64,
}

/// A finite number > 0.
fn positive(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("{s:?}: a number > 0")),
    }
}

/// Reads the source, fits it and writes the keyframe file; says on standard error how many
/// keys it took and the worst error.
pub fn run(a: ImportArgs, out: &mut dyn Write) -> Result<()> {
    if let Some(target) = &a.out {
        super::args::check_extension("--out", target, &["ron"], "import writes a keyframe file")?;
        crate::output::check(target, Use::File)
            .map_err(|r| CliError::refused("--out", target, &r))?;
        super::args::check_writable(target)?;
    }
    let source = crate::import::read(&a.source, a.camera.as_deref())?;
    let first = source.samples[0].window;
    let width = a.width.or(source.size.map(|s| s.0)).unwrap_or(1920);
    let height = (a.height)
        .or(source.size.filter(|s| s.0 == width).map(|s| s.1))
        .unwrap_or_else(|| ((f64::from(width) * first.y / first.x).round() as u32).max(1));
    let side = crate::raster::MAX_SIDE;
    if width > side || height > side {
        return Err(CliError::Usage(format!(
            "the image would be {width}×{height} pixels, past campath's {side} a side: give \
             --width and --height"
        )));
    }
    let options = Options {
        tolerance: a.tolerance,
        size: (width, height),
        fps: a.fps.or(source.fps).unwrap_or(24.0),
        near: a.near,
    };
    let fitted = fit::fit(&source, &options).map_err(|message| crate::Error::Import {
        path: a.source.clone(),
        message,
    })?;
    let (worst, at) = fitted.worst;
    let frame = at * options.fps;
    let summary = format!(
        "{} sample(s) of {:?} as {} key(s) ({}); worst error {worst:.4} px at {at} s (frame \
         {frame}), tolerance {} px at {width}×{height}, nearest point {} units",
        source.samples.len(),
        source.camera,
        fitted.keys,
        fitted.tracks.join(", "),
        a.tolerance,
        a.near,
    );
    let text = format!(
        "// Imported by campath {} from {}: {summary}.\n// Add the scene: scene: (spheres: [...], ...).\n{}",
        env!("CARGO_PKG_VERSION"),
        a.source.display(),
        fitted.text
    );
    match &a.out {
        Some(path) => {
            super::args::create_parent(path)?;
            crate::output::write_atomic(path, text)?;
            writeln!(out, "wrote {}: {summary}", path.display()).map_err(crate::Error::stdout)?;
        }
        None => {
            out.write_all(text.as_bytes())
                .map_err(crate::Error::stdout)?;
            eprintln!("campath: {summary}");
        }
    }
    Ok(())
}
