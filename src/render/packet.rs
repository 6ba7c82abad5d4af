//! Ray packets: [`LANES`] neighbouring pixels of a row (or samples of neighbouring pixels) cast
//! together, primary and shadow rays alike, and the choice of CPU instructions that runs them.
//!
//! This is the renderer's only copy of each step: the ray directions, the hit, the shading, the
//! shadow rays, adaptive sampling and the sRGB levels. Each lane does exactly the operations, in
//! exactly the order, of the plain one-ray-at-a-time oracle in the tests
//! (tests/it/reference.rs): the same dot products, the same stable roots, the same tests. Only
//! the control flow differs — branches become 8-bit lane masks, and a packet leaves the sorted
//! candidate list once every lane would have left it. IEEE addition, multiplication, division
//! and square root are correctly rounded at every vector width, Rust never fuses a multiply and
//! an add on its own, and nothing here uses an approximate reciprocal, so every [`Simd`] path
//! gives the same bits. The code is written once against [`Lanes`] (`lanes.rs`): one
//! AVX-512 register, two AVX2 registers, or arrays the compiler vectorises for SSE2.
//!
//! A packet's work is a long chain of dependent square roots, divisions and table lookups, so
//! a row is taken a stretch at a time and stage by stage: every packet's directions, then every
//! packet's nearest hit (two packets of a tile together), then every colour, then every sRGB
//! level. Each stage is a short loop over independent packets, which the CPU overlaps; taken
//! packet by packet, the same work ran 15–20% slower.

use super::bins::CellRect;
use super::lanes::{InBounds, Isa, Lanes, Portable};
use super::shadows::{cell_key, cell_range, FrameShadows};
use super::tiles::{TileBins, TILE};
use super::{RayTable, Shading, SrgbEncoder, ViewColumns, ViewSphere, BUCKETS, SPLIT};
use crate::raster::MAX_SAMPLES;

/// Rays per packet: a whole AVX-512 register, two AVX2 ones or four SSE2 ones of f64. Divides
/// the tile side, so a packet never straddles two tiles.
pub const LANES: usize = 8;

/// Most samples in one cast (`RowJob::cast`): a group of pixels at s×s samples holds four of
/// them up to 8×8, two up to 11×11 and one above; adaptive sampling fits as many pixels' other
/// samples as it can.
const MAX_GROUP_SAMPLES: usize = (MAX_SAMPLES * MAX_SAMPLES) as usize;

/// Pixels `first` .. `first + pixels` of row `row`, inside one tile.
#[derive(Clone, Copy)]
struct Span {
    row: usize,
    first: usize,
    pixels: usize,
}

/// The packets of a group of samples between the stages of [`RowJob::cast`]: their
/// directions, then their nearest hits. Made once per row.
struct Stages<V: Lanes> {
    dirs: [[V; 3]; MAX_GROUP_SAMPLES / LANES],
    founds: [Found<V>; MAX_GROUP_SAMPLES / LANES],
}

impl<V: Lanes> Stages<V> {
    #[inline(always)]
    fn new(tok: V::Token) -> Self {
        let zero = V::splat(tok, 0.0);
        Stages {
            dirs: [[zero; 3]; MAX_GROUP_SAMPLES / LANES],
            founds: [(0, V::index(tok, 0), zero); MAX_GROUP_SAMPLES / LANES],
        }
    }
}

/// A sample of a group of pixels: its column in the ray table's `xs` past the group's first
/// pixel's, and its line in `ys` past the pixel row's first.
type Sample = (u16, u16);

/// Sample k (row-major in the s×s grid) of pixel p of a group.
fn sample(s: usize, p: usize, k: usize) -> Sample {
    ((p * s + k % s) as u16, (k / s) as u16)
}

/// Pixels of a row whose directions are computed together; a multiple of [`LANES`].
const STRETCH: usize = 32 * LANES;

/// How the renderer casts its rays. Every choice gives the same bytes; they differ in speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Simd {
    /// The packet code on plain arrays of lanes (`Portable`), the form every target runs;
    /// on x86-64 the same code as `Baseline`.
    Scalar,
    /// Packets with the target's baseline vectors (SSE2 on x86-64).
    Baseline,
    /// Packets compiled for AVX2.
    Avx2,
    /// Packets compiled for AVX-512F.
    Avx512,
}

impl Simd {
    /// Every path, slowest first.
    pub const ALL: [Simd; 4] = [Simd::Scalar, Simd::Baseline, Simd::Avx2, Simd::Avx512];

    /// Whether this CPU can run the path.
    pub fn supported(self) -> bool {
        self.isa().is_some()
    }

    /// The path's instruction set, with the proof that this CPU runs it; None when it does not.
    pub(super) fn isa(self) -> Option<Isa> {
        match self {
            Simd::Scalar | Simd::Baseline => Some(Isa::Portable),
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2 => super::lanes::Avx2::detect().map(Isa::Avx2),
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512 => super::lanes::Avx512::detect().map(Isa::Avx512),
            #[cfg(not(target_arch = "x86_64"))]
            Simd::Avx2 | Simd::Avx512 => None,
        }
    }

    /// The fastest path this CPU runs.
    pub fn fastest() -> Simd {
        *Simd::ALL
            .iter()
            .rev()
            .find(|s| s.supported())
            .unwrap_or(&Simd::Scalar)
    }

    /// The path named by the environment variable `CAMPATH_SIMD` (`scalar`, `sse2`, `avx2`,
    /// `avx512`) when this CPU runs it, otherwise the fastest. The choice never changes the
    /// bytes; it is there to check exactly that, and to measure each path.
    pub fn detect() -> Simd {
        match Simd::from_env() {
            Some(Ok(s)) if s.supported() => s,
            _ => Simd::fastest(),
        }
    }

    /// `CAMPATH_SIMD` read and parsed, None when unset. An unknown name or a path this CPU
    /// cannot run is an error, for the command line to report.
    pub fn from_env() -> Option<Result<Simd, String>> {
        let name = std::env::var("CAMPATH_SIMD").ok()?;
        Some(name.parse::<Simd>().and_then(|s| {
            if s.supported() {
                Ok(s)
            } else {
                Err(format!("this CPU cannot run the {} path", s.name()))
            }
        }))
    }

    pub fn name(self) -> &'static str {
        match self {
            Simd::Scalar => "scalar",
            Simd::Baseline if cfg!(target_arch = "x86_64") => "sse2",
            Simd::Baseline => "baseline",
            Simd::Avx2 => "avx2",
            Simd::Avx512 => "avx512",
        }
    }
}

impl std::str::FromStr for Simd {
    type Err = String;

    fn from_str(s: &str) -> Result<Simd, String> {
        Simd::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Simd::ALL.iter().map(|p| p.name()).collect();
                format!(
                    "unknown instruction path {s:?}: one of {}",
                    names.join(", ")
                )
            })
    }
}

/// What one row needs: the scene in view coordinates, the ray table and the tiles.
pub struct RowJob<'a> {
    pub ctx: &'a Shading<'a>,
    pub table: &'a RayTable,
    pub bins: &'a TileBins,
    pub encode: &'a SrgbEncoder,
    /// The background's sRGB levels, for a packet's eight pixels.
    pub background: [u8; 3 * LANES],
    /// Samples per pixel side: 1, or s ≥ 2 for s×s samples averaged.
    pub samples: usize,
    /// With s ≥ 2: the corners first, the rest only where they disagree.
    pub adaptive: bool,
}

// Two packets side by side lie in one tile, and a stretch holds whole pairs.
const _: () = assert!(TILE.is_multiple_of(2 * LANES) && STRETCH.is_multiple_of(2 * LANES));

impl RowJob<'_> {
    /// Renders row `j` into `row` (RGB8) in packets, with the instruction set `isa`, which
    /// proves that the CPU runs it.
    pub fn row(&self, isa: Isa, j: usize, row: &mut [u8]) {
        let one = self.samples == 1;
        match isa {
            Isa::Portable if one => self.row_packets::<Portable>((), j, row),
            Isa::Portable => self.row_several::<Portable>((), j, row),
            // SAFETY: `t` proves AVX2.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2(t) if one => unsafe { self.row_avx2(t, j, row) },
            // SAFETY: `t` proves AVX2.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2(t) => unsafe { self.row_samples_avx2(t, j, row) },
            // SAFETY: `t` proves AVX-512F.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512(t) if one => unsafe { self.row_avx512(t, j, row) },
            // SAFETY: `t` proves AVX-512F.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512(t) => unsafe { self.row_samples_avx512(t, j, row) },
        }
    }

    /// A row of several samples a pixel, adaptive or not.
    #[inline(always)]
    fn row_several<V: Lanes>(&self, tok: V::Token, j: usize, row: &mut [u8]) {
        if self.adaptive {
            self.row_adaptive::<V>(tok, j, row)
        } else {
            self.row_samples::<V>(tok, j, row)
        }
    }

    // One function per path and per kind of row: each is compiled on its own, so the
    // single-sample loop keeps its registers and layout. Each takes the token that proves its
    // instruction set: `#[target_feature]` makes it unsafe to call without one.

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn row_avx2(&self, t: super::lanes::Avx2, j: usize, row: &mut [u8]) {
        self.row_packets::<super::lanes::Ymm2>(t, j, row)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn row_avx512(&self, t: super::lanes::Avx512, j: usize, row: &mut [u8]) {
        self.row_packets::<super::lanes::Zmm>(t, j, row)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn row_samples_avx2(&self, t: super::lanes::Avx2, j: usize, row: &mut [u8]) {
        self.row_several::<super::lanes::Ymm2>(t, j, row)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn row_samples_avx512(&self, t: super::lanes::Avx512, j: usize, row: &mut [u8]) {
        self.row_several::<super::lanes::Zmm>(t, j, row)
    }

    /// Row `j` with s×s samples a pixel (s = `self.samples` ≥ 2), as the one-ray code does it:
    /// each sample's colour, summed in sample order and divided by s². The samples of a group of
    /// pixels in one tile (4 pixels up to 8×8, 2 up to 11×11, else 1) are cast together
    /// ([`RowJob::cast`]), stage by stage.
    #[inline(always)]
    fn row_samples<V: Lanes>(&self, tok: V::Token, j: usize, row: &mut [u8]) {
        let s = self.samples;
        let s2 = s * s;
        // Four pixels a group, or as many as fit (a group stays inside a tile).
        let group = [4, 2, 1]
            .into_iter()
            .find(|g| g * s2 <= MAX_GROUP_SAMPLES)
            .unwrap_or(1);
        let mut colors = [[0.0; 3]; MAX_GROUP_SAMPLES];
        let mut stages = Stages::<V>::new(tok);
        // The group's samples in (pixel, sample) order.
        let list: Vec<Sample> = (0..group * s2)
            .map(|at| sample(s, at / s2, at % s2))
            .collect();
        for (g, out) in row.chunks_mut(3 * group).enumerate() {
            let i0 = g * group;
            let pixels = out.len() / 3;
            let n = pixels * s2;
            let span = Span {
                row: j,
                first: i0,
                pixels,
            };
            self.cast::<V, false>(span, &list[..n], &mut stages, &mut colors, &mut []);
            let mut linear = [[0.0; LANES]; 3];
            for p in 0..pixels {
                let mut sum = [0.0; 3];
                for c in &colors[p * s2..(p + 1) * s2] {
                    for a in 0..3 {
                        sum[a] += c[a];
                    }
                }
                for a in 0..3 {
                    linear[a][p] = sum[a] / s2 as f64;
                }
            }
            self.encode_pixels::<V>(tok, &linear, out);
        }
    }

    /// Row `j` with adaptive s×s samples: each pixel's four corner samples first, and the
    /// average of those where all four saw the same sphere lit by the same lights; elsewhere
    /// every sample, the corners reused, summed in order.
    /// A tile's pixels go together: all their corners, then the other samples of the pixels
    /// whose corners disagree.
    #[inline(always)]
    fn row_adaptive<V: Lanes>(&self, tok: V::Token, j: usize, row: &mut [u8]) {
        let s = self.samples;
        let s2 = s * s;
        let corners = [0, s - 1, s * (s - 1), s2 - 1];
        let corner_list: Vec<Sample> = (0..TILE)
            .flat_map(|p| corners.map(|k| sample(s, p, k)))
            .collect();
        let mut shaded = [[0.0; 3]; 4 * TILE];
        let mut seen = [0u64; 4 * TILE];
        let mut colors = [[0.0; 3]; MAX_GROUP_SAMPLES];
        let mut stages = Stages::<V>::new(tok);
        // A pixel's samples other than its corners, and where each sample's colour comes from:
        // a corner (its index among the four) or the next of those others.
        let others: Vec<usize> = (0..s2).filter(|k| !corners.contains(k)).collect();
        let corner_of: Vec<Option<usize>> = (0..s2)
            .map(|k| corners.iter().position(|&c| c == k))
            .collect();
        // The other samples of the disagreeing pixels of a tile, as many pixels a cast as fit.
        let per_cast = (MAX_GROUP_SAMPLES / others.len().max(1)).min(TILE);
        let mut rest: Vec<Sample> = Vec::with_capacity(MAX_GROUP_SAMPLES);
        let mut disagree = Vec::with_capacity(TILE);
        // The tile's pixels' linear colours, encoded a packet at a time once all are known.
        let mut linear = [[0.0; 3]; TILE];
        for (g, out) in row.chunks_mut(3 * TILE).enumerate() {
            let i0 = g * TILE;
            let pixels = out.len() / 3;
            let span = Span {
                row: j,
                first: i0,
                pixels,
            };
            let n = 4 * pixels;
            self.cast::<V, true>(span, &corner_list[..n], &mut stages, &mut shaded, &mut seen);
            disagree.clear();
            for p in 0..pixels {
                let (c, what) = (&shaded[4 * p..4 * p + 4], &seen[4 * p..4 * p + 4]);
                if what.iter().all(|w| *w == what[0]) {
                    for a in 0..3 {
                        linear[p][a] = (((c[0][a] + c[1][a]) + c[2][a]) + c[3][a]) / 4.0;
                    }
                } else {
                    disagree.push(p);
                }
            }
            for chunk in disagree.chunks(per_cast) {
                rest.clear();
                for &p in chunk {
                    rest.extend(others.iter().map(|&k| sample(s, p, k)));
                }
                self.cast::<V, false>(span, &rest, &mut stages, &mut colors, &mut []);
                for (m, &p) in chunk.iter().enumerate() {
                    let c = &shaded[4 * p..4 * p + 4];
                    let mut sum = [0.0; 3];
                    let mut next = colors[m * others.len()..].iter();
                    for corner in &corner_of {
                        let v = match *corner {
                            Some(m) => c[m],
                            None => *next.next().unwrap(),
                        };
                        for a in 0..3 {
                            sum[a] += v[a];
                        }
                    }
                    for a in 0..3 {
                        linear[p][a] = sum[a] / s2 as f64;
                    }
                }
            }
            for (q, out) in out.chunks_mut(3 * LANES).enumerate() {
                let mut lanes = [[0.0; LANES]; 3];
                for (l, c) in linear[q * LANES..].iter().take(out.len() / 3).enumerate() {
                    for a in 0..3 {
                        lanes[a][l] = c[a];
                    }
                }
                self.encode_pixels::<V>(tok, &lanes, out);
            }
        }
    }

    /// The sRGB levels of up to [`LANES`] pixels' linear colours (a lane per pixel, an array
    /// per channel) into `out`, RGB8, as many pixels as it holds.
    #[inline(always)]
    fn encode_pixels<V: Lanes>(&self, tok: V::Token, linear: &[[f64; LANES]; 3], out: &mut [u8]) {
        let mut rgb = [0u8; 3 * LANES];
        for (a, channel) in linear.iter().enumerate() {
            self.encode.encode_into(V::load(tok, channel), &mut rgb, a);
        }
        let n = out.len();
        out.copy_from_slice(&rgb[..n]);
    }

    /// Casts the samples `list` of the pixels of `span`, in packets of 8 (the last packet's
    /// spare lanes repeat the last sample): each one's linear colour into `colors`, and, when
    /// `SEEN`, what it saw into `seen`: the sphere (or `u64::MAX` for the background) in the
    /// high 32 bits and, in the low 32, which lights reach the point. Adaptive sampling compares
    /// these.
    #[inline(always)]
    fn cast<V: Lanes, const SEEN: bool>(
        &self,
        span: Span,
        list: &[Sample],
        stages: &mut Stages<V>,
        colors: &mut [[f64; 3]],
        seen: &mut [u64],
    ) {
        let tok = stages.dirs[0][0].token();
        let (s, t, n) = (self.samples, self.table, list.len());
        let Span {
            row: j,
            first: i0,
            pixels,
        } = span;
        let background = self.ctx.background.to_array();
        let candidates = self.bins.at(i0, j);
        let covers = |k: u32, _: usize| self.bins.covers(k, i0, i0 + pixels - 1, j);
        // Stage by stage, as `row_packets`: every packet's directions, then the nearest hits
        // two packets at a time, then the colours.
        let packets = n.div_ceil(LANES);
        let mut hints = [NO_HINT; HINTED_LIGHTS];
        let Stages { dirs, founds } = stages;
        for (q, d) in dirs[..packets].iter_mut().enumerate() {
            let mut xs = [0.0; LANES];
            let mut ys = [0.0; LANES];
            for l in 0..LANES {
                let (column, line) = list[(q * LANES + l).min(n - 1)];
                xs[l] = t.xs[i0 * s + column as usize];
                ys[l] = t.ys[j * s + line as usize];
            }
            let (x, y, z) = (V::load(tok, &xs), V::load(tok, &ys), V::splat(tok, t.dz));
            *d = unit(x, y, z, y.mul(y), z.mul(z));
        }
        for pair in 0..packets.div_ceil(2) {
            let d = [dirs[2 * pair], dirs[2 * pair + 1]];
            let live = [true, 2 * pair + 1 < packets];
            let found = self.ctx.nearest_packets(&d, candidates, covers, live);
            founds[2 * pair] = found[0];
            founds[2 * pair + 1] = found[1];
        }
        for q in 0..packets {
            let (hit, index, t) = founds[q];
            let (c, lights) = if hit == 0 {
                let [r, g, b] = background;
                ([[r; LANES], [g; LANES], [b; LANES]], [0; LANES])
            } else {
                let (c, lights) = self
                    .ctx
                    .shade_packet::<V, SEEN>(&dirs[q], hit, index, t, &mut hints);
                ([c[0].store(), c[1].store(), c[2].store()], lights)
            };
            let start = q * LANES;
            let end = (start + LANES).min(n);
            for (l, color) in colors[start..end].iter_mut().enumerate() {
                *color = [c[0][l], c[1][l], c[2][l]];
            }
            if SEEN {
                let index = V::index_store(index);
                for (l, what) in seen[start..end].iter_mut().enumerate() {
                    *what = if hit >> l & 1 == 1 {
                        index[l] << 32 | lights[l] as u64
                    } else {
                        u64::MAX
                    };
                }
            }
        }
    }

    /// Row `j` at one sample a pixel, a stretch at a time and stage by stage; the two packets of
    /// a tile's row are searched together: they share its candidates, and their chains of
    /// dependent work interleave.
    #[inline(always)]
    fn row_packets<V: Lanes>(&self, tok: V::Token, j: usize, row: &mut [u8]) {
        let width = row.len() / 3;
        let t = self.table;
        let (y, z) = (t.ys[j], t.dz);
        let (yy, zz) = (V::splat(tok, y * y), V::splat(tok, z * z));
        // A stretch of the row's unit directions (`row_direction`), computed ahead of its
        // packets: independent square roots and divisions, out of each packet's chain of
        // dependent work. The first stretch's are computed here, each next stretch's in this
        // stretch's last stage, packet by packet as its slots are freed: that stage reads
        // tables and stores bytes, and leaves the divider idle (1–2% less CPU time on the
        // dense cluster, 2–3% on fly1000, than in a loop of their own).
        let xs = &t.xs[..width];
        let mut dirs = [[V::splat(tok, 0.0); 3]; STRETCH / LANES];
        for (q, d) in dirs[..width.min(STRETCH).div_ceil(LANES)]
            .iter_mut()
            .enumerate()
        {
            *d = row_direction(xs, q * LANES, y, z, yy, zz);
        }
        // The stretch's nearest hits, then its colours, then its levels, each stage a short loop
        // over independent packets, so that one packet's square roots, divisions and table
        // lookups overlap the next one's.
        let mut founds = [(0u8, V::index(tok, 0), V::splat(tok, 0.0)); STRETCH / LANES];
        let mut colors = [[V::splat(tok, 0.0); 3]; STRETCH / LANES];
        // The shadow hints, along the whole row.
        let mut hints = [NO_HINT; HINTED_LIGHTS];
        for (s, out) in row.chunks_mut(3 * STRETCH).enumerate() {
            let i0 = s * STRETCH;
            let packets = (out.len() / 3).div_ceil(LANES);
            let next = i0 + STRETCH;
            let next_packets = width.saturating_sub(next).min(STRETCH).div_ceil(LANES);
            for pair in 0..packets.div_ceil(2) {
                let i0 = i0 + pair * 2 * LANES;
                let d = [dirs[2 * pair], dirs[2 * pair + 1]];
                // Pixels in each packet; the second is empty when a row ends after the first.
                let n = [
                    (width - i0).min(LANES),
                    (width - i0).saturating_sub(LANES).min(LANES),
                ];
                let candidates = self.bins.at(i0, j);
                let covers = |k: u32, q: usize| {
                    let first = i0 + q * LANES;
                    self.bins.covers(k, first, first + n[q] - 1, j)
                };
                let found = self
                    .ctx
                    .nearest_packets(&d, candidates, covers, [true, n[1] > 0]);
                founds[2 * pair] = found[0];
                founds[2 * pair + 1] = found[1];
            }
            for q in 0..packets {
                let (hit, index, t) = founds[q];
                if hit != 0 {
                    colors[q] = self
                        .ctx
                        .shade_packet::<V, false>(&dirs[q], hit, index, t, &mut hints)
                        .0;
                }
            }
            for (q, out) in out.chunks_mut(3 * LANES).enumerate() {
                // Packet q's direction is used: its slot takes the next stretch's packet q.
                if q < next_packets {
                    dirs[q] = row_direction(xs, next + q * LANES, y, z, yy, zz);
                }
                if founds[q].0 == 0 {
                    // All background (sky): the frame's background levels, already encoded;
                    // a whole packet's as one fixed-size copy, not a call to `memcpy`.
                    match <&mut [u8; 3 * LANES]>::try_from(&mut *out) {
                        Ok(rgb) => *rgb = self.background,
                        Err(_) => {
                            let n = out.len();
                            out.copy_from_slice(&self.background[..n]);
                        }
                    }
                    continue;
                }
                // Plain calls, not `array::map`: its closure is not inlined into the function
                // compiled for the instruction set, and would run its intrinsics out of line.
                // Each level straight to its pixel: in the row for a whole packet, through a
                // packet's worth of pixels at the row's end.
                let enc = self.encode;
                if let Ok(rgb) = <&mut [u8; 3 * LANES]>::try_from(&mut *out) {
                    for (a, &linear) in colors[q].iter().enumerate() {
                        enc.encode_into::<V>(linear, rgb, a);
                    }
                } else {
                    let mut rgb = [0u8; 3 * LANES];
                    for (a, &linear) in colors[q].iter().enumerate() {
                        enc.encode_into::<V>(linear, &mut rgb, a);
                    }
                    let n = out.len();
                    out.copy_from_slice(&rgb[..n]);
                }
            }
        }
    }
}

/// The unit directions of the packet of row pixels `at..at + LANES` (column positions `xs`,
/// the row's `y` and the view plane's `z`, with `yy` = y² and `zz` = z² in every lane),
/// normalised exactly as `DVec3::normalize` does (v · (1 / √(v·v))). Lanes past the row's end
/// repeat its last pixel. A plain function, not a closure: a closure is not inlined into the
/// row function compiled for the instruction set (1.5× the time, measured).
#[inline(always)]
fn row_direction<V: Lanes>(xs: &[f64], at: usize, y: f64, z: f64, yy: V, zz: V) -> [V; 3] {
    let tok = yy.token();
    let width = xs.len();
    let x = if at + LANES <= width {
        V::load(tok, xs[at..at + LANES].try_into().expect("LANES values"))
    } else {
        let mut v = [xs[width - 1]; LANES];
        v[..width - at].copy_from_slice(&xs[at..width]);
        V::load(tok, &v)
    };
    unit(x, V::splat(tok, y), V::splat(tok, z), yy, zz)
}

/// The unit vectors along (x, y, z) per lane, given yy = y² and zz = z² (a row's are the same in
/// every packet), normalised exactly as `DVec3::normalize` does: v · (1 / √((x² + y²) + z²)).
#[inline(always)]
fn unit<V: Lanes>(x: V, y: V, z: V, yy: V, zz: V) -> [V; 3] {
    let tok = x.token();
    let r = V::splat(tok, 1.0).div(x.mul(x).add(yy).add(zz).sqrt());
    [x.mul(r), y.mul(r), z.mul(r)]
}

/// (a·b for x and y) + z: glam's dot product order.
#[inline(always)]
fn dot<V: Lanes>(a: &[V; 3], b: &[V; 3]) -> V {
    a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]))
}

#[inline(always)]
fn splat3<V: Lanes>(tok: V::Token, v: glam::DVec3) -> [V; 3] {
    [V::splat(tok, v.x), V::splat(tok, v.y), V::splat(tok, v.z)]
}

/// Per lane of a packet: whether it hit (a mask), which sphere, and where.
type Found<V> = (u8, <V as Lanes>::Index, V);

impl Shading<'_> {
    /// The nearest hit in front of the COP, among `candidates` (sphere indices, nearest possible
    /// hit first), for two packets (directions `d`, `covers(k, packet)`) at once; the search
    /// stops once no candidate left can be nearer. Each packet does exactly what it would alone: it passes a sphere that does not cover it, and
    /// stops for good at the first one none of its lanes would test; a packet not `live` takes
    /// no part. A lane takes part in a candidate while the one-ray search would still be
    /// running; it may also test a sphere that its tile placed by a bound of its own, below
    /// spheres with a larger `min_dist` (a ground, `tiles.rs`), after the one-ray search has
    /// stopped — a hit there is no nearer than that bound, so the answer is the same.
    #[inline(always)]
    pub(super) fn nearest_packets<V: Lanes>(
        &self,
        d: &[[V; 3]; 2],
        candidates: &[u32],
        covers: impl Fn(u32, usize) -> bool,
        mut live: [bool; 2],
    ) -> [Found<V>; 2] {
        let tok = d[0][0].token();
        let zero = V::splat(tok, 0.0);
        let mut hit = [0u8; 2];
        let mut index = [V::index(tok, 0); 2];
        let mut best = [V::splat(tok, f64::INFINITY); 2];
        for &k in candidates {
            let s = &self.spheres[k as usize];
            let min_dist = V::splat(tok, s.min_dist);
            let mut active = [0u8; 2];
            for q in 0..2 {
                if live[q] && covers(k, q) {
                    // Lanes still searching: no hit yet, or this sphere might be nearer.
                    active[q] = !hit[q] | !min_dist.ge(best[q]);
                    live[q] = active[q] != 0;
                }
            }
            if !(live[0] | live[1]) {
                break;
            }
            if active[0] | active[1] == 0 {
                continue;
            }
            let f = splat3::<V>(tok, s.f);
            let (c, radius2, k) = (
                V::splat(tok, s.c),
                V::splat(tok, s.radius2),
                V::index(tok, k as u64),
            );
            for q in 0..2 {
                // The smallest t > 0 with |f + t·d| = r, lane by lane, in the numerically stable
                // form (Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray
                // Tracing Gems ch. 7): the discriminant from |f − (f·d)d|² instead of b² − c,
                // and the root q = −(b + sign(b)√Δ) with the other root c/q, so neither root is
                // the difference of two nearly equal numbers. No branch past the discriminant
                // when no lane meets the sphere: the roots cost less than the mispredicted
                // branches.
                let d = &d[q];
                let b = dot(&f, d);
                let g = [
                    f[0].sub(d[0].mul(b)),
                    f[1].sub(d[1].mul(b)),
                    f[2].sub(d[2].mul(b)),
                ];
                let disc = radius2.sub(dot(&g, &g));
                let meets = active[q] & !disc.lt(zero);
                let root_q = b.add(disc.sqrt().copysign(b)).neg();
                let (t0, t1) = (c.div(root_q), root_q);
                let lt = t0.lt(t1);
                let near = V::blend(lt, t1, t0);
                let far = V::blend(lt, t0, t1);
                let (near_ahead, far_ahead) = (near.gt(zero), far.gt(zero));
                let t = V::blend(near_ahead, far, near);
                let root = !root_q.eq(zero) & (near_ahead | far_ahead);
                let take = meets & root & (!hit[q] | t.lt(best[q]));
                best[q] = V::blend(take, best[q], t);
                index[q] = V::index_blend(take, index[q], k);
                hit[q] |= take;
            }
        }
        [(hit[0], index[0], best[0]), (hit[1], index[1], best[1])]
    }

    /// The linear colours (r, g and b lanes) for a packet with a hit: the ambient plus each
    /// light facing the point and not blocked, times the sphere's colour, clamped; background
    /// where a lane missed, with the shadow rays of each light cast as one packet
    /// (the first [`HINTED_LIGHTS`] lights' with the row's `hints`, see [`occluded`]).
    #[inline(always)]
    fn shade_packet<V: Lanes, const SEEN: bool>(
        &self,
        d: &[V; 3],
        hit: u8,
        index: V::Index,
        t: V,
        hints: &mut Hints,
    ) -> ([V; 3], [u32; LANES]) {
        let tok = t.token();
        let mut lights = [0u32; LANES];
        let (zero, one) = (V::splat(tok, 0.0), V::splat(tok, 1.0));
        let fields = SphereLanes::<V>::new(tok, self.spheres, self.columns, hit, index);
        let mut light = [V::splat(tok, self.ambient); 3];
        if !self.lights.is_empty() {
            let f = fields.vec3(tok, |c| &c.f, |s| s.f);
            let c = fields.vec3(tok, |c| &c.center, |s| s.center);
            let r = fields.field(tok, |c| &c.radius, |s| s.radius);
            // The hit relative to the centre, rel = f + d·t, has length r: normal = rel / r,
            // point = centre + rel.
            let rel = [
                f[0].add(d[0].mul(t)),
                f[1].add(d[1].mul(t)),
                f[2].add(d[2].mul(t)),
            ];
            let normal = [rel[0].div(r), rel[1].div(r), rel[2].div(r)];
            let point = [c[0].add(rel[0]), c[1].add(rel[1]), c[2].add(rel[2])];
            for (n, l) in self.lights.iter().enumerate() {
                let facing = dot(&normal, &splat3(tok, l.to_light));
                let mut lit = hit & !facing.le(zero);
                if let Some(grid) = &l.shadows {
                    if lit != 0 {
                        let mut none = NO_HINT;
                        let hint = hints.get_mut(n).unwrap_or(&mut none);
                        lit &= !occluded(grid, &point, fields.ids(tok), lit, hint);
                    }
                }
                let color = l.color.to_array();
                for a in 0..3 {
                    let add = light[a].add(V::splat(tok, color[a]).mul(facing));
                    light[a] = V::blend(lit, light[a], add);
                }
                if SEEN {
                    // `Seen`'s light bits: which lights reach each lane's point.
                    for (k, bits) in lights.iter_mut().enumerate() {
                        *bits |= ((lit >> k & 1) as u32) << n.min(31);
                    }
                }
            }
        }
        let color = fields.vec3(tok, |c| &c.color, |s| s.color);
        let background = self.background.to_array();
        let flat = self.lights.is_empty();
        let mut out = [zero; 3];
        for a in 0..3 {
            // Clamp to [0, 1] as glam does (max, then min), or only to 1 for a flat scene (no
            // lights: the ambient alone).
            let c = color[a].mul(light[a]);
            let c = if flat {
                c.min(one)
            } else {
                c.max(zero).min(one)
            };
            out[a] = V::blend(hit, V::splat(tok, background[a]), c);
        }
        (out, lights)
    }
}

/// Each lane's sphere, for reading its fields: one sphere for the whole packet when every lane
/// that hit found the same one (the common case), two at a sphere's edge, otherwise lane by
/// lane (gathers from the fields' slices, which cost far more than two reads and a blend). A
/// lane that missed reads sphere 0 (there is one: some lane hit); its results are never used.
enum SphereLanes<'a, V: Lanes> {
    One(&'a ViewSphere),
    /// The second sphere's lanes, and the two spheres.
    Two(u8, &'a ViewSphere, &'a ViewSphere),
    Each(&'a ViewColumns, InBounds<V::Index>),
}

impl<'a, V: Lanes> SphereLanes<'a, V> {
    #[inline(always)]
    fn new(
        tok: V::Token,
        spheres: &'a [ViewSphere],
        columns: &'a ViewColumns,
        hit: u8,
        index: V::Index,
    ) -> SphereLanes<'a, V> {
        let lanes = V::index_store(index);
        let k = lanes[hit.trailing_zeros() as usize];
        let rest = hit & !V::index_eq(index, V::index(tok, k));
        if rest == 0 {
            return SphereLanes::One(&spheres[k as usize]);
        }
        let k2 = lanes[rest.trailing_zeros() as usize];
        let second = V::index_eq(index, V::index(tok, k2));
        if rest & !second == 0 {
            SphereLanes::Two(second, &spheres[k as usize], &spheres[k2 as usize])
        } else {
            let own = V::index_blend(hit, V::index(tok, 0), index);
            let len = columns.id.len();
            let own = InBounds::new(own, &V::index_store(own), len).expect("hits index spheres");
            SphereLanes::Each(columns, own)
        }
    }

    /// A field of each lane's sphere: `column` of the slices, `one` of a sphere.
    #[inline(always)]
    fn field(
        &self,
        tok: V::Token,
        column: impl Fn(&ViewColumns) -> &[f64],
        one: impl Fn(&ViewSphere) -> f64,
    ) -> V {
        match *self {
            SphereLanes::One(s) => V::splat(tok, one(s)),
            SphereLanes::Two(second, a, b) => {
                V::blend(second, V::splat(tok, one(a)), V::splat(tok, one(b)))
            }
            SphereLanes::Each(columns, own) => V::gather(column(columns), own),
        }
    }

    #[inline(always)]
    fn vec3(
        &self,
        tok: V::Token,
        column: impl Fn(&ViewColumns) -> &[Vec<f64>; 3],
        one: impl Fn(&ViewSphere) -> glam::DVec3,
    ) -> [V; 3] {
        [
            self.field(tok, |c| &column(c)[0], |s| one(s).x),
            self.field(tok, |c| &column(c)[1], |s| one(s).y),
            self.field(tok, |c| &column(c)[2], |s| one(s).z),
        ]
    }

    /// The spheres' scene indices.
    #[inline(always)]
    fn ids(&self, tok: V::Token) -> V::Index {
        match *self {
            SphereLanes::One(s) => V::index(tok, s.id as u64),
            SphereLanes::Two(second, a, b) => V::index_blend(
                second,
                V::index(tok, a.id as u64),
                V::index(tok, b.id as u64),
            ),
            SphereLanes::Each(columns, own) => V::gather_index(&columns.id, own),
        }
    }
}

/// Whether the ray from each view point (on sphere `own`) towards the light meets another
/// sphere, for the lanes in `need`: which of them the light does not reach. Whether any sphere blocks a ray does not
/// depend on the order of the tests, so lanes sharing a grid cell test its spheres together,
/// and `hint`, the last sphere found blocking a ray of an earlier packet of the row (or
/// [`NO_HINT`]), is tested first: neighbouring points are mostly in the same sphere's shadow,
/// and a packet that it blocks whole skips the grid. The hint is cleared when it blocks no
/// lane, and set to each sphere the grid's walk finds blocking.
#[inline(always)]
fn occluded<V: Lanes>(
    sh: &FrameShadows,
    point: &[V; 3],
    own: V::Index,
    need: u8,
    hint: &mut u32,
) -> u8 {
    let tok = point[0].token();
    let mut blocked = 0u8;
    for &(k, c, r2) in &sh.always {
        // Lanes on the sphere itself (points on a ground sphere) skip it.
        if need & !V::index_eq(own, V::index(tok, k as u64)) == 0 {
            continue;
        }
        blocked |= need & blocks(sh, point, own, k, c, r2);
        if need & !blocked == 0 {
            return blocked;
        }
    }
    if sh.grid.dims.0 == 0 {
        return blocked;
    }
    if *hint != NO_HINT {
        let (k, c, r2) = sh.blocker(*hint);
        let found = need & !blocked & blocks(sh, point, own, k, c, r2);
        if found == 0 {
            *hint = NO_HINT;
        }
        blocked |= found;
        if need & !blocked == 0 {
            return blocked;
        }
    }
    // The square (in cells, unclamped) that each point stands for on the grid: its projection
    // widened by the rounding allowance (1e-9 of the coordinates' scale, far above the rounding
    // by which a view point reaches the grid in world coordinates), so a point on a cell's edge
    // looks in both cells.
    let (ax, ay) = sh.axes;
    let q = [
        dot(point, &splat3(tok, ax)).add(V::splat(tok, sh.offset.x)),
        dot(point, &splat3(tok, ay)).add(V::splat(tok, sh.offset.y)),
    ];
    let size = point[0].abs().max(point[1].abs()).max(point[2].abs());
    let err = V::splat(tok, 1e-9).mul(V::splat(tok, sh.slack).add(size));
    // How far each point lies towards the light, less the allowance (`FrameShadows::up`):
    // a sphere whose top is below this cannot block the lane's ray.
    let low = dot(point, &splat3(tok, sh.up))
        .add(V::splat(tok, sh.height))
        .sub(err);
    let inv = V::splat(tok, sh.grid.inv_cell);
    let lo = [q[0].sub(err).mul(inv), q[1].sub(err).mul(inv)];
    let hi = [q[0].add(err).mul(inv), q[1].add(err).mul(inv)];
    // Lanes whose square misses the grid (or is NaN) have no cells; the others' ranges are
    // clamped to it (the far edges belong to the last cells).
    let zero = V::splat(tok, 0.0);
    let (w, h) = sh.grid.dims;
    let on_grid = hi[0].ge(zero) & hi[1].ge(zero);
    let on_grid = on_grid & lo[0].le(V::splat(tok, w as f64)) & lo[1].le(V::splat(tok, h as f64));
    let pending = need & !blocked & on_grid;
    if pending == 0 {
        return blocked;
    }
    let (x0, x1) = (cell_index(lo[0], w), cell_index(hi[0], w));
    let (y0, y1) = (cell_index(lo[1], h), cell_index(hi[1], h));
    // The cells of all pending lanes together. Testing a lane against a sphere outside its own
    // cells cannot change its answer: every sphere that blocks its ray is binned in its cells.
    // So when the lanes' cells make a small rectangle, its spheres are tested on all of them.
    let (mut cx, mut cy) = ((i32::MAX, 0), (i32::MAX, 0));
    for l in 0..LANES {
        if pending >> l & 1 == 1 {
            cx = (cx.0.min(x0[l]), cx.1.max(x1[l]));
            cy = (cy.0.min(y0[l]), cy.1.max(y1[l]));
        }
    }
    if (cx.1 - cx.0 + 1) * (cy.1 - cy.0 + 1) <= UNION_CELLS {
        let cells = (cx.0 as usize, cx.1 as usize, cy.0 as usize, cy.1 as usize);
        let (blocked, found) = walk(sh, point, own, low, cells, pending, blocked);
        if found != NO_HINT {
            *hint = found;
        }
        return blocked;
    }
    let mut key = [u64::MAX; LANES];
    for l in 0..LANES {
        if pending >> l & 1 == 1 {
            let at = |c: [i32; LANES]| c[l] as u64;
            key[l] = cell_key(at(x0), at(x1), at(y0), at(y1));
        }
    }
    // Lanes whose squares fall in the same single cell test its spheres together.
    for l in 0..LANES {
        let here = key[l];
        if here == u64::MAX {
            continue;
        }
        let cells = cell_range(here);
        let single = cells.0 == cells.1 && cells.2 == cells.3;
        let mut lanes = 0u8;
        for (m, other) in key.iter_mut().enumerate().skip(l) {
            if *other == here && (single || m == l) {
                lanes |= 1 << m;
                *other = u64::MAX;
            }
        }
        let found;
        (blocked, found) = walk(sh, point, own, low, cells, lanes, blocked);
        if found != NO_HINT {
            *hint = found;
        }
    }
    blocked
}

/// `blocked` with the lanes in `lanes` that a sphere of grid cells `cells` blocks added, until
/// every one of them is blocked, and the last sphere found blocking (or [`NO_HINT`]). A cell
/// is read down to the first sphere whose top is below every open lane's `low`. A function,
/// not a closure, so that it is inlined into the one compiled for the instruction set.
#[inline(always)]
fn walk<V: Lanes>(
    sh: &FrameShadows,
    point: &[V; 3],
    own: V::Index,
    low: V,
    (x0, x1, y0, y1): CellRect,
    lanes: u8,
    mut blocked: u8,
) -> (u8, u32) {
    let tok = low.token();
    let mut last = NO_HINT;
    let tops = &sh.grid.tops;
    for y in y0..=y1 {
        for x in x0..=x1 {
            for &k in sh.cell(x, y) {
                let reach = lanes & !blocked & V::splat(tok, tops[k as usize]).ge(low);
                if reach == 0 {
                    break;
                }
                let (k, c, r2) = sh.blocker(k);
                let found = reach & blocks(sh, point, own, k, c, r2);
                if found != 0 {
                    last = k;
                }
                blocked |= found;
                if lanes & !blocked == 0 {
                    return (blocked, last);
                }
            }
        }
    }
    (blocked, last)
}

/// No shadow hint (see [`occluded`]).
const NO_HINT: u32 = u32::MAX;

/// The lights whose shadow packets keep a hint along a row.
const HINTED_LIGHTS: usize = 4;

/// A row's shadow hints, one per light (the first [`HINTED_LIGHTS`]).
type Hints = [u32; HINTED_LIGHTS];

/// The most grid cells that a shadow packet walks for all its lanes together.
const UNION_CELLS: i32 = 4;

/// `(v.max(0.0) as usize).min(n - 1)` per lane, for lanes that are not NaN: the cell of a
/// grid coordinate, clamped to a side of `n` cells.
#[inline(always)]
fn cell_index<V: Lanes>(v: V, n: usize) -> [i32; LANES] {
    let tok = v.token();
    let last = n as i32 - 1;
    // Clamped as floats first, so that no lane is out of the conversion's range.
    v.max(V::splat(tok, 0.0))
        .min(V::splat(tok, last as f64))
        .to_i32(last)
}

/// The lanes whose shadow ray sphere k (centre `c`, r² `r2`, in view coordinates) blocks,
/// leaving out lanes on sphere k itself. A point inside (or on) the sphere is blocked; outside,
/// both roots share a sign, positive exactly when the sphere lies ahead. No epsilon is needed:
/// a point's own sphere, being convex, never shadows its own lit side.
#[inline(always)]
fn blocks<V: Lanes>(
    sh: &FrameShadows,
    point: &[V; 3],
    own: V::Index,
    k: u32,
    c: glam::DVec3,
    r2: f64,
) -> u8 {
    let tok = point[0].token();
    let (zero, r2) = (V::splat(tok, 0.0), V::splat(tok, r2));
    let dir = splat3::<V>(tok, sh.to_light);
    let f = [
        point[0].sub(V::splat(tok, c.x)),
        point[1].sub(V::splat(tok, c.y)),
        point[2].sub(V::splat(tok, c.z)),
    ];
    let cc = dot(&f, &f).sub(r2);
    let b = dot(&f, &dir);
    let g = [
        f[0].sub(dir[0].mul(b)),
        f[1].sub(dir[1].mul(b)),
        f[2].sub(dir[2].mul(b)),
    ];
    let g2 = dot(&g, &g);
    let hit = cc.le(zero) | (b.lt(zero) & g2.le(r2));
    hit & !V::index_eq(own, V::index(tok, k as u64))
}

impl SrgbEncoder {
    /// [`SrgbEncoder::encode`] of every lane, written to channel `a` of eight RGB pixels:
    /// clamp and bucket on whole lanes, then a table read per value, and a comparison only for
    /// values in a bucket that a threshold splits.
    #[inline(always)]
    pub(super) fn encode_into<V: Lanes>(&self, linear: V, rgb: &mut [u8; 3 * LANES], a: usize) {
        let tok = linear.token();
        let (zero, one) = (V::splat(tok, 0.0), V::splat(tok, 1.0));
        // f64::clamp(0, 1), which keeps a NaN.
        let x = V::blend(linear.lt(zero), linear, zero);
        let x = V::blend(x.gt(one), x, one);
        let bucket = x.mul(V::splat(tok, BUCKETS as f64)).to_i32(BUCKETS as i32);
        let mut any = 0;
        for l in 0..LANES {
            let entry = self.buckets[bucket[l] as usize];
            rgb[3 * l + a] = entry as u8;
            any |= entry;
        }
        if any & SPLIT != 0 {
            let x = x.store();
            for l in 0..LANES {
                let entry = self.buckets[bucket[l] as usize];
                rgb[3 * l + a] = self.finish(entry, x[l]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::lanes::Portable;
    use super::super::shadows::tests::cluster;
    use super::super::shadows::view_center;
    use super::*;
    use glam::DVec3;

    /// The packets' nearest hit of one sphere (centre `center`, radius `r`, view coordinates)
    /// by the ray from the origin along unit `d`, in every lane.
    fn hit(center: DVec3, r: f64, d: DVec3) -> Option<f64> {
        let f = -center;
        let sphere = ViewSphere {
            center,
            radius: r,
            radius2: r * r,
            f,
            c: f.length_squared() - r * r,
            min_dist: f.length() - r,
            color: DVec3::ONE,
            id: 0,
        };
        let columns = ViewColumns::new(&[sphere]);
        let shading = Shading {
            spheres: &[sphere],
            columns: &columns,
            lights: &[],
            ambient: 0.0,
            background: DVec3::ZERO,
        };
        let d = [d.x, d.y, d.z].map(|x| Portable::splat((), x));
        let [(hit, _, t), _] =
            shading.nearest_packets::<Portable>(&[d, d], &[0], |_, _| true, [true, false]);
        let t = t.store();
        assert!(hit == 0 || hit == 0xff, "every lane alike");
        assert!(t.iter().all(|x| x.to_bits() == t[0].to_bits()));
        (hit != 0).then_some(t[0])
    }

    #[test]
    fn roots_match_the_textbook_quadratic() {
        // Unit sphere at (0, 0, 5), ray from the origin along +z: hits at 4 and 6.
        let t = hit(DVec3::new(0.0, 0.0, 5.0), 1.0, DVec3::Z).unwrap();
        assert!((t - 4.0).abs() < 1e-15);
        // From inside: the far root.
        let t = hit(DVec3::new(0.0, 0.0, 0.5), 1.0, DVec3::Z).unwrap();
        assert!((t - 1.5).abs() < 1e-15);
        // Behind: none.
        assert_eq!(hit(DVec3::new(0.0, 0.0, -5.0), 1.0, DVec3::Z), None);
        // Miss.
        assert_eq!(hit(DVec3::new(-2.0, 0.0, 5.0), 1.0, DVec3::Z), None);
    }

    #[test]
    fn stable_roots_keep_a_tiny_sphere_far_away() {
        // r = 1e-3 at distance 1e4 along a slightly oblique ray; the naive b² − c loses every
        // digit of the discriminant here. Closed form: t = D·cosθ − sqrt(r² − D² sin²θ).
        let (dist, offset, r) = (1e4, 0.5e-3, 1e-3_f64);
        let t = hit(DVec3::new(0.0, offset, dist), r, DVec3::Z).unwrap();
        let expect = dist - (r * r - offset * offset).sqrt();
        assert!((t - expect).abs() < 1e-9, "{t} vs {expect}");
    }

    /// Eight values at a time, [`SrgbEncoder::encode_into`] is [`SrgbEncoder::encode`], in its
    /// channel and nowhere else: at, just below and just above every threshold (values in split
    /// buckets, mixed with others), at bucket edges, and outside [0, 1] and NaN.
    #[test]
    fn lanes_encode_as_one_value_does() {
        let enc = super::super::srgb_encoder();
        let mut xs = vec![
            -1.0,
            -0.0,
            0.0,
            1.0,
            2.0,
            f64::NAN,
            f64::INFINITY,
            1.0f64.next_down(),
        ];
        for k in 0..255 {
            let t = enc.thresholds[k];
            xs.extend([t.next_down(), t, t.next_up(), (k as f64 + 0.3) / 255.0]);
        }
        for b in (0..=BUCKETS).step_by(97) {
            let start = b as f64 / BUCKETS as f64;
            xs.extend([start.next_down(), start, start.next_up()]);
        }
        for (k, lanes) in xs.chunks_exact(LANES).enumerate() {
            let a = k % 3;
            let mut rgb = [7u8; 3 * LANES];
            enc.encode_into(Portable::load((), lanes.try_into().unwrap()), &mut rgb, a);
            for (l, px) in rgb.chunks(3).enumerate() {
                let want: Vec<u8> = (0..3)
                    .map(|c| if c == a { enc.encode(lanes[l]) } else { 7 })
                    .collect();
                assert_eq!(px, want, "{lanes:?}, channel {a}");
            }
        }
    }

    /// A shadow packet's answer per lane is the one-ray answer of testing every sphere: eight
    /// points at a time from spheres next to each other in the list, so that a packet's lanes
    /// lie on different spheres and in cells near or far apart (the union walk and the walks
    /// per group of lanes), with the light's tops cutting each cell short; without a hint, and
    /// with the hint carried from packet to packet as along a row (some packets answered by
    /// the hint alone, some in part, some not at all).
    #[test]
    fn shadow_packets_find_every_blocker() {
        let c = cluster();
        let centers: std::sync::Arc<[_]> = c
            .spheres
            .iter()
            .map(|s| view_center(&c.camera, s))
            .collect();
        // Neighbouring points of a sphere (lanes in one cell or a few), and every 7th point
        // (lanes on different spheres, cells far apart).
        let picked = [1, 7].map(|n| c.points.iter().step_by(n).copied().collect::<Vec<_>>());
        for light in &c.lights {
            for all in [None, Some(centers.clone())] {
                let frame =
                    FrameShadows::new(&light.grid, &c.camera, &c.spheres, all, light.to_light);
                let mut hint = NO_HINT;
                let mut hinted = [0; 3];
                for (p, lanes) in picked.iter().flat_map(|p| p.chunks(LANES)).enumerate() {
                    let mut xyz = [[0.0; LANES]; 3];
                    let mut own = [0u64; LANES];
                    for l in 0..LANES {
                        let (point, o) = lanes[l.min(lanes.len() - 1)];
                        for a in 0..3 {
                            xyz[a][l] = point[a];
                        }
                        own[l] = o as u64;
                    }
                    let point = xyz.map(|a| Portable::load((), &a));
                    let need = (0xffu16 >> (LANES - lanes.len())) as u8;
                    let got = occluded::<Portable>(&frame, &point, own, need, &mut NO_HINT.clone());
                    let before = hint;
                    let with_hint = occluded::<Portable>(&frame, &point, own, need, &mut hint);
                    assert_eq!(with_hint, got, "packet {p} with hint {before}");
                    if before != NO_HINT {
                        let (k, center, r2) = frame.blocker(before);
                        let by_hint = need & blocks(&frame, &point, own, k, center, r2);
                        hinted[(by_hint != 0) as usize + (by_hint == need) as usize] += 1;
                    }
                    for (l, &lane) in lanes.iter().enumerate() {
                        let every = c.any_blocker(light.to_light, lane);
                        let direction = light.direction;
                        assert_eq!(
                            got >> l & 1 == 1,
                            every,
                            "packet {p}, lane {l}, {direction}"
                        );
                    }
                }
                // Packets whose hint blocked none of their lanes, some, and all.
                assert!(hinted.iter().all(|&n| n > 0), "{hinted:?}");
            }
        }
    }
}
