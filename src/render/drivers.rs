//! The row drivers: pixels cast in packets of [`LANES`] rays — at one sample a pixel a band of
//! [`BAND`] rows at a time in packets of 4 columns × 2 rows, a stretch of columns at a time; at
//! s×s samples a row at a time in groups of pixels, adaptively corners first — each kind of
//! work a [`ForLanes`] that `Isa::run` (simd.rs) runs compiled for the instruction set. Rows
//! end as 8-bit sRGB levels or as linear colours ([`Pixel`]) for a frame that averages several
//! renders (motion blur) and quantises once: the same drivers either way.
//!
//! A packet of 4 × 2 pixels, not 8 × 1, meets fewer spheres at once where spheres are a few
//! pixels wide (docs/performance.md): its search tests fewer spheres, its shading reads one or
//! two spheres' fields more often, its shadow rays start closer together.
//!
//! A packet's work is a long chain of dependent square roots, divisions and table lookups, so
//! a band is taken a stretch at a time and stage by stage: every packet's directions, then
//! every packet's nearest hit (the two packets of a column of 4 × 4 pixels together), then
//! every colour, then every sRGB level. Each stage is a short loop over independent packets,
//! which the CPU overlaps.

use super::kernels::{Found, Shading};
use super::lanes::{ForLanes, Lanes, LANES};
use super::rays::{unit, RayTable, HALF};
use super::shadows::{HINTED_LIGHTS, NO_HINT};
use super::simd::Isa;
use super::srgb::SrgbEncoder;
use super::tiles::{TileBins, TILE};
use crate::raster::MAX_SAMPLES;

/// Most samples in one cast (`RowJob::cast`): a group of pixels at s×s samples holds four of
/// them up to 8×8, two up to 11×11 and one above; adaptive sampling fits as many pixels' other
/// samples as it can.
const MAX_GROUP_SAMPLES: usize = (MAX_SAMPLES * MAX_SAMPLES) as usize;

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

/// The average of a pixel's s² sample colours, summed in order.
fn average(samples: impl Iterator<Item = [f64; 3]>, s2: usize) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for c in samples {
        for a in 0..3 {
            sum[a] += c[a];
        }
    }
    sum.map(|v| v / s2 as f64)
}

/// Sample k (row-major in the s×s grid) of pixel p of a group.
fn sample(s: usize, p: usize, k: usize) -> Sample {
    ((p * s + k % s) as u16, (k / s) as u16)
}

/// What a row's pixels end as: 8-bit sRGB levels (`u8`), or linear colours (`f64`) for a
/// frame that averages several renders (motion blur), three to a pixel either way.
pub trait Pixel: Copy + Default {
    /// Up to [`LANES`] pixels' linear colours into `out`, as many pixels as it holds.
    fn put<V: Lanes>(job: &RowJob, tok: V::Token, linear: &[[f64; 3]], out: &mut [Self]);

    /// A band's packet: lanes 0..4 into `upper`, 4..8 into `lower` (a packet's worth of
    /// pixels, or fewer at a row's end), its colours `color` unless it hit nothing.
    fn put_packet<V: Lanes>(
        job: &RowJob,
        found: &Found<V>,
        color: &[V; 3],
        upper: &mut [Self],
        lower: &mut [Self],
    );
}

impl Pixel for u8 {
    #[inline(always)]
    fn put<V: Lanes>(job: &RowJob, tok: V::Token, linear: &[[f64; 3]], out: &mut [u8]) {
        let n = out.len();
        let mut lanes = [[0.0; LANES]; 3];
        for (l, c) in linear[..n / 3].iter().enumerate() {
            for a in 0..3 {
                lanes[a][l] = c[a];
            }
        }
        let mut rgb = [0u8; 3 * LANES];
        for (a, channel) in lanes.iter().enumerate() {
            job.encode.encode_into(V::load(tok, channel), &mut rgb, a);
        }
        out.copy_from_slice(&rgb[..n]);
    }

    #[inline(always)]
    fn put_packet<V: Lanes>(
        job: &RowJob,
        found: &Found<V>,
        color: &[V; 3],
        upper: &mut [u8],
        lower: &mut [u8],
    ) {
        // A whole packet: each level straight to its pixel, the sky as fixed-size copies of
        // the background's levels, not calls to `memcpy`.
        let sky = found.0 == 0;
        let (bg_upper, bg_lower) = job.background.split_at(3 * HALF);
        if let (Ok(up), Ok(low)) = (
            <&mut [u8; 3 * HALF]>::try_from(&mut *upper),
            <&mut [u8; 3 * HALF]>::try_from(&mut *lower),
        ) {
            if sky {
                *up = bg_upper.try_into().expect("half a packet");
                *low = bg_lower.try_into().expect("half a packet");
            } else {
                // Plain calls, not `array::map`: its closure is not inlined into the function
                // compiled for the instruction set, and would run its intrinsics out of line.
                for (a, &linear) in color.iter().enumerate() {
                    job.encode.encode_halves::<V>(linear, up, low, a);
                }
            }
            return;
        }
        let mut rgb = job.background;
        if !sky {
            for (a, &linear) in color.iter().enumerate() {
                job.encode.encode_into::<V>(linear, &mut rgb, a);
            }
        }
        let n = upper.len();
        upper.copy_from_slice(&rgb[..n]);
        lower.copy_from_slice(&rgb[3 * HALF..3 * HALF + n]);
    }
}

impl Pixel for f64 {
    #[inline(always)]
    fn put<V: Lanes>(_: &RowJob, _: V::Token, linear: &[[f64; 3]], out: &mut [f64]) {
        for (px, c) in out.chunks_exact_mut(3).zip(linear) {
            px.copy_from_slice(c);
        }
    }

    #[inline(always)]
    fn put_packet<V: Lanes>(
        job: &RowJob,
        found: &Found<V>,
        color: &[V; 3],
        upper: &mut [f64],
        lower: &mut [f64],
    ) {
        let linear = if found.0 == 0 {
            job.ctx.background.to_array().map(|c| [c; LANES])
        } else {
            [color[0].store(), color[1].store(), color[2].store()]
        };
        for (half, out) in [upper, lower].into_iter().enumerate() {
            for (l, px) in out.chunks_exact_mut(3).enumerate() {
                for a in 0..3 {
                    px[a] = linear[a][half * HALF + l];
                }
            }
        }
    }
}

/// Rows of a band at one sample a pixel: two packets of two rows, one above the other.
pub const BAND: usize = 4;

/// Packets of a band whose directions are computed together: two rows of packets, each
/// [`HALF`] columns wide.
const STRETCH: usize = 32;

/// Columns of a stretch.
const STRETCH_COLUMNS: usize = STRETCH / 2 * HALF;

/// What a row or band needs: the scene in view coordinates, the ray table and the tiles.
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

/// Row `j` of a job, or with `ONE` (one sample a pixel) the rows of a band from row `j`, to be
/// written into `row`.
struct RowWork<'r, 'a, P, const ONE: bool> {
    job: &'r RowJob<'a>,
    j: usize,
    row: &'r mut [P],
}

impl<P: Pixel, const ONE: bool> ForLanes for RowWork<'_, '_, P, ONE> {
    type Output = ();

    #[inline(always)]
    fn run<V: Lanes>(self, tok: V::Token) {
        let RowWork { job, j, row } = self;
        if ONE {
            job.band_packets::<V, P>(tok, j, row)
        } else if job.adaptive {
            job.row_adaptive::<V, P>(tok, j, row)
        } else {
            job.row_samples::<V, P>(tok, j, row)
        }
    }
}

// A band's packets of one column lie in one tile, as do two packets side by side (`cast`).
// Tiles of `DENSE_TILE` (tiles/mod.rs, which checks that a band's column lies in one) come only
// at one sample a pixel: the drivers of several samples group the pixels of a `TILE`.
const _: () = assert!(
    TILE.is_multiple_of(BAND) && TILE.is_multiple_of(2 * LANES) && BAND == 4 && LANES == 2 * HALF
);

impl RowJob<'_> {
    /// Renders the rows of a band from row `j` into `band` ([`BAND`] rows, or fewer at the
    /// frame's end; RGB8, or linear colours, the values that the levels quantise, the same on
    /// every path) in packets, with the instruction set `isa`, which proves that the CPU runs
    /// it. One sample a pixel and several are each a work of their own, so that on the x86
    /// paths each is a function of its own and the single-sample loop keeps its registers and
    /// layout.
    pub fn band<P: Pixel>(&self, isa: Isa, j: usize, band: &mut [P]) {
        if self.samples == 1 {
            isa.run(RowWork::<P, true> {
                job: self,
                j,
                row: band,
            })
        } else {
            let row_bytes = 3 * self.table.raster.width as usize;
            for (r, row) in band.chunks_mut(row_bytes).enumerate() {
                isa.run(RowWork::<P, false> {
                    job: self,
                    j: j + r,
                    row,
                })
            }
        }
    }

    /// Row `j` with s×s samples a pixel (s = `self.samples` ≥ 2), as the one-ray code does it:
    /// each sample's colour, summed in sample order and divided by s². The samples of a group of
    /// pixels in one tile (4 pixels up to 8×8, 2 up to 11×11, else 1) are cast together
    /// ([`RowJob::cast`]), stage by stage.
    #[inline(always)]
    fn row_samples<V: Lanes, P: Pixel>(&self, tok: V::Token, j: usize, row: &mut [P]) {
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
            let span = (j, i0, pixels);
            self.cast::<V, false>(span, &list[..n], &mut stages, &mut colors, &mut []);
            let mut linear = [[0.0; 3]; 4];
            for (p, c) in colors[..n].chunks(s2).enumerate() {
                linear[p] = average(c.iter().copied(), s2);
            }
            P::put::<V>(self, tok, &linear[..pixels], out);
        }
    }

    /// Row `j` with adaptive s×s samples: each pixel's four corner samples first, and the
    /// average of those where all four saw the same sphere lit by the same lights; elsewhere
    /// every sample, the corners reused, summed in order.
    /// A tile's pixels go together: all their corners, then the other samples of the pixels
    /// whose corners disagree.
    #[inline(always)]
    fn row_adaptive<V: Lanes, P: Pixel>(&self, tok: V::Token, j: usize, row: &mut [P]) {
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
            let span = (j, i0, pixels);
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
                    let mut next = colors[m * others.len()..].iter();
                    let samples = corner_of.iter().map(|corner| match *corner {
                        Some(m) => c[m],
                        None => *next.next().unwrap(),
                    });
                    linear[p] = average(samples, s2);
                }
            }
            for (q, out) in out.chunks_mut(3 * LANES).enumerate() {
                P::put::<V>(self, tok, &linear[q * LANES..], out);
            }
        }
    }

    /// Casts the samples `list` of the pixels of `span` (row j's pixels i0 .. i0 + `pixels`,
    /// inside one tile), in packets of 8 (the last packet's
    /// spare lanes repeat the last sample): each one's linear colour into `colors`, and, when
    /// `SEEN`, what it saw into `seen`: the sphere (or `u64::MAX` for the background) in the
    /// high 32 bits and, in the low 32, which lights reach the point. Adaptive sampling compares
    /// these.
    #[inline(always)]
    fn cast<V: Lanes, const SEEN: bool>(
        &self,
        (j, i0, pixels): (usize, usize, usize),
        list: &[Sample],
        stages: &mut Stages<V>,
        colors: &mut [[f64; 3]],
        seen: &mut [u64],
    ) {
        let tok = stages.dirs[0][0].token();
        let (s, t, n) = (self.samples, self.table, list.len());
        let background = self.ctx.background.to_array();
        let candidates = self.bins.at(i0, j);
        let covers = |k: u32, _: usize| self.bins.covers(k, (i0, i0 + pixels - 1), (j, j));
        // Stage by stage, as `band_packets`: every packet's directions, then the nearest hits
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

    /// The band of rows from `j` at one sample a pixel, into `band` (RGB8): [`BAND`] rows, or
    /// at the frame's end fewer, cast as a whole band whose missing rows repeat the last (and
    /// are not kept), as a row's last packet repeats its last pixel.
    #[inline(always)]
    fn band_packets<V: Lanes, P: Pixel>(&self, tok: V::Token, j: usize, band: &mut [P]) {
        let row_bytes = 3 * self.table.raster.width as usize;
        let rows = band.len() / row_bytes;
        if rows == BAND {
            self.whole_band::<V, P>(tok, j, rows, band)
        } else {
            let mut whole = vec![P::default(); BAND * row_bytes];
            self.whole_band::<V, P>(tok, j, rows, &mut whole);
            band.copy_from_slice(&whole[..band.len()]);
        }
    }

    /// [`BAND`] rows from `j` into `band`, of which the first `rows` are the frame's: packets
    /// of [`HALF`] columns × 2 rows, a stretch of columns at a time and stage by stage; the two
    /// packets of a column (4 × 4 pixels) are searched together: they share its tile's
    /// candidates, and their chains of dependent work interleave.
    #[inline(always)]
    fn whole_band<V: Lanes, P: Pixel>(&self, tok: V::Token, j: usize, rows: usize, band: &mut [P]) {
        let t = self.table;
        let width = t.raster.width as usize;
        let row = |a: usize| j + a.min(rows - 1);
        // The y of each lane of the upper and lower packets (rows 0, 1 and 2, 3), and y². A
        // loop, not `array::map`, whose closure would run the loads out of line.
        let mut ys = [V::splat(tok, 0.0); 2];
        for (h, y) in ys.iter_mut().enumerate() {
            let mut lanes = [t.ys[row(2 * h)]; LANES];
            lanes[HALF..].fill(t.ys[row(2 * h + 1)]);
            *y = V::load(tok, &lanes);
        }
        let yys = [ys[0].mul(ys[0]), ys[1].mul(ys[1])];
        let (z, zz) = (V::splat(tok, t.dz), V::splat(tok, t.dz * t.dz));
        // A stretch of the band's unit directions (of the table's `packet_xs`), computed ahead of its
        // packets: independent square roots and divisions, out of each packet's chain of
        // dependent work. The first stretch's are computed here, each next stretch's in this
        // stretch's last stage, column by column as its slots are freed: that stage reads
        // tables and stores bytes, and leaves the divider idle. Packet 2c is column c's upper
        // packet, 2c + 1 its lower.
        let columns = width.div_ceil(HALF);
        let mut dirs = [[V::splat(tok, 0.0); 3]; STRETCH];
        for c in 0..columns.min(STRETCH / 2) {
            for h in 0..2 {
                let x = V::load(tok, &t.packet_xs[c]);
                dirs[2 * c + h] = unit(x, ys[h], z, yys[h], zz);
            }
        }
        // The stretch's nearest hits, then its colours, then its levels, each stage a short loop
        // over independent packets, so that one packet's square roots, divisions and table
        // lookups overlap the next one's.
        let mut founds = [(0u8, V::index(tok, 0), V::splat(tok, 0.0)); STRETCH];
        let mut colors = [[V::splat(tok, 0.0); 3]; STRETCH];
        // The shadow hints, along the whole band.
        let mut hints = [NO_HINT; HINTED_LIGHTS];
        let (upper, lower) = band.split_at_mut(2 * 3 * width);
        let (row0, row1) = upper.split_at_mut(3 * width);
        let (row2, row3) = lower.split_at_mut(3 * width);
        let stretches = row0
            .chunks_mut(3 * STRETCH_COLUMNS)
            .zip(row1.chunks_mut(3 * STRETCH_COLUMNS))
            .zip(row2.chunks_mut(3 * STRETCH_COLUMNS))
            .zip(row3.chunks_mut(3 * STRETCH_COLUMNS));
        for (s, (((out0, out1), out2), out3)) in stretches.enumerate() {
            let c0 = s * STRETCH / 2;
            let here = (out0.len() / 3).div_ceil(HALF);
            let next = columns.saturating_sub(c0 + STRETCH / 2).min(STRETCH / 2);
            for c in 0..here {
                let i0 = (c0 + c) * HALF;
                let i1 = (i0 + HALF).min(width) - 1;
                let d = [dirs[2 * c], dirs[2 * c + 1]];
                let candidates = self.bins.at(i0, j);
                let covers =
                    |k: u32, h: usize| self.bins.covers(k, (i0, i1), (row(2 * h), row(2 * h + 1)));
                let found = self
                    .ctx
                    .nearest_packets(&d, candidates, covers, [true, true]);
                founds[2 * c] = found[0];
                founds[2 * c + 1] = found[1];
            }
            for q in 0..2 * here {
                let (hit, index, t) = founds[q];
                if hit != 0 {
                    colors[q] = self
                        .ctx
                        .shade_packet::<V, false>(&dirs[q], hit, index, t, &mut hints)
                        .0;
                }
            }
            let outs = out0
                .chunks_mut(3 * HALF)
                .zip(out1.chunks_mut(3 * HALF))
                .zip(out2.chunks_mut(3 * HALF))
                .zip(out3.chunks_mut(3 * HALF));
            for (c, (((o0, o1), o2), o3)) in outs.enumerate() {
                // Column c's directions are used: its slots take the next stretch's column c.
                if c < next {
                    for h in 0..2 {
                        let column = c0 + STRETCH / 2 + c;
                        let x = V::load(tok, &t.packet_xs[column]);
                        dirs[2 * c + h] = unit(x, ys[h], z, yys[h], zz);
                    }
                }
                P::put_packet::<V>(self, &founds[2 * c], &colors[2 * c], o0, o1);
                P::put_packet::<V>(self, &founds[2 * c + 1], &colors[2 * c + 1], o2, o3);
            }
        }
    }
}
