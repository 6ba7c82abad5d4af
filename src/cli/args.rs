//! Option values as the command line writes them, parsed by clap into typed values, and the
//! command line's default paths.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use super::error::{CliError, Result};
use crate::document::MAX_FRAMES;
use crate::export::PathFormat;
use crate::output::Compression;

/// The keyframe file a verb reads.
#[derive(clap::Args)]
pub struct Shot {
    /// The keyframe file (RON; see docs/format.md).
    pub file: PathBuf,
}

/// `--quiet`.
#[derive(clap::Args)]
pub struct Quiet {
    /// Print nothing.
    #[arg(id = "quiet", long = "quiet", short = 'q')]
    pub on: bool,
}

/// `--no-wait`.
#[derive(clap::Args)]
pub struct NoWait {
    /// If another run is writing the output folder, refuse (exit 2) instead of waiting.
    #[arg(id = "no_wait", long = "no-wait")]
    pub on: bool,
}

/// `--stats-json`.
#[derive(clap::Args)]
pub struct StatsJson {
    /// Also write the run's numbers (frames, times, peak memory) as JSON to this file.
    #[arg(id = "stats_json", long = "stats-json", value_name = "FILE")]
    pub path: Option<PathBuf>,
}

/// `--frames`: `A..B` (frames A to B − 1), `A..` (A to the end), `..B`, `A..=B` or a single `K`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSpec {
    start: u64,
    /// Exclusive end; None for "to the end".
    end: Option<u64>,
    text_inclusive: bool,
}

impl FromStr for FrameSpec {
    type Err = String;

    fn from_str(spec: &str) -> Result<FrameSpec, String> {
        // A frame number below `bound`: MAX_FRAMES for a frame, one more for an exclusive end.
        let bounded = |s: &str, bound: u64| {
            let n = s.trim().parse::<u64>().map_err(|_| {
                format!("{spec:?}: expected A..B, A.., ..B, A..=B or K with whole numbers")
            })?;
            match n < bound {
                true => Ok(n),
                false => Err(format!(
                    "{spec:?}: {n} is past every frame (a file has at most {MAX_FRAMES} frames)"
                )),
            }
        };
        let num = |s: &str| bounded(s, MAX_FRAMES);
        let start = |a: &str| if a.is_empty() { Ok(0) } else { num(a) };
        let (start, end, inclusive) = if let Some((a, b)) = spec.split_once("..=") {
            (start(a)?, Some(num(b)? + 1), true)
        } else if let Some((a, b)) = spec.split_once("..") {
            let end = (!b.is_empty()).then(|| bounded(b, MAX_FRAMES + 1));
            let end = end.transpose()?;
            (start(a)?, end, false)
        } else {
            let k = num(spec)?;
            (k, Some(k + 1), false)
        };
        if end.is_some_and(|e| start >= e) {
            return Err(format!("{spec:?}: the range is empty"));
        }
        Ok(FrameSpec {
            start,
            end,
            text_inclusive: inclusive,
        })
    }
}

impl FrameSpec {
    /// The frames of an animation of `frames` frames, or an error if the spec reaches past it.
    pub fn resolve(spec: Option<FrameSpec>, frames: u64) -> Result<Range<u64>> {
        let Some(s) = spec else {
            return Ok(0..frames);
        };
        let range = s.start..s.end.unwrap_or(frames);
        if range.end > frames || range.start >= range.end {
            let shown = if s.text_inclusive {
                format!("{}..={}", range.start, range.end - 1)
            } else {
                format!("{}..{}", range.start, range.end)
            };
            let message = format!("--frames {shown}: the animation has frames 0..{frames}");
            return Err(CliError::Usage(message));
        }
        Ok(range)
    }
}

/// `--compression`: the library's levels, with a line of help each.
pub fn compression() -> impl clap::builder::TypedValueParser<Value = Compression> {
    let help = |c: Compression| match c {
        Compression::Fast => "Fastest encoding, larger files",
        Compression::Default => "zlib's default level",
        Compression::Best => "Smallest files, slowest encoding",
    };
    choice(Compression::ALL.map(|c| (c, c.name(), help(c))))
}

/// `path --origin X,Y,Z`: three finite numbers.
pub fn point(s: &str) -> std::result::Result<glam::DVec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let numbers: Vec<f64> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    match numbers[..] {
        [x, y, z] if parts.len() == 3 && numbers.iter().all(|n| n.is_finite()) => {
            Ok(glam::DVec3::new(x, y, z))
        }
        _ => Err(format!("expected X,Y,Z (three finite numbers), not {s:?}")),
    }
}

/// `path --format`: the library's formats, with a line of help each.
pub fn path_format() -> impl clap::builder::TypedValueParser<Value = PathFormat> {
    let help = |f: PathFormat| match f {
        PathFormat::Csv => "frame, t, VRP, u, v, n, cop_world, window (one row per frame)",
        PathFormat::Json => "an array of per-frame objects with the same fields",
        PathFormat::Chan => {
            "`frame tx ty tz rx ry rz vfov` for Nuke (Nuke counts from 1: --first-frame 1)"
        }
        PathFormat::Gltf => "the whole shot as glTF 2.0 (binary when --out ends in .glb)",
        PathFormat::Blender => "a Python script for Blender that builds the whole shot",
        PathFormat::Usd => "the whole shot as an OpenUSD stage (USDA), lens shift included",
    };
    choice(PathFormat::ALL.map(|f| (f, f.name(), help(f))))
}

/// A clap parser for one of `values` (value, name, help): the library's enums on the command
/// line without a second copy of them here.
fn choice<T: Copy + Send + Sync + 'static, const N: usize>(
    values: [(T, &'static str, &'static str); N],
) -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    let names = values.map(|(_, name, help)| PossibleValue::new(name).help(help));
    PossibleValuesParser::new(names).map(move |name| {
        values
            .iter()
            .find(|(_, n, _)| *n == name)
            .map(|(v, _, _)| *v)
            .expect("clap accepts only the possible values")
    })
}

/// `--format`, or the one `--out`'s extension says (CSV when neither is given). An `--out`
/// whose extension names no format (`.txt`, `.fbx`, none) is refused, `--format` or not: the
/// name of a file should say what it holds. A `--format` that the extension contradicts is
/// refused too. `.usdc` and `.usdz` are USD's, which [`super::path::path`] refuses with a way to
/// convert.
pub fn resolve_format(format: Option<PathFormat>, out: Option<&Path>) -> Result<PathFormat> {
    let Some(out) = out else {
        return Ok(format.unwrap_or_default());
    };
    const KNOWN: &str = ".csv, .json, .chan, .gltf, .glb, .py or .usda (.usd)";
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let by_name = match ext.as_deref() {
        Some("usdc" | "usdz") => Some(PathFormat::Usd),
        _ => PathFormat::of_extension(out),
    };
    let named = out.display();
    match (format, by_name, ext) {
        (Some(f), Some(n), _) if f != n => Err(CliError::Usage(format!(
            "--out {named} names a {} file, but --format {} writes {}: change the extension or \
             leave --format out",
            n.title(),
            f.name(),
            f.title()
        ))),
        (_, Some(n), _) => Ok(n),
        (format, None, ext) => {
            let what = match ext {
                Some(ext) => format!("no format is written as .{ext}"),
                None => "the name has no extension to say its format".to_string(),
            };
            let name_it = match format {
                Some(f) => format!(
                    "--format {} writes {}: name the file so, as campath refuses a name that \
                     does not say its format",
                    f.name(),
                    f.extensions()
                ),
                None => format!("name the file {KNOWN}"),
            };
            Err(CliError::Usage(format!("--out {named}: {what}; {name_it}")))
        }
    }
}

/// A whole number ≥ 1.
pub fn at_least_one(s: &str) -> Result<u64, String> {
    let n = s.parse::<u64>().ok().filter(|n| *n >= 1);
    n.ok_or_else(|| "expected a whole number ≥ 1".into())
}

/// `out/<file stem>/`, relative to the working directory.
pub fn default_out_dir(file: &Path) -> PathBuf {
    // The stem as it is (a name that is not UTF-8 stays apart from others).
    let stem = file.file_stem().unwrap_or("render".as_ref());
    Path::new("out").join(stem)
}

/// Refuses (exit 2, before any work) a report `path` given as `option` that exists and is not
/// `what` campath wrote there, as `ours` tells from its bytes: a report never overwrites a shot,
/// a golden or anything else.
pub fn report_target(
    option: &str,
    path: &Path,
    what: &str,
    ours: impl Fn(&[u8]) -> bool,
) -> Result<()> {
    if !path.exists() || path.is_file() && std::fs::read(path).is_ok_and(|b| ours(&b)) {
        return Ok(());
    }
    Err(CliError::Usage(format!(
        "{option} {} exists and is not {what} campath wrote; nothing was written (choose a new \
         path)",
        path.display()
    )))
}

/// Creates the folder a file will be written into, refusing a path below a file (no folder can
/// be made there).
pub fn create_parent(file: &Path) -> Result<()> {
    if let Some(above) = file.ancestors().skip(1).find(|p| p.is_file()) {
        let message = format!("{} is a file, not a folder", above.display());
        return Err(CliError::Usage(message));
    }
    match file.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            std::fs::create_dir_all(dir).map_err(|e| crate::Error::write(dir)(e).into())
        }
        _ => Ok(()),
    }
}

/// Refuses an output file whose extension is not one of `allowed` (the first is named as the
/// one to use), before any work: `what` says what is written, e.g. "plot writes PNG".
pub fn check_extension(option: &str, file: &Path, allowed: &[&str], what: &str) -> Result<()> {
    let ext = file
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if ext.as_deref().is_some_and(|e| allowed.contains(&e)) {
        return Ok(());
    }
    Err(CliError::Usage(format!(
        "{option} {}: {what}; name it .{}",
        file.display(),
        allowed.join(" or .")
    )))
}

/// Creates the folder `file` will be written into and checks that a file can be written there
/// (and that the name is not a folder).
pub fn check_writable(file: &Path) -> Result<()> {
    if file.is_dir() {
        let message = format!("{} is a folder: name the file to write", file.display());
        return Err(CliError::Usage(message));
    }
    create_parent(file)?;
    // A file beside it, as it is written before it is renamed into place (removed on drop).
    crate::output::temp_beside(file)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_specs() {
        let r = |s: &str| FrameSpec::resolve(Some(s.parse().unwrap()), 10).unwrap();
        assert_eq!(r("2..5"), 2..5);
        assert_eq!(r("7.."), 7..10);
        assert_eq!(r("..3"), 0..3);
        assert_eq!(r("2..=4"), 2..5);
        assert_eq!(r("9"), 9..10);
        assert!("5..5".parse::<FrameSpec>().is_err());
        assert!("a..b".parse::<FrameSpec>().is_err());
        assert!(FrameSpec::resolve(Some("2..11".parse().unwrap()), 10).is_err());
        assert!(FrameSpec::resolve(Some("10..".parse().unwrap()), 10).is_err());
        // Frame numbers lie below 10⁷, an exclusive end up to it.
        let most = |s: &str| FrameSpec::resolve(Some(s.parse().unwrap()), MAX_FRAMES).unwrap();
        assert_eq!(most("9999998..10000000"), 9_999_998..10_000_000);
        assert_eq!(most("..=9999999"), 0..10_000_000);
        for past in [
            "10000000",
            "..=10000000",
            "0..10000001",
            "18446744073709551615",
        ] {
            let e = past.parse::<FrameSpec>().unwrap_err();
            assert!(e.contains("is past every frame"), "{past}: {e}");
        }
    }

    #[test]
    fn path_formats_from_the_extension() {
        let r = |f: Option<PathFormat>, out: &str| resolve_format(f, Some(Path::new(out)));
        assert_eq!(r(None, "x.glb").unwrap(), PathFormat::Gltf);
        assert_eq!(r(None, "x.GLTF").unwrap(), PathFormat::Gltf);
        assert_eq!(r(None, "x.py").unwrap(), PathFormat::Blender);
        // A name that does not say its format is refused, with --format too.
        assert!(r(None, "x.txt").is_err());
        assert!(r(Some(PathFormat::Json), "x.txt").is_err());
        assert!(r(Some(PathFormat::Csv), "cameras").is_err());
        assert_eq!(
            r(Some(PathFormat::Chan), "x.chan").unwrap(),
            PathFormat::Chan
        );
        assert!(r(Some(PathFormat::Csv), "x.glb").is_err());
        assert!(r(None, "x.fbx").is_err());
        assert_eq!(r(None, "x.usdz").unwrap(), PathFormat::Usd);
        assert!(r(Some(PathFormat::Csv), "x.usdc").is_err());
        assert!(r(None, "cameras").is_err());
        assert_eq!(resolve_format(None, None).unwrap(), PathFormat::Csv);
        let given = resolve_format(Some(PathFormat::Json), None).unwrap();
        assert_eq!(given, PathFormat::Json);
    }
}
