//! The frame engine: which frames a run covers, rendering them in order with each frame's
//! `FrameKey`, and streaming the pixels to a consumer on its own thread.

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::str::FromStr;
use std::sync::Arc;
use std::time::Instant;

use crate::animation::Exposure;
use crate::camera::Camera;
use crate::document::Document;
use crate::error::{Error, Result};
use crate::hash::{FrameHash, FrameHasher};
use crate::key::{FrameKey, KeyBase};
use crate::render::{PreparedFrame, Renderer, SceneIndex};

/// Shard K of N: the frames k with k mod N = K (interleaved, so every shard gets a share of the
/// slow and the fast parts of an animation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Shard {
    /// K, 0 ≤ K < N.
    pub index: u64,
    /// N ≥ 1.
    pub count: u64,
}

impl Shard {
    /// Whether frame `frame` is this shard's.
    pub fn contains(&self, frame: u64) -> bool {
        frame % self.count == self.index
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = String;

    /// `K/N` with 0 ≤ K < N.
    fn from_str(s: &str) -> std::result::Result<Shard, String> {
        let bad = || format!("{s:?}: expected K/N with 0 ≤ K < N, e.g. 0/4");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let parse = |x: &str| x.trim().parse::<u64>().map_err(|_| bad());
        let (index, count) = (parse(k)?, parse(n)?);
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// The frames a run covers: a range, optionally one shard of it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameSet {
    /// The frames, before the shard picks its own.
    pub range: Range<u64>,
    /// Only the frames of this shard, if given.
    pub shard: Option<Shard>,
}

impl FrameSet {
    /// Every frame of `range`.
    pub fn all(range: Range<u64>) -> FrameSet {
        FrameSet { range, shard: None }
    }

    /// Whether frame `k` is in the set.
    pub fn contains(&self, k: u64) -> bool {
        self.range.contains(&k) && self.shard.is_none_or(|s| s.contains(k))
    }

    /// How many frames the set holds.
    pub fn count(&self) -> u64 {
        match self.shard {
            None => self.range.end - self.range.start,
            Some(s) => self.range.clone().filter(|k| s.contains(*k)).count() as u64,
        }
    }
}

/// Timing of a run of frames.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Timing {
    /// Frames delivered to the consumer.
    pub frames: u64,
    /// Frames whose camera equalled the previous frame's: delivered again without rendering.
    pub held: u64,
    /// Seconds per rendered frame, in frame order: its rows and their SHA-256, while the next
    /// frame is prepared beside them (a frame prepared ahead leaves out its own preparation).
    pub render_secs: Vec<f64>,
    /// Wall-clock seconds for the whole run, output included.
    pub wall_secs: f64,
    /// When the first frame was delivered (for the first-frame latency).
    pub first_frame_at: Option<Instant>,
    /// The most spheres any rendered frame had inside its view.
    pub max_in_view: usize,
}

impl Timing {
    /// Median seconds per rendered frame.
    pub fn median_render_secs(&self) -> f64 {
        median(&self.render_secs)
    }
}

/// The median of `xs` (0 for none).
pub fn median(xs: &[f64]) -> f64 {
    if xs.is_empty() {
        return 0.0;
    }
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        (v[m - 1] + v[m]) * 0.5
    }
}

/// Every frame's key, in order from frame 0 (the cameras are evaluated in order), or the first
/// frame whose camera is undefined.
pub fn keys(doc: &Document) -> impl Iterator<Item = Result<(u64, FrameKey)>> + '_ {
    let base = KeyBase::new(&doc.scene, doc.raster);
    doc.exposures()
        .map(move |item| item.map(|(frame, exposure)| (frame, key(doc, &base, &exposure))))
}

/// A frame's key: its camera, and with motion blur the setting and every time sample's camera.
fn key(doc: &Document, base: &KeyBase, exposure: &Exposure) -> FrameKey {
    match doc.motion_blur {
        None => base.key(&exposure.camera),
        Some(blur) => base.key_blurred(&exposure.camera, blur, &exposure.times),
    }
}

/// Renders the frames of `set` in order and calls `sink` with each frame's key, RGB8 pixels
/// and hash ([`crate::hash::frame_hash`], computed row by row as the rows are rendered);
/// frames for which `done` says true are passed over without rendering (`done` is asked ahead:
/// before a rendered frame reaches `sink`, about the frames up to the next one to render, so it
/// must not depend on what `sink` did). A frame whose cameras (with motion blur, the time
/// samples' cameras) equal the previous rendered frame's is not rendered again.
pub fn for_each_frame(
    doc: &Document,
    set: &FrameSet,
    done: impl FnMut(u64) -> bool,
    mut sink: impl FnMut(u64, &FrameKey, &Arc<Vec<u8>>, FrameHash) -> Result<()>,
) -> Result<Timing> {
    let kept = "Keep::Frames keeps the key and the pixels";
    run(doc, set, done, Keep::Frames, |frame, key, pixels, hash| {
        sink(frame, key.expect(kept), pixels.expect(kept), hash)
    })
}

/// What a run keeps of a frame.
#[derive(Clone, Copy, PartialEq)]
enum Keep {
    /// The whole frame and its key, for a sink that writes them.
    Frames,
    /// Only its hash: the rows being rendered and hashed (a ring of
    /// [`crate::render::ring_rows`]), and no key (hashing every sphere for it costs 40 ms of
    /// CPU at a million).
    Hashes,
}

/// The next frame is prepared while this one renders only when this one has fewer spheres in
/// view than this, over all its time samples: above it, the two frames' spheres in view
/// coordinates would be in memory at once (about 100 MB more at a million in view), and a frame
/// that large prepares on the whole pool anyway (at 1 M spheres the same time a frame, 390 MB
/// peak instead of 670 when view spheres took 128 bytes).
pub const PREPARE_AHEAD_MAX: usize = 1 << 18;

/// A frame's pixels (if kept) and hash.
type Delivered = (Option<Arc<Vec<u8>>>, FrameHash);

/// [`for_each_frame`], with the pixels and the key handed to `sink` only if `keep` says so.
fn run(
    doc: &Document,
    set: &FrameSet,
    mut done: impl FnMut(u64) -> bool,
    keep: Keep,
    mut sink: impl FnMut(u64, Option<&FrameKey>, Option<&Arc<Vec<u8>>>, FrameHash) -> Result<()>,
) -> Result<Timing> {
    let started = Instant::now();
    // The key hashes every sphere while the index is built (38 ms of 0.2 s at a million).
    let (base, index) = rayon::join(
        || (keep == Keep::Frames).then(|| KeyBase::new(&doc.scene, doc.raster)),
        || SceneIndex::for_frames_of(&doc.scene, doc.raster),
    );
    let mut renderer = Renderer::new();
    let end = set.range.end;
    let mut wanted = doc
        .exposures()
        .take_while(|item| item.as_ref().map_or(true, |(frame, _)| *frame < end))
        .filter(|item| {
            item.as_ref()
                .map_or(true, |&(frame, _)| set.contains(frame) && !done(frame))
        })
        .peekable();
    // The last frame delivered, sent again while the cameras stay the same.
    let mut previous: Option<(Vec<Camera>, Delivered)> = None;
    // The next frame to render, prepared while the one before it rendered.
    let mut prepared: Option<(Vec<Camera>, PreparedFrame)> = None;
    let mut buffers = FrameBuffers::default();
    let mut ring = Vec::new();
    let mut timing = Timing::default();
    while let Some(item) = wanted.next() {
        let (frame, exposure) = item?;
        // The cameras whose renders make the frame: one, or one per time sample.
        let cameras = exposure.renders();
        let (pixels, hash) = match previous.take() {
            Some((cams, delivered)) if Camera::all_same_bits(&cams, cameras) => {
                timing.held += 1;
                delivered
            }
            stale => {
                // Let go of the previous frame first: once the consumer has too, its buffer is
                // the one rendered into.
                drop(stale);
                let t = Instant::now();
                let this = match prepared.take() {
                    Some((cams, p)) if Camera::all_same_bits(&cams, cameras) => p,
                    _ => renderer.prepare_times(cameras, &index, doc.raster),
                };
                // The next frame that is not this one again.
                // Not while a frame with very many spheres in view renders (see
                // [`PREPARE_AHEAD_MAX`]), nor while a shadow grid waits to be built (by the
                // next frame: this one's rows would wait for the build on the pool).
                let next = match wanted.peek() {
                    Some(Ok((_, e)))
                        if !Camera::all_same_bits(e.renders(), cameras)
                            && this.view_spheres() < PREPARE_AHEAD_MAX
                            && index.shadow_grids_built() =>
                    {
                        Some(e.renders().to_vec())
                    }
                    _ => None,
                };
                let mut pixels = (keep == Keep::Frames).then(|| buffers.take());
                let mut hasher = FrameHasher::default();
                let mut in_order = |row: &[u8]| hasher.update(row);
                let ((), ahead) = rayon::join(
                    || match pixels.as_mut() {
                        Some(p) => {
                            let buffer = Arc::get_mut(p).expect("a taken buffer is not shared");
                            this.render_into(buffer, &mut in_order)
                        }
                        None => this.render_through(&mut ring, &mut in_order),
                    },
                    || {
                        next.map(|cams| {
                            let p = renderer.prepare_times(&cams, &index, doc.raster);
                            (cams, p)
                        })
                    },
                );
                prepared = ahead;
                let hash = hasher.finish();
                timing.render_secs.push(t.elapsed().as_secs_f64());
                timing.max_in_view = timing.max_in_view.max(this.in_view());
                renderer.recycle(this);
                if let Some(p) = &pixels {
                    buffers.keep(p);
                }
                (pixels, hash)
            }
        };
        let key = base.as_ref().map(|base| key(doc, base, &exposure));
        sink(frame, key.as_ref(), pixels.as_ref(), hash)?;
        timing.frames += 1;
        timing.first_frame_at.get_or_insert_with(Instant::now);
        previous = Some((cameras.to_vec(), (pixels, hash)));
    }
    timing.wall_secs = started.elapsed().as_secs_f64();
    Ok(timing)
}

/// Frame buffers handed out before, reused once nobody else holds them: a frame is rendered
/// into memory that is already mapped, not into fresh pages that the kernel must fault in and
/// zero (some 1,500 of them at 1080p).
#[derive(Default)]
struct FrameBuffers {
    handed_out: Vec<Arc<Vec<u8>>>,
}

impl FrameBuffers {
    /// More than a run holds at once: the frame being rendered, the one sent to the consumer,
    /// and the one the consumer is still on.
    const MOST: usize = 4;

    /// A buffer that no one else holds, or a new empty one. Its old bytes are all overwritten
    /// by the render.
    fn take(&mut self) -> Arc<Vec<u8>> {
        let handed_out = &mut self.handed_out;
        let free = handed_out.iter().position(|b| Arc::strong_count(b) == 1);
        free.map_or_else(|| Arc::new(Vec::new()), |k| handed_out.swap_remove(k))
    }

    /// Remembers `pixels` for reuse once its other holders let go of it.
    fn keep(&mut self, pixels: &Arc<Vec<u8>>) {
        if self.handed_out.len() == Self::MOST {
            self.handed_out.remove(0);
        }
        self.handed_out.push(Arc::clone(pixels));
    }
}

/// [`for_each_frame`] with `consume` on a second thread, so a frame is written while the next
/// one renders. At most one frame waits between them: memory stays flat in the number of
/// frames. The first error of either side is returned.
pub fn stream_frames(
    doc: &Document,
    set: &FrameSet,
    done: impl FnMut(u64) -> bool,
    mut consume: impl FnMut(u64, &FrameKey, &[u8], FrameHash) -> Result<()> + Send,
) -> Result<Timing> {
    let started = Instant::now();
    std::thread::scope(|scope| {
        type Sent = (u64, FrameKey, Arc<Vec<u8>>, FrameHash);
        let (tx, rx) = std::sync::mpsc::sync_channel::<Sent>(1);
        let consumer = scope.spawn(move || -> Result<()> {
            for (frame, key, pixels, hash) in rx {
                consume(frame, &key, &pixels, hash)?;
            }
            Ok(())
        });
        let rendered = for_each_frame(doc, set, done, |frame, key, pixels, hash| {
            // A failed send means the consumer stopped on an error: stop rendering too; the
            // consumer's error is the one reported.
            tx.send((frame, *key, Arc::clone(pixels), hash))
                .map_err(|_| Error::Usage("the frame consumer stopped".into()))
        });
        drop(tx);
        consumer
            .join()
            .expect("the frame consumer does not panic")?;
        // The run ends when the last frame is written or hashed, not when it is rendered.
        let mut timing = rendered?;
        timing.wall_secs = started.elapsed().as_secs_f64();
        Ok(timing)
    })
}

/// Renders `frames`, each hashed row by row as its rows are rendered (on the same threads, so
/// hashing overlaps rendering), through a ring of rows rather than a whole frame; `each` sees
/// every (frame, hash) in order, as it is ready, and may stop the run by returning an error.
pub fn hash_frames(
    doc: &Document,
    frames: Range<u64>,
    mut each: impl FnMut(u64, FrameHash) -> Result<()>,
) -> Result<Timing> {
    run(
        doc,
        &FrameSet::all(frames),
        |_| false,
        Keep::Hashes,
        |frame, _, _, hash| each(frame, hash),
    )
}

/// The `(frame, sha256)` pairs of `frames`, without writing images.
///
/// ```
/// # let doc = campath::document::Document::from_str(std::path::Path::new("t.ron"),
/// #     "(frames: 2, image: (width: 8, height: 4), camera: (vrp: (0.0, 0.0, -4.0), tp: (0.0, 0.0, 0.0)),
/// #       scene: (spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0)]))").unwrap();
/// let hashes = campath::frames::hashes(&doc, 0..2).unwrap();
/// assert_eq!(hashes.len(), 2);
/// assert_eq!(hashes[1].1.to_string().len(), 64);
/// ```
pub fn hashes(doc: &Document, frames: Range<u64>) -> Result<Vec<(u64, FrameHash)>> {
    let mut out = Vec::new();
    hash_frames(doc, frames, |frame, hash| {
        out.push((frame, hash));
        Ok(())
    })?;
    Ok(out)
}

/// Frame `frame`'s RGB8 pixels, row-major, top row first (with motion blur, the mean of its
/// time samples' renders).
pub fn render_frame(doc: &Document, frame: u64) -> Result<Vec<u8>> {
    let exposure = doc.exposure(frame)?;
    let index = SceneIndex::for_frames_of(&doc.scene, doc.raster);
    let mut pixels = Vec::new();
    Renderer::new()
        .prepare_times(exposure.renders(), &index, doc.raster)
        .render_into(&mut pixels, &mut |_| {});
    Ok(pixels)
}

/// A frame whose fresh render does not hash as expected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Difference {
    /// The frame.
    pub frame: u64,
    /// The golden hash; None when the golden does not list the frame (or there is none).
    pub expected: Option<FrameHash>,
    /// The fresh render's hash; None when the animation has no such frame.
    pub actual: Option<FrameHash>,
}

/// Renders the frames listed in `expected` (for example a hashes.txt read with
/// [`crate::output::manifest::parse_hashes`]) and returns those that differ.
///
/// ```
/// # use std::path::Path;
/// # let doc = campath::document::Document::from_str(Path::new("t.ron"),
/// #     "(frames: 3, image: (width: 8, height: 4), camera: (vrp: (0.0, 0.0, -4.0), tp: (0.0, 0.0, 0.0)),
/// #       scene: (spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0)]))").unwrap();
/// let mut golden = campath::frames::hashes(&doc, 0..3).unwrap();
/// golden[1].1 = campath::FrameHash([0; 32]);
/// let differ = campath::frames::compare(&doc, &golden).unwrap();
/// assert_eq!(differ.len(), 1);
/// assert_eq!(differ[0].frame, 1);
/// ```
pub fn compare(doc: &Document, expected: &[(u64, FrameHash)]) -> Result<Vec<Difference>> {
    compare_each(doc, expected, |_, _| Ok(()))
}

/// [`compare`], also handing each differing frame's fresh pixels to `each` as it is found.
pub fn compare_each(
    doc: &Document,
    expected: &[(u64, FrameHash)],
    mut each: impl FnMut(&Difference, &[u8]) -> Result<()> + Send,
) -> Result<Vec<Difference>> {
    let total = doc.animation.frames;
    let wanted: BTreeMap<u64, FrameHash> = expected.iter().copied().collect();
    let end = wanted.keys().last().map_or(0, |last| (last + 1).min(total));
    let mut differ = Vec::new();
    stream_frames(
        doc,
        &FrameSet::all(0..end),
        |frame| !wanted.contains_key(&frame),
        |frame, _, pixels, hash| {
            if wanted[&frame] != hash {
                let d = Difference {
                    frame,
                    expected: Some(wanted[&frame]),
                    actual: Some(hash),
                };
                each(&d, pixels)?;
                differ.push(d);
            }
            Ok(())
        },
    )?;
    differ.extend(past_end(&wanted, total));
    Ok(differ)
}

/// The frames from `total` on that `expected` lists: frames the animation does not have.
pub(crate) fn past_end(
    expected: &BTreeMap<u64, FrameHash>,
    total: u64,
) -> impl Iterator<Item = Difference> + '_ {
    expected.range(total..).map(|(&frame, &hash)| Difference {
        frame,
        expected: Some(hash),
        actual: None,
    })
}

/// `1, 4, 7` for a few frames, `1, 4, 7, … (40 in all)` for many.
pub fn list_frames(frames: &[u64]) -> String {
    list_first(frames.iter().copied(), frames.len() as u64)
}

/// [`list_frames`] of `count` frames, which `frames` yields (only the first are taken).
pub fn list_first(frames: impl Iterator<Item = u64>, count: u64) -> String {
    const SHOWN: usize = 8;
    let shown: Vec<String> = frames.take(SHOWN).map(|f| f.to_string()).collect();
    if count > SHOWN as u64 {
        format!("{}, … ({count} in all)", shown.join(", "))
    } else {
        shown.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash::frame_hash;
    use std::path::Path;

    #[test]
    fn shards_parse_only_when_well_formed() {
        assert!("3/2".parse::<Shard>().is_err());
        assert!("0/0".parse::<Shard>().is_err());
        assert!("1".parse::<Shard>().is_err());
        assert_eq!("1/4".parse::<Shard>(), Ok(Shard { index: 1, count: 4 }));
        assert_eq!(Shard { index: 1, count: 4 }.to_string(), "1/4");
        let set = FrameSet {
            range: 2..10,
            shard: Some(Shard { index: 1, count: 4 }),
        };
        assert_eq!(
            (2..10).filter(|k| set.contains(*k)).collect::<Vec<_>>(),
            [5, 9]
        );
        assert_eq!(set.count(), 2);
    }

    /// Frames 0–2 share a camera, 3–5 move, 6–9 keep frame 5's. Taller than the ring of rows.
    const HOLDS: &str = "(frames: 10, fps: 10.0, image: (width: 40, height: 150),
        camera: (vrp: (0.0, 0.0, -4.0), tp: (0.0, 0.0, 0.0)),
        animate: [Observer(keys: [(t: 0.0, value: (0.0, 0.0, -4.0)), (t: 0.2, value: (0.0, 0.0, -4.0)),
            (t: 0.5, value: (1.5, 0.5, -4.0))], interpolation: Linear)],
        scene: (lights: [(direction: (-0.5, -1.0, 0.7))], spheres: [
            (center: (0.0, 0.0, 0.0), radius: 1.0), (center: (1.2, 0.3, -1.0), radius: 0.4)]))";

    /// Each delivered frame, against the frame rendered on its own by a fresh renderer: frames
    /// passed over, held frames and frames prepared while the one before rendered.
    #[test]
    fn every_frame_delivered_is_the_frame_rendered_alone() {
        let doc = Document::from_str(Path::new("holds.ron"), HOLDS).unwrap();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut seen = Vec::new();
            let timing = pool
                .install(|| {
                    for_each_frame(
                        &doc,
                        &FrameSet::all(0..10),
                        |frame| frame == 1 || frame == 4,
                        |frame, _, pixels, hash| {
                            seen.push((frame, pixels.to_vec(), hash));
                            Ok(())
                        },
                    )
                })
                .unwrap();
            let frames: Vec<u64> = seen.iter().map(|s| s.0).collect();
            assert_eq!(frames, [0, 2, 3, 5, 6, 7, 8, 9]);
            // Frame 2 repeats frame 0, and 6–9 repeat 5; 5 was prepared while 3 rendered.
            assert_eq!((timing.frames, timing.held), (8, 5));
            for (frame, pixels, hash) in &seen {
                let alone = render_frame(&doc, *frame).unwrap();
                assert!(*pixels == alone, "frame {frame}, {threads} threads");
                assert_eq!(*hash, frame_hash(&alone), "frame {frame}");
            }
            assert_ne!(seen[1].2, seen[2].2, "the camera moves from frame 2 to 3");
            // Hash-only, through a ring of rows (150 rows go round a ring of 64 twice): the
            // same hashes, for every frame.
            let hashes = pool.install(|| hashes(&doc, 0..10)).unwrap();
            for (frame, hash) in hashes {
                let alone = render_frame(&doc, frame).unwrap();
                assert_eq!(hash, frame_hash(&alone), "frame {frame}, {threads} threads");
            }
        }
    }
}
