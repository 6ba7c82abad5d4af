//! What every chart shares: the built-in font, an RGB bitmap, drawing errors, and the PNG.

use std::path::Path;

use plotters::prelude::*;

use super::error::{CliError, Result};
use crate::output::{write_png, Compression};

/// DejaVu Sans (free licence: src/cli/fonts/DejaVuSans-LICENSE.txt), built in so that charts need
/// no system font.
static FONT: &[u8] = include_bytes!("fonts/DejaVuSans.ttf");

/// Registers the built-in DejaVu Sans as plotters' "sans-serif", once.
pub fn register_font() {
    use std::sync::Once;
    static DONE: Once = Once::new();
    DONE.call_once(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .map_err(|_| ())
            .expect("the built-in font is a valid TrueType file");
    });
}

/// A drawing failure, for `map_err`.
pub fn draw_error<E: std::error::Error + Send + Sync>(
    path: &Path,
) -> impl Fn(DrawingAreaErrorKind<E>) -> CliError + '_ {
    move |e| CliError::Draw {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// What drawing returns: plotters' error, made the command's in [`draw_png`].
pub type Drawn = std::result::Result<
    (),
    DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>,
>;

/// Draws on a white `size` bitmap with `draw`, then writes it to `path` as a PNG.
pub fn draw_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Drawn,
) -> Result<()> {
    register_font();
    let mut buf = vec![255u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error(path))?;
        draw(root.clone()).map_err(draw_error(path))?;
        root.present().map_err(draw_error(path))?;
    }
    Ok(write_png(path, &buf, size, Compression::Fast)?)
}
