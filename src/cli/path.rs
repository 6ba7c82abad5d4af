//! `campath path`: the evaluated camera per frame, or the whole shot for another program, and
//! the warnings of formats that keep places in f32.

use std::io::Write;
use std::path::PathBuf;

use super::args::Shot;

use super::error::{CliError, Result};
use crate::document::Document;
use crate::export::PathFormat;
use crate::output::Use;

/// The options of `campath path`.
#[derive(clap::Args)]
pub struct PathArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// [default: from --out's extension (.csv, .json, .chan, .gltf, .glb, .py, .usda), else csv]
    #[arg(long, value_parser = super::args::path_format())]
    pub format: Option<PathFormat>,
    /// Write to this file instead of standard output; its extension must name a format (glTF:
    /// binary when it ends in .glb; USD: .usda or .usd).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write every place relative to this point of campath's world (glTF and Blender keep
    /// places in f32: a shot far from the origin needs one near it).
    #[arg(long, value_name = "X,Y,Z", value_parser = super::args::point, allow_hyphen_values = true)]
    pub origin: Option<glam::DVec3>,
    /// The number campath's frame 0 gets in every format: frame k is written as frame k + N (the
    /// CSV and JSON `frame`, the .chan frame, Blender's scene frame, USD's time code, glTF's time
    /// (k + N) / fps); the `t` column stays k / fps. Nuke counts from 1: --first-frame 1.
    #[arg(long, value_name = "N", default_value_t = 0,
          value_parser = clap::value_parser!(u64).range(..=crate::export::MAX_FIRST_FRAME))]
    pub first_frame: u64,
}

/// `campath path`: the evaluated camera per frame (or the whole shot as glTF) on standard
/// output, or into `--out` (binary glTF when it ends in `.glb`).
pub fn path(a: PathArgs, out: &mut dyn Write) -> Result<()> {
    let file_out = a.out.as_deref();
    let format = super::args::resolve_format(a.format, file_out)?;
    let origin = a.origin.unwrap_or_default();
    // Not into a golden or a folder of rendered frames: the next render there would refuse
    // the folder for holding a file campath did not write.
    if let Some(target) = file_out {
        crate::output::check(target, Use::File)
            .map_err(|r| CliError::refused("--out", target, &r))?;
    }
    if format == PathFormat::Usd {
        if let Some(ext) = file_out.and_then(|p| p.extension()) {
            if !ext.eq_ignore_ascii_case("usda") && !ext.eq_ignore_ascii_case("usd") {
                return Err(CliError::Usage(format!(
                    "campath writes USD's text form: name the file .usda (or .usd), not .{}; \
                     OpenUSD converts it, e.g. in Python: pxr.Sdf.Layer.FindOrOpen(\"shot.usda\").Export(\"shot.usdc\")",
                    ext.to_string_lossy()
                )));
            }
        }
    }
    let doc = Document::load(&a.shot.file)?;
    let frames = doc.animation.frames;
    let first_frame = a.first_frame;
    let last_number = first_frame + frames - 1;
    if format == PathFormat::Blender && last_number > crate::export::BLENDER_LAST_FRAME {
        let way = match first_frame {
            0 => "write the shot in parts",
            _ => "give a smaller --first-frame",
        };
        return Err(CliError::Usage(format!(
            "campath's last frame would be Blender's frame {last_number} (--first-frame \
             {first_frame} and {frames} frames), past Blender's last, {}; nothing was written: \
             {way}",
            crate::export::BLENDER_LAST_FRAME
        )));
    }
    let glb =
        file_out.is_some_and(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb")));
    // Before anything is written: places that f32 cannot hold are refused, and a reader that
    // keeps f32 (glTF, Blender, Blender's USD importer) is warned of rounding.
    if matches!(
        format,
        PathFormat::Gltf | PathFormat::Blender | PathFormat::Usd
    ) {
        if let Some(place) = crate::export::past_f32_in(&doc, format, origin) {
            return Err(CliError::Usage(format!(
                "{place} lies past f32's range (±3.4e38){}, which {} keeps; nothing was written",
                if origin == glam::DVec3::ZERO {
                    String::new()
                } else {
                    " relative to --origin".to_string()
                },
                format.title()
            )));
        }
        f32_warning(&doc, format, origin)?;
    } else if origin != glam::DVec3::ZERO {
        eprintln!(
            "campath: note: {} has no place to record --origin: its places are relative to \
             ({}, {}, {}) without saying so",
            format.title(),
            origin.x,
            origin.y,
            origin.z
        );
    }
    let dropped = match file_out {
        Some(path) => {
            super::args::create_parent(path)?;
            crate::output::write_atomic_with(path, |file| {
                crate::export::write_path(&doc, format, glb, origin, first_frame, file)
            })?
        }
        None => crate::export::write_path(&doc, format, glb, origin, first_frame, out)?,
    };
    if dropped.off_axis > 0 {
        let (off_axis, first, last) = (dropped.off_axis, dropped.first, dropped.last);
        let which = match (format, first_frame) {
            (PathFormat::Chan, 0) => format!(", campath frames {first}..={last},"),
            (PathFormat::Chan, n) => format!(
                ", campath frames {first}..={last} (.chan frames {}..={}),",
                first + n,
                last + n
            ),
            _ => String::new(),
        };
        eprintln!(
            "campath: note: {} has no place for an off-axis COP (distort): {off_axis} of {frames} \
             frame(s){which} are written as if the COP were on the VPN, so their pictures are \
             centred; csv, json, blender and usd keep the COP",
            format.title()
        );
    }
    Ok(())
}

/// Warns when glTF or Blender (or Blender's USD importer), keeping places in f32, would move
/// the camera's picture by a quarter of a pixel or more (a shot far from the origin), and
/// names an origin that keeps it near zero.
fn f32_warning(doc: &Document, format: PathFormat, origin: glam::DVec3) -> Result<()> {
    const MOST_PX: f64 = 0.25;
    let Some(shift) = crate::export::f32_shift(doc, origin)? else {
        return Ok(());
    };
    if shift.px < MOST_PX {
        return Ok(());
    }
    let m = shift.middle;
    let better = crate::export::f32_shift(doc, m)?.map_or(0.0, |s| s.px);
    let hint = if better < MOST_PX {
        format!(
            "--origin {},{},{} (the middle of the camera's path) writes every place relative to \
             it (about {better:.1e} px)",
            m.x, m.y, m.z
        )
    } else {
        "the camera's path is too long for f32 at this scale: write the shot in parts, each \
         with an --origin near it, or read the USD with OpenUSD, which keeps f64"
            .to_string()
    };
    let keeps = match format {
        PathFormat::Usd => "USD keeps f64, but Blender's USD importer keeps places in f32",
        _ => "keeps places in f32",
    };
    let title = match format {
        PathFormat::Usd => String::new(),
        _ => format!("{} ", format.title()),
    };
    eprintln!(
        "campath: warning: {title}{keeps}: this far from the origin, rounding moves the camera \
         by {:.1e} at frame {}, about {:.1} px on the nearest sphere; {hint}",
        shift.units, shift.frame, shift.px
    );
    Ok(())
}
