//! The checked scene: spheres and directional lights in world coordinates. Every value here is
//! finite and in range ([`crate::document`] checks them).

use glam::DVec3;
use rayon::prelude::*;
use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};

/// A sphere in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// World units.
    pub center_world: DVec3,
    /// World units, > 0.
    pub radius: f64,
    /// Linear RGB in [0, 1].
    pub color: DVec3,
}

impl Sphere {
    /// The centre and radius.
    pub fn ball(&self) -> (DVec3, f64) {
        (self.center_world, self.radius)
    }
}

/// A directional light: parallel rays travelling along `direction_world`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Unit vector, the way the light travels (a surface facing −direction is fully lit).
    pub direction_world: DVec3,
    /// Linear RGB, ≥ 0.
    pub color: DVec3,
    /// Whether spheres cast hard shadows from this light.
    pub shadows: bool,
}

/// Checked spheres and directional lights.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Linear RGB in [0, 1], seen where no sphere is hit.
    pub background: DVec3,
    /// Ambient term added to every light's contribution, ≥ 0.
    pub ambient: f64,
    /// Directional lights.
    pub lights: Vec<Light>,
    /// The spheres.
    pub spheres: Spheres,
}

/// The scene's spheres, stored as small as their values allow and read back bit for bit: a
/// centre and radius that are all f32 values (a float PLY's, most generated scenes') take 16
/// bytes, not 32, and a colour of 8-bit levels (k / 255, or an sRGB level as linear light) or
/// one met just before takes 4 bytes, not 24. Any other sphere keeps its f64 values beside
/// them; where those would cost more than [`EXCEPTIONS_MAX`] bytes a sphere on average (a file
/// of doubles), every sphere is kept whole. [`Spheres::get`] gives the [`Sphere`] that was put
/// in, to the bit.
#[derive(Clone, Default)]
pub struct Spheres(Store);

#[derive(Clone)]
enum Store {
    /// Each sphere whole: spheres that do not pack, and the renderer's copy of a small scene,
    /// read in its hottest loops.
    Wide(Vec<Sphere>),
    Packed(Packed),
}

impl Default for Store {
    fn default() -> Store {
        Spheres::new().0
    }
}

#[derive(Clone, Default)]
struct Packed {
    /// Centre and radius as f32; or, where one of them is not an f32, NaN and the index of
    /// its f64 values in `wide` (as the bits of the second).
    balls: Vec<[f32; 4]>,
    /// Each sphere's colour ([`color_code`]).
    colors: Vec<u32>,
    /// The centres and radii that are not f32 values.
    wide: Vec<[f64; 4]>,
    /// The colours that are not 8-bit levels, each once per run of spheres that share it.
    palette: Vec<DVec3>,
    /// The spheres room was asked for ([`Spheres::reserve`]), made once the spheres show
    /// whether they pack: room made and handed back unused would leave the allocator keeping
    /// later blocks of that size (the next frames' buffers) rather than returning them.
    room: usize,
}

/// The most bytes a sphere, on average, that the f64 values and palette entries of packed
/// spheres may cost. Past it every sphere is kept whole (a file of f64 values): packed, each
/// of their reads would take a second read, and more memory.
const EXCEPTIONS_MAX: usize = 4;

/// The fewest spheres that may be kept whole: fewer cost little either way, and a few inline
/// f64 spheres (a ground) do not decide for a file of f32 values after them.
const WIDEN_FROM: usize = 4096;

/// A colour code's flag: the rest is an index into the palette.
const PALETTE: u32 = 1 << 31;
/// A colour code's flag: the three levels below it are sRGB levels, as linear light.
const SRGB: u32 = 1 << 24;
/// No colour code yet (never a palette's: the palette stops short of it).
const UNCODED: u32 = u32::MAX;

/// The 256 levels k / 255.
static LEVELS: [f64; 256] = {
    let mut t = [0.0; 256];
    let mut k = 0;
    while k < 256 {
        t[k] = k as f64 / 255.0;
        k += 1;
    }
    t
};

/// The 256 sRGB levels as linear light ([`srgb_linear`]).
fn srgb_levels() -> &'static [f64; 256] {
    static TABLE: std::sync::OnceLock<[f64; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|k| srgb_linear(k as u8)))
}

/// A level of 8-bit sRGB as linear light (IEC 61966-2-1).
pub(crate) fn srgb_linear(level: u8) -> f64 {
    let c = f64::from(level) / 255.0;
    match c <= 0.04045 {
        true => c / 12.92,
        false => libm::pow((c + 0.055) / 1.055, 2.4),
    }
}

/// The level of `table` (increasing) whose value is `v` to the bit.
fn level_in(table: &[f64; 256], v: f64) -> Option<u32> {
    let k = table.partition_point(|&t| t < v);
    (k < 256 && table[k].to_bits() == v.to_bits()).then_some(k as u32)
}

/// The level k whose k / 255 is `v` to the bit.
#[inline]
fn byte_level(v: f64) -> Option<u32> {
    // The nearest level for any v within a few ulps of one, without `f64::round` (a call
    // into libm on the baseline path): the check to the bit decides.
    let x = v * 255.0 + 0.5;
    if !(0.0..256.0).contains(&x) {
        return None;
    }
    let k = x as usize;
    (LEVELS[k].to_bits() == v.to_bits()).then_some(k as u32)
}

/// Whether `p` with `block` after it would cost more than [`EXCEPTIONS_MAX`] bytes a sphere
/// in f64 values and palette ([`Packed::costly`]). A colour that is not levels counts where it
/// differs from the sphere's before (the palette keeps one a run): at most the entries made.
fn costly(p: &Packed, block: &[Sphere]) -> bool {
    let (wide, colors) = (0..block.len())
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| {
            let s = &block[i];
            let before = match i {
                0 => p.palette.last().copied(),
                _ => Some(block[i - 1].color),
            };
            let new = color_code(s.color).is_none() && !before.is_some_and(|b| same(b, s.color));
            (usize::from(narrow(s).is_none()), usize::from(new))
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    p.costly(block.len(), wide, colors)
}

/// Whether two colours are the same to the bit.
fn same(a: DVec3, b: DVec3) -> bool {
    a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits)
}

/// `c` as three 8-bit levels (k / 255, or sRGB as linear light), or None.
#[inline]
fn color_code(c: DVec3) -> Option<u32> {
    let [r, g, b] = c.to_array();
    match (byte_level(r), byte_level(g), byte_level(b)) {
        (Some(r), Some(g), Some(b)) => Some(levels_code([r, g, b])),
        _ => {
            let [r, g, b] = c.to_array().map(|v| level_in(srgb_levels(), v));
            Some(SRGB | levels_code([r?, g?, b?]))
        }
    }
}

/// The code of three 8-bit levels, red highest ([`color_code`]'s, less its flags).
#[inline]
fn levels_code([r, g, b]: [u32; 3]) -> u32 {
    r << 16 | g << 8 | b
}

/// A sphere's centre and radius as f32, when each is one (finite, and the same to the bit).
fn narrow(s: &Sphere) -> Option<[f32; 4]> {
    let v = [
        s.center_world.x,
        s.center_world.y,
        s.center_world.z,
        s.radius,
    ];
    let f = v.map(|x| x as f32);
    let exact = v
        .iter()
        .zip(&f)
        .all(|(&x, &y)| x.is_finite() && f64::from(y).to_bits() == x.to_bits());
    exact.then_some(f)
}

impl Packed {
    fn get(&self, k: usize) -> Sphere {
        let (center_world, radius) = self.ball(k);
        Sphere {
            center_world,
            radius,
            color: self.color(k),
        }
    }

    fn color(&self, k: usize) -> DVec3 {
        self.decode(self.colors[k])
    }

    /// The colour of a colour code. Out of line: the shading's loops decode packed spheres'
    /// codes ([`Spheres::color_of_code`]), and only the whole spheres of a small scene's copy
    /// belong inline there.
    #[inline(never)]
    fn decode(&self, code: u32) -> DVec3 {
        match code & PALETTE != 0 {
            true => self.palette[(code & !PALETTE) as usize],
            false => {
                let table = if code & SRGB != 0 {
                    srgb_levels()
                } else {
                    &LEVELS
                };
                let level = |shift: u32| table[(code >> shift & 0xff) as usize];
                DVec3::new(level(16), level(8), level(0))
            }
        }
    }

    #[inline]
    fn ball(&self, k: usize) -> (DVec3, f64) {
        let [x, y, z, r] = self.balls[k];
        match x.is_nan() {
            true => {
                let [x, y, z, r] = self.wide[y.to_bits() as usize];
                (DVec3::new(x, y, z), r)
            }
            false => (DVec3::new(x.into(), y.into(), z.into()), r.into()),
        }
    }

    /// Sphere `s`'s ball: as f32, or through `wide`.
    fn ball_of(&mut self, s: &Sphere) -> [f32; 4] {
        narrow(s).unwrap_or_else(|| {
            let at = u32::try_from(self.wide.len()).expect("fewer than 2^32 spheres");
            let c = s.center_world;
            self.wide.push([c.x, c.y, c.z, s.radius]);
            [f32::NAN, f32::from_bits(at), 0.0, 0.0]
        })
    }

    /// Colour `c`'s code: its levels, or through the palette.
    fn code_of(&mut self, c: DVec3) -> u32 {
        color_code(c).unwrap_or_else(|| {
            if !self.palette.last().is_some_and(|&p| same(p, c)) {
                assert!(
                    self.palette.len() < PALETTE as usize - 1,
                    "fewer than 2^31 colours"
                );
                self.palette.push(c);
            }
            PALETTE | (self.palette.len() - 1) as u32
        })
    }

    /// Whether the spheres' f64 values and palette, with `more` spheres of which `wide` are not
    /// f32 values and `colors` make palette entries, would cost more than [`EXCEPTIONS_MAX`]
    /// bytes a sphere; never below [`WIDEN_FROM`] spheres.
    fn costly(&self, more: usize, wide: usize, colors: usize) -> bool {
        let n = self.balls.len() + more;
        let exceptions = (self.wide.len() + wide) * 32 + (self.palette.len() + colors) * 24;
        n >= WIDEN_FROM && exceptions > n * EXCEPTIONS_MAX
    }

    /// Room for `more` spheres, and the room asked for before ([`Spheres::reserve`]) where
    /// that is more: where the next block's first sphere goes.
    fn make_room(&mut self, more: usize) -> usize {
        let start = self.balls.len();
        let room = self.room.max(start + more) - start;
        self.balls.reserve(room);
        self.colors.reserve(room);
        start
    }

    fn push(&mut self, s: &Sphere) {
        let ball = self.ball_of(s);
        let code = self.code_of(s.color);
        self.balls.push(ball);
        self.colors.push(code);
    }
}

impl Spheres {
    /// No spheres.
    pub const fn new() -> Spheres {
        Spheres(Store::Packed(Packed {
            balls: Vec::new(),
            colors: Vec::new(),
            wide: Vec::new(),
            palette: Vec::new(),
            room: 0,
        }))
    }

    /// The renderer's copy: each sphere whole, read without unpacking.
    pub(crate) fn wide(spheres: Vec<Sphere>) -> Spheres {
        Spheres(Store::Wide(spheres))
    }

    /// How many spheres.
    pub fn len(&self) -> usize {
        match &self.0 {
            Store::Wide(v) => v.len(),
            Store::Packed(p) => p.balls.len(),
        }
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sphere `k`, as it was put in. Panics past the end.
    #[inline]
    pub fn get(&self, k: usize) -> Sphere {
        match &self.0 {
            Store::Wide(v) => v[k],
            Store::Packed(p) => p.get(k),
        }
    }

    /// Sphere `k`'s centre and radius (without its colour). Panics past the end.
    #[inline]
    pub fn ball(&self, k: usize) -> (DVec3, f64) {
        match &self.0 {
            Store::Wide(v) => (v[k].center_world, v[k].radius),
            Store::Packed(p) => p.ball(k),
        }
    }

    /// Sphere `k`'s colour. Panics past the end.
    #[inline]
    pub fn color(&self, k: usize) -> DVec3 {
        match &self.0 {
            Store::Wide(v) => v[k].color,
            Store::Packed(p) => p.color(k),
        }
    }

    /// Each sphere's colour code, where the spheres are packed: 4 bytes a sphere that a
    /// frame's view keeps beside each sphere it sees ([`Spheres::color_of_code`]), so that
    /// shading a hit reads no more of the scene. Whole spheres keep their colour beside their
    /// centre, and have none.
    #[inline]
    pub(crate) fn color_codes(&self) -> Option<&[u32]> {
        match &self.0 {
            Store::Wide(_) => None,
            Store::Packed(p) => Some(&p.colors),
        }
    }

    /// The colour of one of [`Spheres::color_codes`]: the bits [`Spheres::color`] gives its
    /// sphere. Panics where the spheres are whole (they have no codes).
    #[inline]
    pub(crate) fn color_of_code(&self, code: u32) -> DVec3 {
        match &self.0 {
            Store::Wide(_) => panic!("whole spheres have no colour codes"),
            Store::Packed(p) => p.decode(code),
        }
    }

    /// Where sphere `k`'s centre is kept, for a prefetch hint.
    #[inline]
    pub(crate) fn slot(&self, k: usize) -> Slot<'_> {
        match &self.0 {
            Store::Wide(v) => Slot::Wide(&v[k]),
            Store::Packed(p) => Slot::Packed(&p.balls[k]),
        }
    }

    /// Replaces sphere `k`. Panics past the end.
    pub fn set(&mut self, k: usize, s: Sphere) {
        match &mut self.0 {
            Store::Wide(v) => v[k] = s,
            Store::Packed(p) => {
                p.balls[k] = p.ball_of(&s);
                p.colors[k] = p.code_of(s.color);
            }
        }
    }

    /// Appends sphere `s`.
    pub fn push(&mut self, s: Sphere) {
        match &mut self.0 {
            Store::Wide(v) => v.push(s),
            Store::Packed(p) => {
                p.push(&s);
                if p.costly(0, 0, 0) {
                    self.widen(&[]);
                }
            }
        }
    }

    /// Every sphere whole from now on, and `more` after them: the packed spheres' exceptions
    /// cost more than packing saves, and reading them costs a second read each.
    fn widen(&mut self, more: &[Sphere]) {
        if let Store::Packed(p) = &self.0 {
            let room = p.room.max(p.balls.len() + more.len());
            let mut all: Vec<Sphere> = Vec::with_capacity(room);
            all.extend((0..p.balls.len()).map(|k| p.get(k)));
            all.extend_from_slice(more);
            self.0 = Store::Wide(all);
        }
    }

    /// Room for `n` more spheres.
    pub fn reserve(&mut self, n: usize) {
        match &mut self.0 {
            Store::Wide(v) => v.reserve(n),
            Store::Packed(p) => p.room = p.room.max(p.balls.len().saturating_add(n)),
        }
    }

    /// Hands back the room past the last sphere.
    pub fn shrink_to_fit(&mut self) {
        match &mut self.0 {
            Store::Wide(v) => v.shrink_to_fit(),
            Store::Packed(p) => {
                p.balls.shrink_to_fit();
                p.colors.shrink_to_fit();
                p.wide.shrink_to_fit();
                p.palette.shrink_to_fit();
            }
        }
    }

    /// Appends `block` ([`Spheres::extend_from_slice`]); to no spheres, where packing them
    /// would not pay, keeps it as it is, without a copy.
    pub(crate) fn append(&mut self, block: Vec<Sphere>) {
        if self.is_empty()
            && matches!(self.0, Store::Packed(_))
            && costly(&Packed::default(), &block)
        {
            // Kept as they are: no copy.
            self.0 = Store::Wide(block);
        } else {
            self.extend_from_slice(&block);
        }
    }

    /// Appends `items`, made on the rayon pool, through `scratch` (a block at a time, its memory
    /// reused) when they are packed.
    pub(crate) fn par_extend(
        &mut self,
        items: impl IndexedParallelIterator<Item = Sphere>,
        scratch: &mut Vec<Sphere>,
    ) {
        match &mut self.0 {
            Store::Wide(v) => v.par_extend(items),
            Store::Packed(_) => {
                scratch.clear();
                scratch.par_extend(items);
                self.extend_from_slice(scratch);
            }
        }
    }

    /// Appends `block`, packed on the rayon pool: the same spheres as pushed one by one.
    pub(crate) fn extend_from_slice(&mut self, block: &[Sphere]) {
        let p = match &mut self.0 {
            Store::Wide(v) => return v.extend_from_slice(block),
            Store::Packed(p) => p,
        };
        // Before the block that makes the room asked for, whether the spheres pack is found
        // first, so that room for them all is made only where they do (room made and handed
        // back would raise the allocator's threshold for the frames' buffers: a million
        // spheres of doubles after an inline ground, 184 -> 203 MB). After it, they are packed
        // at once and the cost counted from what packing made: one pass over a block, not two.
        let first = p.room > p.balls.capacity();
        if first && costly(p, block) {
            return self.widen(block);
        }
        let start = p.make_room(block.len());
        // Each sphere packed where it can be, marked where not (a NaN ball, no colour code):
        // the wide values and the palette are then given in order, on this thread.
        let marked = AtomicBool::new(false);
        let mark = || marked.store(true, Ordering::Relaxed);
        let mut columns = (std::mem::take(&mut p.balls), std::mem::take(&mut p.colors));
        columns.par_extend(block.par_iter().with_min_len(4096).map(|s| {
            let ball = narrow(s).unwrap_or_else(|| {
                mark();
                [f32::NAN; 4]
            });
            let code = color_code(s.color).unwrap_or_else(|| {
                mark();
                UNCODED
            });
            (ball, code)
        }));
        (p.balls, p.colors) = columns;
        if marked.into_inner() {
            for (k, s) in (start..).zip(block) {
                if p.balls[k][0].is_nan() {
                    p.balls[k] = p.ball_of(s);
                }
                if p.colors[k] == UNCODED {
                    p.colors[k] = p.code_of(s.color);
                }
            }
            if !first && p.costly(0, 0, 0) {
                self.widen(&[]);
            }
        }
    }

    /// Appends `count` spheres of f32 centre and radius and byte levels (k / 255), `row(k)` the
    /// k-th, made on the rayon pool: the store [`Spheres::extend_from_slice`] makes of the same
    /// spheres, without making them. Whether it did: not where the spheres are whole, where
    /// the first block would widen them, or where a row is None (then none is appended).
    pub(crate) fn extend_plain(
        &mut self,
        count: usize,
        row: impl Fn(usize) -> Option<([f32; 4], [u8; 3])> + Sync,
    ) -> bool {
        let Store::Packed(p) = &mut self.0 else {
            return false;
        };
        // Such spheres add no f64 values and no palette entry, so the cost rises only where
        // `extend_from_slice`'s first block would find it (the spheres before them costly).
        if p.room > p.balls.capacity() && p.costly(count, 0, 0) {
            return false;
        }
        let start = p.make_room(count);
        let missing = AtomicBool::new(false);
        let mut columns = (std::mem::take(&mut p.balls), std::mem::take(&mut p.colors));
        let rows = (0..count).into_par_iter().with_min_len(4096);
        columns.par_extend(rows.map(|k| match row(k) {
            // `color_code` of (r, g, b) / 255: the levels themselves.
            Some((ball, levels)) => (ball, levels_code(levels.map(u32::from))),
            None => {
                missing.store(true, Ordering::Relaxed);
                ([0.0; 4], UNCODED)
            }
        }));
        (p.balls, p.colors) = columns;
        if missing.into_inner() {
            p.balls.truncate(start);
            p.colors.truncate(start);
            return false;
        }
        true
    }

    /// Packed spheres taken in `order` (a permutation of their indices), still packed, made on
    /// the rayon pool: the renderer's copy of a large scene along its curve, 20 bytes a sphere.
    /// None where the spheres are whole.
    pub(crate) fn packed_along(&self, order: &[u32]) -> Option<Spheres> {
        let Store::Packed(p) = &self.0 else {
            return None;
        };
        debug_assert_eq!(order.len(), p.balls.len(), "an index for every sphere");
        // A ball that is not f32 values names its place in `wide`, which is kept whole.
        let (balls, colors) = order
            .par_iter()
            .with_min_len(4096)
            .map(|&k| (p.balls[k as usize], p.colors[k as usize]))
            .unzip();
        Some(Spheres(Store::Packed(Packed {
            balls,
            colors,
            wide: p.wide.clone(),
            palette: p.palette.clone(),
            room: 0,
        })))
    }

    /// Each sphere's centre and radius as f32 (`[x, y, z, r]`), where every one of them is
    /// packed as f32 values.
    pub(crate) fn f32_balls(&self) -> Option<&[[f32; 4]]> {
        match &self.0 {
            Store::Packed(p) if p.wide.is_empty() => Some(&p.balls),
            _ => None,
        }
    }

    /// Each sphere, in order, on the rayon pool.
    pub fn par_iter(&self) -> impl IndexedParallelIterator<Item = Sphere> + '_ {
        (0..self.len()).into_par_iter().map(|k| self.get(k))
    }

    /// Each sphere's centre and radius ([`Spheres::ball`]), in order, on the rayon pool.
    pub fn par_balls(&self) -> impl IndexedParallelIterator<Item = (DVec3, f64)> + '_ {
        (0..self.len()).into_par_iter().map(|k| self.ball(k))
    }

    /// Each sphere, in order.
    pub fn iter(&self) -> Iter<'_> {
        Iter {
            spheres: self,
            next: 0,
            end: self.len(),
        }
    }

    /// The bytes the spheres take.
    pub fn bytes(&self) -> usize {
        match &self.0 {
            Store::Wide(v) => v.capacity() * size_of::<Sphere>(),
            Store::Packed(p) => {
                p.balls.capacity() * 16
                    + p.colors.capacity() * 4
                    + p.wide.capacity() * 32
                    + p.palette.capacity() * 24
            }
        }
    }
}

/// Where a sphere's centre is kept ([`Spheres::slot`]).
pub(crate) enum Slot<'a> {
    Wide(&'a Sphere),
    Packed(&'a [f32; 4]),
}

/// The spheres in order ([`Spheres::iter`]).
#[derive(Clone)]
pub struct Iter<'a> {
    spheres: &'a Spheres,
    next: usize,
    end: usize,
}

impl Iterator for Iter<'_> {
    type Item = Sphere;

    #[inline]
    fn next(&mut self) -> Option<Sphere> {
        (self.next < self.end).then(|| {
            self.next += 1;
            self.spheres.get(self.next - 1)
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.end - self.next, Some(self.end - self.next))
    }

    fn nth(&mut self, n: usize) -> Option<Sphere> {
        self.next = self.next.saturating_add(n).min(self.end);
        self.next()
    }
}

impl DoubleEndedIterator for Iter<'_> {
    fn next_back(&mut self) -> Option<Sphere> {
        (self.next < self.end).then(|| {
            self.end -= 1;
            self.spheres.get(self.end)
        })
    }
}

impl ExactSizeIterator for Iter<'_> {}

impl<'a> IntoIterator for &'a Spheres {
    type Item = Sphere;
    type IntoIter = Iter<'a>;

    fn into_iter(self) -> Iter<'a> {
        self.iter()
    }
}

impl From<Vec<Sphere>> for Spheres {
    /// Packed, or kept as they are (no copy) where packing would not pay.
    fn from(spheres: Vec<Sphere>) -> Spheres {
        let mut out = Spheres::new();
        out.append(spheres);
        out
    }
}

impl FromIterator<Sphere> for Spheres {
    fn from_iter<I: IntoIterator<Item = Sphere>>(iter: I) -> Spheres {
        let mut out = Spheres::new();
        out.extend(iter);
        out
    }
}

impl Extend<Sphere> for Spheres {
    fn extend<I: IntoIterator<Item = Sphere>>(&mut self, iter: I) {
        let iter = iter.into_iter();
        self.reserve(iter.size_hint().0);
        for s in iter {
            self.push(s);
        }
    }
}

impl PartialEq for Spheres {
    fn eq(&self, other: &Spheres) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

impl fmt::Debug for Spheres {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::splitmix::SplitMix;
    use proptest::prelude::*;

    fn bits(s: &Sphere) -> [u64; 7] {
        let (c, k) = (s.center_world, s.color);
        [c.x, c.y, c.z, s.radius, k.x, k.y, k.z].map(f64::to_bits)
    }

    fn sphere(v: [f64; 7]) -> Sphere {
        Sphere {
            center_world: DVec3::new(v[0], v[1], v[2]),
            radius: v[3],
            color: DVec3::new(v[4], v[5], v[6]),
        }
    }

    /// Values of every kind the store tells apart: f32 values (zeros of both signs, a
    /// subnormal, the largest), f64 values beyond f32 (in precision, in range, not finite),
    /// colour levels k / 255 and sRGB levels as linear light, and colours of neither.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            any::<f32>().prop_map(f64::from),
            any::<f64>(),
            Just(-0.0),
            Just(0.0),
            Just(f64::from(f32::MAX)),
            Just(f64::from(f32::from_bits(1))),
            Just(1e150),
            Just(0.1),
            (0u8..=255).prop_map(|k| f64::from(k) / 255.0),
            any::<u8>().prop_map(srgb_linear),
            Just(f64::NAN),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5ea1), failure_persistence: None, ..ProptestConfig::default() })]

        /// Every sphere comes back to the bit, pushed one by one or appended in a block, and
        /// after another sphere is set over it.
        #[test]
        fn spheres_come_back_to_the_bit(
            values in prop::collection::vec(prop::array::uniform7(value()), 0..40),
            over in prop::array::uniform7(value()),
        ) {
            let spheres: Vec<Sphere> = values.iter().map(|v| sphere(*v)).collect();
            let mut pushed = Spheres::new();
            for s in &spheres {
                pushed.push(*s);
            }
            let appended = Spheres::from(spheres.clone());
            for store in [&pushed, &appended] {
                prop_assert_eq!(store.len(), spheres.len());
                for (k, s) in spheres.iter().enumerate() {
                    prop_assert_eq!(bits(&store.get(k)), bits(s));
                    prop_assert_eq!(&store.ball(k).0.to_array().map(f64::to_bits)[..], &bits(s)[..3]);
                    prop_assert_eq!(store.ball(k).1.to_bits(), bits(s)[3]);
                    prop_assert_eq!(&store.color(k).to_array().map(f64::to_bits)[..], &bits(s)[4..]);
                }
                // A packed sphere's colour code gives its colour to the bit, whatever kind.
                let codes = store.color_codes().expect("fewer than WIDEN_FROM spheres pack");
                prop_assert_eq!(codes.len(), spheres.len());
                for (k, s) in spheres.iter().enumerate() {
                    let color = store.color_of_code(codes[k]);
                    prop_assert_eq!(&color.to_array().map(f64::to_bits)[..], &bits(s)[4..]);
                }
                let every: Vec<[u64; 7]> = store.iter().map(|s| bits(&s)).collect();
                let want: Vec<[u64; 7]> = spheres.iter().map(bits).collect();
                prop_assert_eq!(every, want);
            }
            if !spheres.is_empty() {
                let k = spheres.len() / 2;
                let mut set = appended.clone();
                set.set(k, sphere(over));
                prop_assert_eq!(bits(&set.get(k)), bits(&sphere(over)));
                let code = set.color_codes().expect("packed")[k];
                let color = set.color_of_code(code).to_array().map(f64::to_bits);
                prop_assert_eq!(&color[..], &bits(&sphere(over))[4..]);
                for j in (0..spheres.len()).filter(|&j| j != k) {
                    prop_assert_eq!(bits(&set.get(j)), bits(&spheres[j]));
                }
            }
        }
    }

    /// A float PLY's spheres (f32 centres and radii, colours of bytes) take 20 bytes each; a
    /// sphere of other values keeps them beside it (a run of one colour keeps it once), and the
    /// rest stay small.
    #[test]
    fn a_float_files_spheres_take_20_bytes() {
        let mut gen = SplitMix(5);
        let n = 10_000;
        let mut level = || f64::from((gen.unit() * 255.0) as u8) / 255.0;
        let spheres: Vec<Sphere> = (0..n)
            .map(|k| Sphere {
                center_world: DVec3::new(k as f64 * 0.25, -(k as f64), 3.5),
                radius: f64::from(0.1f32),
                color: DVec3::new(level(), level(), level()),
            })
            .collect();
        let mut store = Spheres::from(spheres.clone());
        store.shrink_to_fit();
        assert_eq!(store.bytes(), 20 * n);
        let ground = Sphere {
            center_world: DVec3::new(0.1, -1e5, 0.0),
            radius: 1e5,
            color: DVec3::new(0.55, 0.55, 0.5),
        };
        store.push(ground);
        store.push(ground);
        store.shrink_to_fit();
        assert_eq!(store.bytes(), 20 * (n + 2) + 2 * 32 + 24);
        assert_eq!(store.get(n + 1), ground);
        assert!(store.iter().take(n).eq(spheres.iter().copied()));
        // A block of one colour that is not levels keeps it once; two inline f64 spheres first
        // do not keep the file's whole.
        let red = DVec3::new(0.9, 0.3, 0.3);
        let one_colour: Vec<Sphere> = spheres
            .iter()
            .map(|&s| Sphere { color: red, ..s })
            .collect();
        let mut store = Spheres::from(vec![ground, ground]);
        store.append(one_colour.clone());
        store.shrink_to_fit();
        assert!(matches!(store.0, Store::Packed(_)));
        assert_eq!(store.bytes(), 20 * (n + 2) + 2 * 32 + 2 * 24);
        assert!(store.iter().skip(2).eq(one_colour));
    }

    /// Rows of f32 centres and radii and byte levels pack as the same spheres do, after
    /// spheres of every kind, with and without room asked for; and are not taken where the
    /// spheres are whole, where their first block widens them, or where a row is missing.
    #[test]
    fn plain_rows_pack_as_their_spheres_do() {
        let mut gen = SplitMix(0x91a1);
        let n = 9000;
        let odd = [
            -0.0,
            0.0,
            f32::from_bits(1),
            f32::MAX,
            -f32::MAX,
            f32::MIN_POSITIVE,
        ];
        let rows: Vec<([f32; 4], [u8; 3])> = (0..n)
            .map(|k| {
                let mut ball = [0.0f32; 4].map(|_| (gen.unit() * 64.0 - 32.0) as f32);
                ball[k % 3] = if k % 5 == 0 { odd[k % 6] } else { ball[k % 3] };
                ball[3] = ball[3].abs() + f32::from_bits(1);
                (ball, [0, 1, 2].map(|_| (gen.unit() * 256.0) as u8))
            })
            .collect();
        let spheres: Vec<Sphere> = (rows.iter())
            .map(|&(b, l)| Sphere {
                center_world: DVec3::new(b[0].into(), b[1].into(), b[2].into()),
                radius: b[3].into(),
                color: DVec3::from_array(l.map(|k| f64::from(k) / 255.0)),
            })
            .collect();
        let ground = Sphere {
            center_world: DVec3::new(0.1, -1e5, 0.0),
            radius: 1e5,
            color: DVec3::new(0.55, 0.55, 0.5),
        };
        let befores = [vec![], vec![ground, ground], spheres[..100].to_vec()];
        for (b, before) in befores.iter().enumerate() {
            for room in [false, true] {
                let mut want = Spheres::new();
                for s in before {
                    want.push(*s);
                }
                if room {
                    want.reserve(n);
                }
                let mut got = want.clone();
                want.extend_from_slice(&spheres);
                assert!(got.extend_plain(n, |k| Some(rows[k])), "{b} {room}");
                got.shrink_to_fit();
                want.shrink_to_fit();
                assert!(matches!(got.0, Store::Packed(_)), "{b} {room}");
                assert_eq!((got.len(), got.bytes()), (want.len(), want.bytes()));
                assert_eq!(got.color_codes(), want.color_codes(), "{b} {room}");
                for k in 0..want.len() {
                    assert_eq!(bits(&got.get(k)), bits(&want.get(k)), "{b} {room}: {k}");
                }
            }
        }
        let unchanged =
            |mut store: Spheres,
             count: usize,
             row: &(dyn Fn(usize) -> Option<([f32; 4], [u8; 3])> + Sync)| {
                let before: Vec<[u64; 7]> = store.iter().map(|s| bits(&s)).collect();
                assert!(!store.extend_plain(count, row));
                let after: Vec<[u64; 7]> = store.iter().map(|s| bits(&s)).collect();
                assert_eq!(before, after);
            };
        // Whole spheres; a row missing; and spheres of f64 values whose first block of rows
        // would widen them (as `extend_from_slice` does).
        unchanged(Spheres::wide(spheres[..10].to_vec()), n, &|k| Some(rows[k]));
        unchanged(Spheres::from(spheres[..10].to_vec()), n, &|k| {
            (k != n - 1).then(|| rows[k])
        });
        let mut wide = Spheres::new();
        for k in 0..4000 {
            wide.push(Sphere {
                radius: 0.1 + k as f64 * 1e-12,
                ..ground
            });
        }
        wide.reserve(200);
        let mut widened = wide.clone();
        widened.extend_from_slice(&spheres[..200]);
        assert!(matches!(widened.0, Store::Wide(_)), "the case widens");
        unchanged(wide, 200, &|k| Some(rows[k]));
    }

    /// Spheres of f64 values are kept whole, 56 bytes each (packed, each read would take a
    /// second): given at once, after a packed ground sphere, or one by one.
    #[test]
    fn spheres_of_f64_values_are_kept_whole() {
        let mut gen = SplitMix(9);
        let n = 5000;
        let spheres: Vec<Sphere> = (0..n)
            .map(|_| Sphere {
                center_world: DVec3::new(gen.unit(), gen.unit(), gen.unit()),
                radius: gen.unit() + 0.01,
                color: DVec3::new(gen.unit(), 0.5, 1.0),
            })
            .collect();
        let ground = Sphere {
            center_world: DVec3::new(0.0, -1e5, 0.0),
            radius: 1e5,
            color: DVec3::new(0.55, 0.55, 0.5),
        };
        let at_once = Spheres::from(spheres.clone());
        let mut after_ground = Spheres::from(vec![ground]);
        assert!(matches!(after_ground.0, Store::Packed(_)));
        after_ground.append(spheres.clone());
        let one_by_one: Spheres = spheres.iter().copied().collect();
        for mut store in [at_once, after_ground, one_by_one] {
            assert!(matches!(store.0, Store::Wide(_)));
            assert!(
                store.color_codes().is_none(),
                "whole spheres keep their colours"
            );
            store.shrink_to_fit();
            assert_eq!(store.bytes() / size_of::<Sphere>(), store.len());
            let skip = store.len() - n;
            assert!(store.iter().skip(skip).eq(spheres.iter().copied()));
        }
    }

    /// The colour tables hold the reader's values: k / 255, and the sRGB formula.
    #[test]
    fn level_tables_are_the_readers_values() {
        for k in 0..=255u8 {
            assert_eq!(
                LEVELS[k as usize].to_bits(),
                (f64::from(k) / 255.0).to_bits()
            );
            assert_eq!(
                srgb_levels()[k as usize].to_bits(),
                srgb_linear(k).to_bits()
            );
        }
        assert!(LEVELS.windows(2).all(|w| w[0] < w[1]));
        assert!(srgb_levels().windows(2).all(|w| w[0] < w[1]));
        // Against independent values: IEC 61966-2-1 at 0, 10 (linear part), 128 and 255.
        assert_eq!(srgb_linear(0), 0.0);
        assert!((srgb_linear(10) - 10.0 / 255.0 / 12.92).abs() < 1e-18);
        assert!((srgb_linear(128) - 0.215_860_5).abs() < 1e-7);
        assert_eq!(srgb_linear(255), 1.0);
    }
}
