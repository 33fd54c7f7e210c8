//! Tube coordinates and the signed gap: where a point is along a tube, which sector of the
//! cross-section holds it, and how far it is from the wall, with sign.
//!
//! The tube's surface is the continuous one the method defines:
//!
//! ```text
//! S(i, u, k, l) = C_i(u) + (1 - l) V_k(u) + l V_{k+1}(u),   V_k(u) = (1 - u) V_{i,k} + u V_{i+1,k}
//! ```
//!
//! with `C_i` the Catmull-Rom segment between rings `i` and `i + 1`, `u, l` in [0, 1], and `k`
//! running around the ring (mod `B`).
//!
//! **Axial coordinate.** Each ring has a plane through its control point with normal `n_i` (the
//! ring's own plane, from its spokes, so tilted rings slice correctly; the midline tangent when
//! the ring is collapsed). A point `P` lies in segment `i` when `d_i = (P - P_i) . n_i >= 0 >=
//! d_{i+1}`, and then `u = d_i / (d_i - d_{i+1})`. Consecutive segments share a plane, so a walk
//! from a guess never oscillates.
//!
//! **Sector.** In the section at `u` (centre `C = C_i(u)`, normal `n(u)`), the in-plane offset
//! `q = P - C` lies between spokes `a = V_k(u)` and `b = V_{k+1}(u)` when `s1 = o (a x q).n >= 0`
//! and `s2 = o (q x b).n >= 0` (`o` = +1 for spokes counter-clockwise about `n`, -1 clockwise).
//! The ray from `C` through `P` meets the wall edge at `l = s1 / (s1 + s2)`.
//!
//! **Signed distance.** With `W = S(i, u, k, l)` and `N` the outward unit normal of `S` at `W`
//! (`o (dS/dl x dS/du)`), `sd = (P - W) . N`: the distance to the wall's tangent plane, negative
//! inside; near a spoke (a corner of the polygonal section) the nearest of the three local
//! wall strips or the tip line between them, so corners are exact too. A refinement moves the
//! section to the axial position of the foot `P - sd N` and evaluates again, which removes the
//! error of a wall sloped along the tube to second order. The normal is the wall's, never "sample to wall", so it does not flip when
//! the sample crosses the wall.

use crate::spline::Cubic;
use crate::view::TubeView;
use crate::V3;

/// Per-ring data derived lazily each frame.
#[derive(Debug, Clone, Copy, Default)]
pub struct Ring {
    /// Unit normal of the ring plane, oriented along the midline.
    pub n: V3,
    /// +1 if spokes run counter-clockwise about `n`, -1 if clockwise.
    pub o: f32,
    /// Largest of four sampled spoke lengths: a size scale for tolerances.
    pub size: f32,
}

/// A ring's plane from `chord`, the chord through its neighbours' control points, and its
/// spokes `0, B/4, B/2, 3B/4`: the unit normal, the spokes' orientation about it and the
/// longest of the four (see [`Ring`]). The two "diagonals" cross in the ring's area normal for
/// any planar section (O(1), where the full area normal costs O(B)), oriented along the chord;
/// the chord itself stands in where the ring is collapsed or lies nearly along the midline
/// (|cos| <= 0.1). Generic so that a model's checks ([`crate::model::Tube::unfold`], in `f64`)
/// read the very planes the detector reads.
#[inline]
pub fn ring_plane<T: nalgebra::RealField + Copy>(chord: nalgebra::Vector3<T>, s: [nalgebra::Vector3<T>; 4]) -> (nalgebra::Vector3<T>, T, T) {
    let size2 = s.iter().map(|v| v.norm_squared()).fold(T::zero(), |a, b| a.max(b));
    let area = (s[2] - s[0]).cross(&(s[3] - s[1]));
    let (an2, tn2) = (area.norm_squared(), chord.norm_squared());
    let at = area.dot(&chord);
    let o = if at < T::zero() { -T::one() } else { T::one() };
    // Squared comparisons: one square root per ring on the common path.
    let n = if an2 > nalgebra::convert::<f64, T>(1e-12) * size2 * size2 && an2 > T::zero() && (tn2 == T::zero() || at * at > nalgebra::convert::<f64, T>(0.01) * an2 * tn2) {
        area * (o / an2.sqrt())
    } else if tn2 > T::zero() {
        chord / tn2.sqrt()
    } else {
        nalgebra::Vector3::x()
    };
    (n, o, size2.sqrt())
}

/// Lazily computed, frame-stamped cubics and rings of one tube: only what the rod's samples
/// touch is computed, so a frame costs what the rod needs, not what the tube holds.
#[derive(Debug, Clone, Default)]
pub struct TubeCache {
    stamp: u32,
    seg_stamp: Vec<u32>,
    cubic: Vec<Cubic>,
    ring_stamp: Vec<u32>,
    ring: Vec<Ring>,
    inner_stamp: Vec<u32>,
    inner: Vec<Inner>,
    /// Per ring: the frame it was last compared in, and its control point and spokes then, kept
    /// across frames to tell a ring that changed ([`TubeCache::inner_bound`]); and how near its
    /// control point its wall edges come, at least.
    seen_stamp: Vec<u32>,
    seen_rings: Vec<[f32; 3]>,
    near: Vec<f32>,
    /// Per ring: bumped each time its spokes change (0: never seen), and the version its `near`
    /// was computed from; per segment, the two rings' versions its [`Inner`] was computed from.
    version: Vec<u32>,
    near_from: Vec<u32>,
    inner_from: Vec<[u32; 2]>,
    /// Per segment: this frame's [`TubeCache::slope_near`], and the reach it was asked for.
    slope_stamp: Vec<u32>,
    slope: Vec<(f32, f32)>,
    /// The last window [`TubeCache::slope_near`] read whole or in part: the next one, a sample
    /// further along, mostly overlaps it.
    slope_window: SlopeWindow,
    /// Per ring: this frame's [`TubeCache::plane_offset`].
    off_stamp: Vec<u32>,
    off: Vec<f32>,
    pub alpha: f32,
}

/// Segments `lo ..= hi` whose largest [`Inner::slope`] is `max`, at segment `at`, in frame
/// `stamp` (0: none).
#[derive(Debug, Clone, Copy, Default)]
struct SlopeWindow {
    stamp: u32,
    lo: usize,
    hi: usize,
    max: f32,
    at: usize,
}

/// What bounds how steeply a segment's wall runs along the tube and how far its sections differ
/// ([`TubeCache::inner_bound`], [`TubeCache::slope_near`]).
#[derive(Debug, Clone, Copy, Default)]
struct Inner {
    /// Largest change of one spoke from ring `seg` to ring `seg + 1`.
    delta: f32,
    /// `delta` per length of midline chord between the rings (infinite for a zero chord or
    /// a NaN): the wall's slope along the tube, bounded.
    slope: f32,
}

/// Where a point is along the tube.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Axial {
    /// Between rings `seg` and `seg + 1`, at `u`.
    In { seg: usize, u: f32 },
    /// Before the first ring's plane.
    BeforeStart,
    /// Past the last ring's plane.
    AfterEnd,
    /// No bracketing planes within the search window.
    Lost,
}

/// The signed gap of a point to the wall, with everything a contact needs.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Gap {
    /// Signed distance from the point to the wall: negative inside the tube.
    pub sd: f32,
    /// Outward unit normal of the wall at `wall`.
    pub normal: V3,
    /// Wall point (local coordinates).
    pub wall: V3,
    pub seg: usize,
    pub u: f32,
    /// First spoke of the sector.
    pub k: usize,
    /// Position between spokes `k` and `k + 1`.
    pub l: f32,
    /// The sector walk found the section not star-shaped.
    pub not_star: bool,
    /// Squared distance of the point from the midline point of its section.
    pub rho2: f32,
    /// Size scale of the section (largest sampled spoke of its two rings).
    pub size: f32,
    /// Whether the point lies outside the section's wall edge in its sector, seen along the
    /// section's normal (the sector test). Where the wall slopes steeply along the tube, this
    /// side holds where the sign of `sd` (that of a tangent plane) may not.
    pub outside: bool,
}

impl Gap {
    /// Weights of tips (seg, k), (seg, k+1), (seg+1, k), (seg+1, k+1).
    pub fn weights(&self) -> [f32; 4] {
        let (u, l) = (self.u, self.l);
        [(1.0 - u) * (1.0 - l), (1.0 - u) * l, u * (1.0 - l), u * l]
    }
}

/// A section reading, or the word that the point is clear of the wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reading {
    /// The point is within reach of a wall (or the case was too close to call): its gap.
    Gap(Gap),
    /// Every wall the reading weighs lies more than the reach inside the point: no contact.
    Clear {
        seg: usize,
        /// First spoke of the strip nearest the point (the full reading's [`Gap::k`]).
        k: usize,
        /// Squared distance of the point from the midline point of its section.
        rho2: f32,
        /// Size scale of the section.
        size: f32,
    },
}

impl Reading {
    /// Segment and sector: where next frame's walk starts.
    pub fn place(&self) -> (usize, usize) {
        match *self {
            Reading::Gap(g) => (g.seg, g.k),
            Reading::Clear { seg, k, .. } => (seg, k),
        }
    }

    /// Squared distance from the section's midline point, and the section's size scale.
    pub fn spread(&self) -> (f32, f32) {
        match *self {
            Reading::Gap(g) => (g.rho2, g.size),
            Reading::Clear { rho2, size, .. } => (rho2, size),
        }
    }
}

/// How much farther than the reach, squared, a candidate must lie for the clearance test to
/// call it clear without the full reading: a margin for the rounding of comparing squares
/// where the full reading compares square roots (relative, ~1e-7 each).
const CLEAR_SLACK: f32 = 1.0 + 1e-4;

/// What a section holds around a point before its distance is taken (see [`TubeCache::gap`]).
#[derive(Debug, Clone, Copy)]
struct Around {
    seg: usize,
    u: f32,
    /// Midline point of the section and its derivative along the tube.
    c: V3,
    cprime: V3,
    /// Section normal (unnormalised) and orientation of the spokes about it.
    n: V3,
    o: f32,
    /// `p - c`, and the in-plane direction the sector was found by.
    d: V3,
    q: V3,
    /// The sector and the ray's place across it.
    k: usize,
    l: f32,
    /// Spokes `k - 1 .. k + 2`, at `u`, and their change along the tube.
    idx: [usize; 4],
    vs: [V3; 4],
    ds: [V3; 4],
    not_star: bool,
    scale: f32,
}

/// Segments either side of a sample's own that [`TubeCache::slope_near`] reads at most (its
/// reach, unless rings lie denser than that across it).
pub const SLOPE_SEGMENTS: usize = 512;

/// Where a point at signed distances `d0` and `d1` from the planes of rings `i` and `i + 1`
/// (`d0 >= 0 >= d1`: they bracket it) lies along segment `i`: `u = d0 / (d0 - d1)`.
#[inline]
fn between(d0: f32, d1: f32) -> f32 {
    let den = d0 - d1;
    if den > 0.0 {
        (d0 / den).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Spoke `k + 1` of a ring of `b` spokes, for `k < b`: a compare, where `% b` would divide.
#[inline]
pub fn next(k: usize, b: usize) -> usize {
    if k + 1 >= b {
        0
    } else {
        k + 1
    }
}

/// Spoke `k - 1` of a ring of `b` spokes, for `k < b`.
#[inline]
pub fn prev(k: usize, b: usize) -> usize {
    if k == 0 {
        b - 1
    } else {
        k - 1
    }
}

/// A unit vector perpendicular to unit `n`.
#[inline]
pub fn any_perpendicular(n: V3) -> V3 {
    let a = if n.x.abs() < 0.577 {
        V3::x()
    } else if n.y.abs() < 0.577 {
        V3::y()
    } else {
        V3::z()
    };
    n.cross(&a).normalize()
}

impl TubeCache {
    /// Starts a new frame for a tube of `rings` rings: every cached value becomes stale.
    pub fn begin(&mut self, rings: usize, alpha: f32) {
        if self.ring.len() != rings || self.alpha != alpha {
            self.seg_stamp.clear();
            self.seg_stamp.resize(rings.saturating_sub(1), 0);
            self.cubic.resize(rings.saturating_sub(1), Cubic::default());
            self.ring_stamp.clear();
            self.ring_stamp.resize(rings, 0);
            self.ring.resize(rings, Ring::default());
            self.inner_stamp.clear();
            self.inner_stamp.resize(rings.saturating_sub(1), 0);
            self.inner.resize(rings.saturating_sub(1), Inner::default());
            self.seen_stamp.clear();
            self.seen_stamp.resize(rings, 0);
            self.near.resize(rings, 0.0);
            self.seen_rings.clear();
            self.version.clear();
            self.version.resize(rings, 0);
            self.near_from.clear();
            self.near_from.resize(rings, 0);
            self.inner_from.clear();
            self.inner_from.resize(rings.saturating_sub(1), [0; 2]);
            self.slope_stamp.clear();
            self.slope_stamp.resize(rings.saturating_sub(1), 0);
            self.slope.resize(rings.saturating_sub(1), (0.0, 0.0));
            self.slope_window = SlopeWindow::default();
            self.off_stamp.clear();
            self.off_stamp.resize(rings, 0);
            self.off.resize(rings, 0.0);
            self.alpha = alpha;
            self.stamp = 0;
        }
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            // Wrapped: clear so no stale entry can match.
            self.seg_stamp.iter_mut().for_each(|s| *s = 0);
            self.ring_stamp.iter_mut().for_each(|s| *s = 0);
            self.inner_stamp.iter_mut().for_each(|s| *s = 0);
            self.seen_stamp.iter_mut().for_each(|s| *s = 0);
            self.slope_stamp.iter_mut().for_each(|s| *s = 0);
            self.off_stamp.iter_mut().for_each(|s| *s = 0);
            self.slope_window = SlopeWindow::default();
            self.stamp = 1;
        }
    }

    /// The midline cubic of segment `i`.
    #[inline]
    pub fn cubic(&mut self, t: &TubeView, i: usize) -> Cubic {
        if self.seg_stamp[i] != self.stamp {
            self.cubic[i] = Cubic::of_chain(|j| t.point(j), t.rings, i, self.alpha);
            self.seg_stamp[i] = self.stamp;
        }
        self.cubic[i]
    }

    /// Ring `i`'s plane.
    #[inline]
    pub fn ring(&mut self, t: &TubeView, i: usize) -> Ring {
        if self.ring_stamp[i] != self.stamp {
            self.ring[i] = self.compute_ring(t, i);
            self.ring_stamp[i] = self.stamp;
        }
        self.ring[i]
    }

    /// How far ring `i`'s spokes stand off its plane (normal [`Ring::n`]) at most,
    /// `max_k |w_k . n|` (0 for a planar ring). Every point `m w_j + l w_k` of the ring's wall
    /// and spokes (`m, l >= 0`, `m + l <= 1`, relative to its control point) lies within it of
    /// the plane, so `|q . n|` less it bounds the distance from `q` to all of them from below,
    /// whatever the spokes.
    pub fn plane_offset(&mut self, t: &TubeView, i: usize) -> f32 {
        if self.off_stamp[i] != self.stamp {
            let n = self.ring(t, i).n;
            self.off[i] = t.spokes_of(i).iter().fold(0.0f32, |m, w| m.max((w[0] * n.x + w[1] * n.y + w[2] * n.z).abs()));
            self.off_stamp[i] = self.stamp;
        }
        self.off[i]
    }

    /// A lower bound on the distance from the midline point of segment `seg`'s section at `u`
    /// to every point of that section's wall edges (scene's unit; 0 where none can be given).
    ///
    /// A wall point of the section is `E = (1 - u) E0 + u E1`, with `E0`, `E1` the points at the
    /// same place on the edges of rings `seg` and `seg + 1` (relative to their control points),
    /// and `|E1 - E0| <= delta`, the largest change of one spoke between them, so
    /// `|E| >= max(near0 - u delta, near1 - (1 - u) delta)`, each ring's `near` its shortest
    /// spoke less half its longest edge (an edge point lies within half the edge of one of its
    /// ends). Rings and segments are computed once a frame, those that are asked for (`O(B)`
    /// each, over the ring's contiguous spokes).
    pub fn inner_bound(&mut self, t: &TubeView, seg: usize, u: f32) -> f32 {
        let (near0, near1) = (self.near_of(t, seg), self.near_of(t, seg + 1));
        let delta = self.inner_of(t, seg).delta;
        let bound = (near0 - u * delta).max(near1 - (1.0 - u) * delta);
        // Negated on purpose: NaN (a degenerate ring) bounds nothing.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(bound > 0.0) {
            return 0.0;
        }
        bound
    }

    /// Ring `i`'s version: checked once a frame against the ring last seen (one compare of
    /// the ring's bytes: its control point and spokes, since what is derived from a segment
    /// reads the chord between control points too) and bumped where it changed, so what is
    /// derived from a ring is computed again only where it changed. The colonoscopy moves a
    /// few rings a frame; most of a frame's rings are as they were.
    #[inline]
    fn version_of(&mut self, t: &TubeView, i: usize) -> u32 {
        if self.seen_stamp[i] != self.stamp {
            let b = t.spokes + 1;
            if self.seen_rings.len() != self.near.len() * b {
                self.seen_rings.clear();
                self.seen_rings.resize(self.near.len() * b, [0.0; 3]);
                self.version.iter_mut().for_each(|v| *v = 0);
                self.near_from.iter_mut().for_each(|v| *v = 0);
                self.inner_from.iter_mut().for_each(|f| *f = [0; 2]);
            }
            let now = t.ring_of(i);
            let kept = &mut self.seen_rings[i * b..(i + 1) * b];
            if self.version[i] == 0 || !same_bits(kept, now) {
                kept.copy_from_slice(now);
                self.version[i] = self.version[i].wrapping_add(1).max(1);
            }
            self.seen_stamp[i] = self.stamp;
        }
        self.version[i]
    }

    /// Ring `i`'s `near` (see [`TubeCache::inner_bound`]), computed again only where the ring
    /// changed.
    #[inline]
    fn near_of(&mut self, t: &TubeView, i: usize) -> f32 {
        let v = self.version_of(t, i);
        if self.near_from[i] != v {
            self.near[i] = ring_near(t.spokes_of(i));
            self.near_from[i] = v;
        }
        self.near[i]
    }

    /// A bound on how steeply the wall runs along the tube within `along` (scene's unit) of
    /// segment `seg`: the largest change of one spoke between neighbouring rings per length of
    /// midline between them, over the segments within reach (at most [`SLOPE_SEGMENTS`] either
    /// side). A wall point `x` along the tube from a section lies at most `s x` nearer the
    /// midline than that section's wall, so a point `D` from its section's wall is at least
    /// `D / sqrt(1 + s^2)` from the wall there (where the midline runs straight; a bend adds
    /// the spokes' turn to `s`, which only makes the bound more cautious).
    pub fn slope_near(&mut self, t: &TubeView, seg: usize, along: f32) -> f32 {
        if self.slope_stamp[seg] == self.stamp && self.slope[seg].0 == along {
            return self.slope[seg].1;
        }
        let chord = (t.point(seg + 1) - t.point(seg)).norm();
        let n = if chord > 0.0 { ((along / chord).ceil() as usize).min(SLOPE_SEGMENTS) } else { SLOPE_SEGMENTS };
        let (lo, hi) = (seg.saturating_sub(n), (seg + n).min(t.segments() - 1));
        // The largest over the part shared with the last window is that window's, where its
        // largest lies in the part: only the segments new to this window are read.
        let w = self.slope_window;
        let (mut s, mut at) = (0.0f32, lo);
        let shared = w.stamp == self.stamp && lo <= w.at && w.at <= hi;
        if shared {
            (s, at) = (w.max, w.at);
        }
        for j in lo..=hi {
            if shared && w.lo <= j && j <= w.hi {
                continue;
            }
            let v = self.inner_of(t, j).slope;
            if v > s {
                (s, at) = (v, j);
            }
        }
        self.slope_window = SlopeWindow { stamp: self.stamp, lo, hi, max: s, at };
        self.slope[seg] = (along, s);
        self.slope_stamp[seg] = self.stamp;
        s
    }

    /// Segment `seg`'s [`Inner`], computed again only where one of its rings changed.
    #[inline]
    fn inner_of(&mut self, t: &TubeView, seg: usize) -> Inner {
        if self.inner_stamp[seg] != self.stamp {
            let from = [self.version_of(t, seg), self.version_of(t, seg + 1)];
            if self.inner_from[seg] != from {
                self.inner[seg] = compute_inner(t, seg);
                self.inner_from[seg] = from;
            }
            self.inner_stamp[seg] = self.stamp;
        }
        self.inner[seg]
    }

    fn compute_ring(&self, t: &TubeView, i: usize) -> Ring {
        // The chord through the neighbours orients the ring (and stands in for a collapsed one):
        // the spline's own tangent would cost a whole segment's coefficients per ring.
        let chord = t.point((i + 1).min(t.rings - 1)) - t.point(i.saturating_sub(1));
        let b = t.spokes;
        let (n, o, size) = ring_plane(chord, [t.spoke(i, 0), t.spoke(i, b / 4), t.spoke(i, b / 2), t.spoke(i, 3 * b / 4)]);
        Ring { n, o, size }
    }

    /// Signed distance of `p` to ring `i`'s plane (positive on the side the midline goes on).
    /// Always inlined: a walk reads three or four planes a sample, and a call costs more than the
    /// cached plane's dot product (docs/decisions/detect.md).
    #[inline(always)]
    pub(crate) fn plane(&mut self, t: &TubeView, i: usize, p: &V3) -> f32 {
        let r = self.ring(t, i);
        (p - t.point(i)).dot(&r.n)
    }

    /// Finds the segment holding `p`, walking at most `window` segments from `guess`.
    pub fn axial(&mut self, t: &TubeView, p: &V3, guess: usize, window: usize) -> Axial {
        let last = t.segments() - 1;
        let mut i = guess.min(last);
        let mut d0 = self.plane(t, i, p);
        let mut d1 = self.plane(t, i + 1, p);
        for _ in 0..=window {
            if d0 < 0.0 {
                if i == 0 {
                    return Axial::BeforeStart;
                }
                i -= 1;
                d1 = d0;
                d0 = self.plane(t, i, p);
            } else if d1 > 0.0 {
                if i == last {
                    return Axial::AfterEnd;
                }
                i += 1;
                d0 = d1;
                d1 = self.plane(t, i + 1, p);
            } else {
                // On ring `i`'s plane exactly (a sample placed on a ring), segments `i - 1` and
                // `i` both hold it: the lower one answers, whichever way the walk came, so a
                // session's history cannot pick between them.
                if d0 == 0.0 && i > 0 {
                    let before = self.plane(t, i - 1, p);
                    if before >= 0.0 {
                        return Axial::In { seg: i - 1, u: between(before, d0) };
                    }
                }
                return Axial::In { seg: i, u: between(d0, d1) };
            }
        }
        Axial::Lost
    }

    /// Calls `f(self, seg, u)` for every segment within `reach` of `around` whose ring planes
    /// bracket `p`, in order along the tube: the segments where [`TubeCache::axial`] with no
    /// step finds `p` (on a ring's plane, both segments it divides), at the same `u`, reading
    /// each ring's plane once (a walk per segment would read two or three).
    pub fn brackets(&mut self, t: &TubeView, p: &V3, around: usize, reach: usize, mut f: impl FnMut(&mut Self, usize, f32)) {
        let lo = around.saturating_sub(reach);
        let hi = (around + reach).min(t.segments() - 1);
        let mut d0 = self.plane(t, lo, p);
        for i in lo..=hi {
            let d1 = self.plane(t, i + 1, p);
            // The walk's "no step" case: neither behind ring i nor past ring i + 1 (so a NaN
            // distance brackets, as it does there).
            if !(d0 < 0.0 || d1 > 0.0) {
                f(self, i, between(d0, d1));
            }
            d0 = d1;
        }
    }

    /// The signed gap of `p` in segment `seg` at `u`, starting the sector walk at `k_guess`
    /// (`None`: estimate from the angle), with `refine` re-projections.
    pub fn gap(&mut self, t: &TubeView, p: &V3, seg: usize, u: f32, k_guess: Option<usize>, refine: u32) -> Gap {
        let mut g = self.gap_once(t, p, seg, u, k_guess);
        for _ in 0..refine {
            // The foot on the wall tells where along the tube the nearest point really is;
            // evaluate the point itself again in that section.
            let foot = p - g.normal * g.sd;
            let Axial::In { seg, u } = self.axial(t, &foot, g.seg, 2) else { break };
            let h = self.gap_once(t, p, seg, u, Some(g.k));
            g = Gap { not_star: g.not_star | h.not_star, ..h };
        }
        g
    }

    fn gap_once(&mut self, t: &TubeView, p: &V3, seg: usize, u: f32, k_guess: Option<usize>) -> Gap {
        self.around(t, p, seg, u, k_guess, true).gap(p)
    }

    /// The signed gap of `p` in segment `seg` at `u` to strip `k` (spokes `k`, `k + 1`) alone,
    /// whichever sector holds `p`: its face where `p` faces it, else the nearer of its tips,
    /// read as from inside. Another wall of the section than its own sector's
    /// ([`crate::around`]).
    pub fn gap_in_strip(&mut self, t: &TubeView, p: &V3, seg: usize, u: f32, k: usize) -> Gap {
        self.around(t, p, seg, u, Some(k), false).gap_on_strip(p)
    }

    /// The signed gap of `p` in segment `seg` at `u` (no re-projection), unless every wall the
    /// reading weighs lies more than `reach` inside the point: then only its sector
    /// ([`Reading::Clear`]). The test takes the same candidates as the full reading, compared
    /// squared (no square root, no wall point); a case within rounding of `reach`, or degenerate,
    /// gets the full reading, so a point it calls clear reads `sd < -reach` there too.
    pub fn gap_or_clear(&mut self, t: &TubeView, p: &V3, seg: usize, u: f32, k_guess: Option<usize>, reach: f32) -> Reading {
        let a = self.around(t, p, seg, u, k_guess, true);
        match a.clear_by(p, reach) {
            Some(k) => Reading::Clear { seg, k, rho2: a.d.norm_squared(), size: a.scale },
            None => Reading::Gap(a.gap(p)),
        }
    }

    /// The section at `u` of segment `seg` around `p`: its sector (found by a walk from
    /// `k_guess` where `walk`, else `k_guess` itself) and the four spokes about it.
    fn around(&mut self, t: &TubeView, p: &V3, seg: usize, u: f32, k_guess: Option<usize>, walk: bool) -> Around {
        let b = t.spokes;
        let cubic = self.cubic(t, seg);
        let (r0, r1) = (self.ring(t, seg), self.ring(t, seg + 1));
        let o = if r0.size > 0.0 { r0.o } else { r1.o };
        let c = cubic.at(u);
        // The section normal; only signs are taken against it, so it is left unnormalised.
        let mut n = r0.n * (1.0 - u) + r1.n * u;
        if n.norm_squared() < 1e-12 {
            n = r0.n;
        }
        let spoke = |k: usize| t.spoke(seg, k) * (1.0 - u) + t.spoke(seg + 1, k) * u;
        let tiny2 = (1e-6 * r0.size.max(r1.size)).powi(2);
        // Direction of spoke k for the sector walk: a zero-length spoke has none, so it takes
        // the bisector of its neighbours and splits their wedge (its tip is the centre).
        let dir = |k: usize| {
            let v = spoke(k);
            if v.norm_squared() > tiny2 {
                v
            } else {
                let (l, r) = (spoke(prev(k, b)), spoke(next(k, b)));
                l.try_normalize(0.0).unwrap_or(l) + r.try_normalize(0.0).unwrap_or(r)
            }
        };
        let d = p - c;
        let scale = r0.size.max(r1.size);
        // Signs of (a x q).n do not depend on q's component along n, so the offset `d` itself
        // serves as the in-plane direction `q`, unless it lies on the midline's axis.
        let mut q = d;
        if d.cross(&n).norm_squared() <= (1e-6 * scale).powi(2) * n.norm_squared() {
            // On the midline: every direction is as near; take the first spoke's, deterministically.
            q = spoke(0);
            if q.norm_squared() == 0.0 {
                q = any_perpendicular(n.normalize());
            }
        }
        let mut k = match k_guess {
            Some(k) if k < b => k,
            _ => {
                let a0 = dir(0);
                let ang = (o * a0.cross(&q).dot(&n)).atan2(a0.dot(&q));
                let f = ang.rem_euclid(std::f32::consts::TAU) / std::f32::consts::TAU;
                ((f * b as f32) as usize).min(b - 1)
            }
        };
        // Sector walk; a reversal of direction means the section is not star-shaped here.
        let (mut a, mut bb) = (dir(k), dir(next(k, b)));
        let mut last_step = 0i32;
        let mut not_star = false;
        let (mut s1, mut s2);
        let mut steps = 0;
        loop {
            s1 = o * a.cross(&q).dot(&n);
            s2 = o * q.cross(&bb).dot(&n);
            if !walk {
                break;
            }
            let step = if s1 < 0.0 {
                -1
            } else if s2 < 0.0 {
                1
            } else {
                0
            };
            if step == 0 {
                break;
            }
            if step == -last_step || steps >= b {
                not_star = true;
                break;
            }
            last_step = step;
            steps += 1;
            k = if step < 0 { prev(k, b) } else { next(k, b) };
            if step < 0 {
                bb = a;
                a = dir(k);
            } else {
                a = bb;
                bb = dir(next(k, b));
            }
        }
        let den = s1 + s2;
        let l = if den > 0.0 && s1 >= 0.0 && s2 >= 0.0 { (s1 / den).clamp(0.0, 1.0) } else { 0.5 };
        let cprime = cubic.tangent(u);
        // The four spokes around the sector (k-1 .. k+2) and their change along the tube, read
        // once: the three strips k-1, k, k+1 are all the distance needs.
        let idx = [prev(k, b), k, next(k, b), next(next(k, b), b)];
        let mut vs = [V3::zeros(); 4];
        let mut ds = [V3::zeros(); 4];
        for (j, &kk) in idx.iter().enumerate() {
            let (s0, s1) = (t.spoke(seg, kk), t.spoke(seg + 1, kk));
            vs[j] = s0 * (1.0 - u) + s1 * u;
            ds[j] = s1 - s0;
        }
        Around { seg, u, c, cprime, n, o, d, q, k, l, idx, vs, ds, not_star, scale }
    }
}

/// Whether two runs of spokes hold the same bits: one `memcmp` of their bytes, where a float
/// compare per value costs ten times as much (and calls a NaN changed every frame).
#[inline]
fn same_bits(a: &[[f32; 3]], b: &[[f32; 3]]) -> bool {
    let bytes = |s: &[[f32; 3]]| {
        // SAFETY: `[f32; 3]` is 12 bytes with no padding, every byte of it initialised, and `u8`
        // has no invalid values or alignment; the slice borrows `s` for its own lifetime.
        unsafe { std::slice::from_raw_parts(s.as_ptr().cast::<u8>(), std::mem::size_of_val(s)) }
    };
    bytes(a) == bytes(b)
}

/// A ring's `near` (see [`TubeCache::inner_bound`]): its shortest spoke less half its longest
/// edge, from squared lengths (two square roots a ring).
fn ring_near(spokes: &[[f32; 3]]) -> f32 {
    let sq = |v: [f32; 3]| v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    let (mut len2, mut edge2) = (f32::INFINITY, 0.0f32);
    let mut prev = spokes[spokes.len() - 1];
    // Plain comparisons, not `f32::min`/`max` (which weigh NaNs at every step): the frame's
    // values are finite, checked on the way in.
    for &v in spokes {
        let l2 = sq(v);
        let e2 = sq([v[0] - prev[0], v[1] - prev[1], v[2] - prev[2]]);
        len2 = if l2 < len2 { l2 } else { len2 };
        edge2 = if e2 > edge2 { e2 } else { edge2 };
        prev = v;
    }
    len2.sqrt() - 0.5 * edge2.sqrt()
}

/// Segment `seg`'s [`Inner`]: the largest change of a spoke from ring `seg` to `seg + 1`, and
/// per length of the midline chord between them.
fn compute_inner(t: &TubeView, seg: usize) -> Inner {
    let mut delta2 = 0.0f32;
    for (a, b) in t.spokes_of(seg).iter().zip(t.spokes_of(seg + 1)) {
        let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        delta2 = if d2 > delta2 { d2 } else { delta2 };
    }
    let delta = delta2.sqrt();
    let chord = (t.point(seg + 1) - t.point(seg)).norm();
    let slope = delta / chord;
    // Negated on purpose: a NaN or a zero chord bounds nothing.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    let slope = if !(slope < f32::INFINITY) { f32::INFINITY } else { slope };
    Inner { delta, slope }
}

/// The tips (of spokes `0 .. 4` of [`Around::vs`]) a reading weighs, given where the point
/// projects along the three strips (`lam`) and whether no strip faced it (`none_yet`).
///
/// A tip can only be nearer than every strip when the point lies beyond both strips that meet
/// there (in the section, a foot inside a strip is nearer than the strip's ends); degenerate
/// strips (NaN) count as "beyond", and when no strip qualified, as on a collapsed patch, all are
/// tried. The outer tips (ends of the outer strips) count too: with uneven spoke angles the
/// nearest tip can lie a sector further round; the strip beyond them is not read, so only the
/// near side is checked.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn tips_in_play(lam: [f32; 3], none_yet: bool) -> impl Iterator<Item = usize> {
    [(1usize, lam[0], lam[1]), (2, lam[1], lam[2]), (0, f32::NAN, lam[0]), (3, lam[2], f32::NAN)]
        .into_iter()
        // Negated on purpose: NaN (a degenerate strip) counts as beyond.
        .filter(move |&(_, before, after)| none_yet || (!(before < 1.0) && !(after > 0.0)))
        .map(|(jt, _, _)| jt)
}

impl Around {
    /// The spoke of the nearest candidate if every candidate of [`Around::gap`] lies more than
    /// `reach` inside `p` (faces with `h < -reach`, tips farther than `reach` with the point
    /// inside its sector's wall edge); `None` if any does not, or is degenerate or NaN.
    ///
    /// A face's distance `h = e . N / |N|` (`N = w x s_u`, unnormalised) is compared as
    /// `(e . N)^2` against `reach^2 |N|^2`, a tip's as its squared distance: the full reading's
    /// candidates and order, without its square roots and divisions by them.
    fn clear_by(&self, p: &V3, reach: f32) -> Option<usize> {
        let Around { c, cprime, d, idx, vs, ds, scale, .. } = *self;
        let far2 = reach * reach * CLEAR_SLACK;
        // Faces the full reading would call degenerate (|N| <= 1e-12 scale^2), or nearly so.
        let tiny2 = 2.0 * (1e-12 * scale * scale).powi(2);
        let mut best = (f32::INFINITY, idx[1]);
        let mut lam = [0.0f32; 3];
        for j in 0..3 {
            let w;
            (lam[j], w) = self.along_strip(j);
            if (0.0..=1.0).contains(&lam[j]) {
                let nrm = self.face(j, lam[j]);
                let len2 = nrm.norm_squared();
                let h_len = (d - vs[j] - w * lam[j]).dot(&nrm);
                if !(len2 > tiny2 && h_len < 0.0 && h_len * h_len > far2 * len2) {
                    return None;
                }
                let h2 = h_len * h_len / len2;
                if h2 < best.0 {
                    best = (h2, idx[j]);
                }
            }
        }
        let mut tips = false;
        for jt in tips_in_play(lam, best.0 == f32::INFINITY) {
            let tt = cprime + ds[jt];
            let r = p - (c + vs[jt]);
            let tt2 = tt.norm_squared();
            let along = if tt2 > 0.0 { tt * (r.dot(&tt) / tt2) } else { V3::zeros() };
            let perp2 = (r - along).norm_squared();
            // Negated on purpose: NaN is not clear.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(perp2 > far2) {
                return None;
            }
            tips = true;
            if perp2 < best.0 {
                best = (perp2, idx[jt]);
            }
        }
        // A tip takes its side from the sector test: any tip in play needs the point inside.
        if tips && self.outside() {
            return None;
        }
        Some(best.1)
    }

    /// Where `d` projects along strip `j` (spokes `j`, `j + 1` of `vs`), and the strip's edge
    /// `w`: inside [0, 1] the point faces the strip; NaN for a degenerate strip.
    #[inline]
    fn along_strip(&self, j: usize) -> (f32, V3) {
        let (va, vb) = (self.vs[j], self.vs[j + 1]);
        let w = vb - va;
        let ww = w.norm_squared();
        (if ww > 0.0 { (self.d - va).dot(&w) / ww } else { f32::NAN }, w)
    }

    /// Outward normal of strip `j` at position `l` along it, unnormalised: `o (w x s_u)`.
    #[inline]
    fn face(&self, j: usize, l: f32) -> V3 {
        let su = self.cprime + self.ds[j] * (1.0 - l) + self.ds[j + 1] * l;
        (self.vs[j + 1] - self.vs[j]).cross(&su) * self.o
    }

    /// The sector test: whether the point lies outside its sector's wall edge, in the section
    /// (a NaN, from a degenerate section, counts as outside).
    #[inline]
    fn outside(&self) -> bool {
        let Around { n, o, d, vs, .. } = *self;
        let inner = o * (vs[2] - vs[1]).cross(&(d - vs[1])).dot(&n);
        inner <= 0.0 || inner.is_nan()
    }

    /// The reading of strip 1 (spoke `k`'s) alone, see [`TubeCache::gap_in_strip`].
    fn gap_on_strip(&self, p: &V3) -> Gap {
        let Around { seg, u, c, cprime, n, d, idx, vs, ds, not_star, scale, .. } = *self;
        let (lam, w) = self.along_strip(1);
        let base = Gap { seg, u, not_star, rho2: d.norm_squared(), size: scale, outside: false, ..Gap::default() };
        if (0.0..=1.0).contains(&lam) {
            let nrm = self.face(1, lam);
            let len = nrm.norm();
            if len > 1e-12 * scale * scale && len > 0.0 {
                let nf = nrm / len;
                let h = (d - vs[1] - w * lam).dot(&nf);
                return Gap { sd: h, normal: nf, wall: p - nf * h, k: idx[1], l: lam, ..base };
            }
        }
        // Beyond an end of the strip (or a strip with no normal): its nearer tip's line.
        let jt = if lam < 0.5 { 1 } else { 2 };
        let tip = c + vs[jt];
        let along = (cprime + ds[jt]).try_normalize(0.0).map_or(V3::zeros(), |dir| dir * (p - tip).dot(&dir));
        let perp = p - tip - along;
        let dist = perp.norm();
        let normal = if dist > 1e-6 * scale { -perp / dist } else { (vs[jt] - n * (vs[jt].dot(&n) / n.norm_squared())).try_normalize(0.0).unwrap_or_else(|| any_perpendicular(n.normalize())) };
        Gap { sd: -dist, normal, wall: tip + along, k: idx[jt], l: 0.0, ..base }
    }

    /// The full reading: the nearest of the three local strips or of the tips between them.
    fn gap(&self, p: &V3) -> Gap {
        let Around { seg, u, c, cprime, n, o, d, q, k, l, idx, vs, ds, mut not_star, scale } = *self;
        // Outward unit normal of strip j (spokes j, j+1 of `vs`) at position `l` along it.
        let face_normal = |j: usize, l: f32| -> Option<V3> {
            let nrm = self.face(j, l);
            let len = nrm.norm();
            (len > 1e-12 * scale * scale && len > 0.0).then(|| nrm / len)
        };
        // Fallback direction where the wall has no normal (collapsed patch).
        let radial = || {
            let qp = q - n * (q.dot(&n) / n.norm_squared());
            qp.try_normalize(0.0).unwrap_or_else(|| any_perpendicular(n.normalize()))
        };
        // The nearest of the three local strips (face region) or of the tip lines between them
        // (vertex region), so convex and concave corners of the polygonal section are exact, not
        // only its flat parts. The side comes from a face's own normal when a face is nearest;
        // at a vertex, from the section itself: which side of the wall edge of its sector the
        // point lies, seen along the section normal. A star-shaped section crosses each ray
        // from its centre once, so this holds at any distance, where a vertex's pseudo-normal
        // (extrapolated along a tip line that twists) does not.
        // (distance, sign, spoke, l, outward normal, wall point)
        let mut best = (f32::INFINITY, 1.0f32, k, l, V3::zeros(), c);
        let mut vertex: Option<V3> = None;
        // Where the point projects along each strip: inside [0, 1] it faces the strip; beyond
        // both ends of neighbouring strips it faces the tip between them.
        let mut lam = [0.0f32; 3];
        for j in 0..3 {
            // A wedge turning backwards is a fold: the section is not star-shaped here.
            not_star |= o * vs[j].cross(&vs[j + 1]).dot(&n) < 0.0;
            let w;
            (lam[j], w) = self.along_strip(j);
            if (0.0..=1.0).contains(&lam[j]) {
                if let Some(nf) = face_normal(j, lam[j]) {
                    let h = (d - vs[j] - w * lam[j]).dot(&nf);
                    if h.abs() < best.0 {
                        best = (h.abs(), h.signum(), idx[j], lam[j], nf, p - nf * h);
                    }
                }
            }
        }
        for jt in tips_in_play(lam, best.0 == f32::INFINITY) {
            let tip = c + vs[jt];
            let tt = cprime + ds[jt];
            let r = p - tip;
            let along = tt.try_normalize(0.0).map_or(V3::zeros(), |dir| dir * r.dot(&dir));
            let perp = r - along;
            let dist = perp.norm();
            if dist < best.0 {
                best = (dist, 1.0, idx[jt], 0.0, V3::zeros(), tip + along);
                vertex = Some(perp);
            }
        }
        let outside = self.outside();
        if let Some(perp) = vertex {
            let sign = if outside { 1.0 } else { -1.0 };
            best.1 = sign;
            best.4 = if best.0 > 1e-6 * scale { perp / best.0 * sign } else { radial() };
        }
        let d_mid2 = (p - c).norm_squared();
        let (d, sign, k, l, normal, wall) = best;
        Gap { sd: sign * d, normal, wall, seg, u, k, l, not_star, rho2: d_mid2, size: scale, outside }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tube of `rings` rings of 8 spokes along x, 1 apart, the radii varying by up to
    /// `wobble` without a pattern, and by three times that at ring 20 (a fold a window slides
    /// past).
    fn tube(rings: usize, wobble: f32) -> Vec<f32> {
        let mut data = Vec::new();
        for i in 0..rings {
            data.extend([i as f32, 0.0, 0.0]);
            for k in 0..8 {
                let a = k as f32 * std::f32::consts::TAU / 8.0;
                let fold = if i == 20 { 3.0 * wobble } else { 0.0 };
                let r = 10.0 + fold + wobble * ((i * i * 31 + k * 17) % 97) as f32 / 97.0;
                data.extend([0.0, r * a.cos(), r * a.sin()]);
            }
        }
        data
    }

    /// On rings whose spokes leave their plane by up to `tilt` (0: planar), the plane offset
    /// bounds the distance from any point to every point of the ring's wall and spokes from
    /// below, and is 0 on planar rings.
    #[test]
    fn the_plane_offset_bounds_the_distance_to_a_rings_wall_and_spokes() {
        let rings = 12;
        let mut lcg = 12345u32;
        let mut unit = || {
            lcg = lcg.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (lcg >> 8) as f32 / (1u32 << 24) as f32
        };
        for tilt in [0.0, 0.5, 3.0] {
            let mut data = tube(rings, 2.0);
            for (i, ring) in data.chunks_exact_mut(27).enumerate() {
                ring[1] += 0.05 * (i * i) as f32; // a midline that bends
                for w in ring[3..].chunks_exact_mut(3) {
                    w[0] += tilt * (2.0 * unit() - 1.0);
                }
            }
            let t = TubeView::new(&data, rings, 8, V3::zeros());
            let mut cache = TubeCache::default();
            cache.begin(rings, 0.5);
            let mut tight = 0;
            for i in 0..rings {
                let (n, off) = (cache.ring(&t, i).n, cache.plane_offset(&t, i));
                if tilt == 0.0 {
                    assert!(off < 1e-3, "ring {i}: planar spokes off their plane by {off}");
                }
                for _ in 0..200 {
                    let q = V3::new(30.0 * unit() - 15.0, 30.0 * unit() - 15.0, 30.0 * unit() - 15.0);
                    let bound = q.dot(&n).abs() - off;
                    let (j, m, l) = ((unit() * 8.0) as usize % 8, unit(), unit());
                    let (m, l) = if m + l > 1.0 { (1.0 - m, 1.0 - l) } else { (m, l) };
                    let wall = t.spoke(i, j) * m + t.spoke(i, (j + 1) % 8) * l;
                    let d = (q - wall).norm();
                    assert!(d >= bound - 1e-4, "ring {i}, tilt {tilt}: a wall point {d} from q, the bound {bound}");
                    tight += (d < bound + 1.0) as usize;
                }
            }
            // The bound is no vacuous one: often within a millimetre of the true distance.
            assert!(tight > 0, "tilt {tilt}");
        }
    }

    /// Asked in any order, with reaches that differ, `slope_near` gives what a fresh cache
    /// gives each segment alone (which reads its whole window), frame after frame.
    #[test]
    fn slope_near_reusing_the_last_window_equals_reading_it_whole() {
        let rings = 60;
        let asks: Vec<(usize, f32)> = (0..58).chain((0..58).rev()).chain([5, 40, 6, 39, 57, 0, 30, 31, 29]).map(|s| (s, if s % 5 == 0 { 7.5 } else { 3.0 })).collect();
        let mut warm = TubeCache::default();
        for (frame, wobble) in [0.0, 4.0, 9.0, 4.0].into_iter().enumerate() {
            let data = tube(rings, wobble);
            let t = TubeView::new(&data, rings, 8, V3::zeros());
            warm.begin(rings, 0.5);
            for &(seg, along) in &asks {
                let mut fresh = TubeCache::default();
                fresh.begin(rings, 0.5);
                let (w, f) = (warm.slope_near(&t, seg, along), fresh.slope_near(&t, seg, along));
                assert_eq!(w.to_bits(), f.to_bits(), "frame {frame}, segment {seg}, reach {along}: {w} against {f}");
            }
        }
    }
}
