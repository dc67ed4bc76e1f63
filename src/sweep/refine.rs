//! Adaptive refinement of a level set (`[refine]`, [`Refine`]): the elimination boundary
//! `r = 0.05` of Fig. 11 resolved finely where it lies instead of everywhere.
//!
//! The refined axis (`along`, say `u0`) holds the dense values; the sweep file's own axis is the
//! coarse grid, every `2^levels`-th dense value. The plane is spanned by `along` and `across`
//! (say `f`), whose values stay as given; it is refined separately for every combination of the
//! other dimensions (the `(f, u0)` plane of each `(v_d, k_d)`). A *column* is one line along
//! `along` (one `f`).
//!
//! Round after round, a step `(j, k)` between neighbouring computed points of a column, at least
//! two dense indices apart, is split (a point inside it is run) when
//! - its ends straddle the level (one below, one at or above it), or
//! - an end lies within `tolerance` of the level (`[refine] tolerance`, default 0): a dip that
//!   reaches the level between grid points, such as the intermittent band near `v_a = v_d`, is
//!   followed instead of bisected away.
//!
//! A column ends with every such step one dense index wide: its crossings, resolved to the dense
//! step. The split point is the midpoint, except in *guided* columns (`[refine] guided`, default
//! true). The boundary moves little from one column to the next (the paper's rule of thumb puts
//! it at `u0 = v_d / (2 pi f)`, a straight line in `log u0` against `log f`), so the crossings
//! of a column's two neighbours, interpolated in the across value (in its logarithm on a
//! logarithmic axis), predict its own: on the overnight sixteenth 84 % of the odd columns cross
//! within one dense step of the interpolation between their even neighbours. So the columns are
//! taken in three passes: every fourth and the last halve their steps alone; then those halfway
//! between (`4i + 2`), guided by the first; then the odd ones, guided by their even neighbours.
//! A guided column waits until both its guides have finished. Where each crossed exactly once,
//! at `b₁` and `b₂`, the interpolation gives the dense index `q` (rounded), and the column's
//! straddling steps are split at `q` and `q + 1`: two runs where the prediction holds, instead of
//! one per halving. Where the crossing lies beyond them, the next point lies as far beyond the
//! step's end again (1, 2, 4, ... dense steps from the prediction), until the search brackets
//! the crossing and halving resolves it. Elsewhere (a guide with no crossing or several, steps
//! only near the level) the guided column halves too. Either way a column ends with crossings
//! one dense step wide.
//!
//! *Guided planes* (`[refine] guide_planes`, a dimension other than the plane's two sides, say
//! `k_d`). Where the boundary hardly moves from one plane to the next along that dimension (on
//! the overnight surface the threshold's `v_a / v_d` changes by a few per cent over a factor of
//! 20 in `k_d`), a plane's columns are predicted by the same columns of planes on either side
//! better than by their neighbours across: counted on the whole overnight surface refined
//! without it, interpolating between the planes on either side (the dyadic order below) puts
//! 84 % of the crossings on the dense step the column finds and 97 % within one, against 56 %
//! and 84 % for the odd columns between their neighbours across. So the planes at the first
//! and the last value of the guiding dimension refine as above, and every other plane `m`
//! takes, for every column, the same column of planes `m − s` and `min(m + s, last)`, `s` the
//! largest power of two dividing `m` (the middle plane from the two ends, the quarters from an
//! end and the middle, and so on), each column waiting until those two have finished. The
//! planes that guide each other make one group, and a sharded sweep deals whole groups.
//!
//! On the coarse grid the *cells* between neighbouring columns of `across` (`i`, `i + 1`) count
//! too: a cell whose four corners straddle the level has its coarse step's midpoint run in both
//! columns, so an island or band that one column's coarse points miss is found from its
//! neighbour (a guided column whose own step straddles there is searched from its guides
//! instead).
//!
//! Corners with no value (a failed run) do not count. A plane's rounds follow from its own values
//! (and its guiding planes' finished columns) alone ([`next_points`]), every point of a round
//! fixed before any of them is run, so the points and numbers do not depend on the thread count
//! or on how far the other planes have got (the sweep asks for a plane's next round as soon as
//! its last one has landed, and again when a plane it waits for lands one), and a resumed
//! sweep, whatever its journal holds, goes on to the same points.

use super::plan::{Plan, Results};
use super::spec::{Refine, SweepSpec};

/// The shape of the dense grid and where the plane lies in it.
struct Layout {
    shape: Vec<usize>,
    along: usize,
    across: Option<usize>,
    guide: Option<usize>,
}

impl Layout {
    fn of(spec: &SweepSpec) -> Layout {
        let rf = spec.refine.as_ref().expect("a refined sweep");
        Layout {
            shape: spec.shape(),
            along: spec.along_dim().expect("the refined axis has a dimension"),
            across: rf.across,
            guide: rf.guide_planes,
        }
    }

    fn flat(&self, idx: &[usize]) -> usize {
        idx.iter()
            .zip(&self.shape)
            .fold(0, |acc, (i, n)| acc * n + i)
    }

    /// The lines along `along`: multi-indices with the along index 0, in C order.
    fn lines(&self) -> Vec<Vec<usize>> {
        let nd = self.shape.len();
        let count: usize = (0..nd)
            .filter(|&k| k != self.along)
            .map(|k| self.shape[k])
            .product();
        let mut out = Vec::with_capacity(count);
        for mut rem in 0..count {
            let mut idx = vec![0usize; nd];
            for k in (0..nd).rev() {
                if k == self.along {
                    continue;
                }
                idx[k] = rem % self.shape[k];
                rem /= self.shape[k];
            }
            out.push(idx);
        }
        out
    }

    /// The dimensions other than `along` and `across`, whose combinations are the planes.
    fn others(&self) -> Vec<usize> {
        (0..self.shape.len())
            .filter(|&k| k != self.along && Some(k) != self.across)
            .collect()
    }

    /// Number of planes.
    fn planes(&self) -> usize {
        self.others().iter().map(|&k| self.shape[k]).product()
    }

    /// The index of plane `p` along the guiding dimension `g`, its count there, and the plane
    /// number's step per index along it.
    fn along_guide(&self, p: usize, g: usize) -> (usize, usize, usize) {
        let step: usize = self
            .others()
            .iter()
            .filter(|&&k| k > g)
            .map(|&k| self.shape[k])
            .product();
        ((p / step) % self.shape[g], self.shape[g], step)
    }

    /// The lines of plane `p` (numbered in C order over [`Layout::others`], as
    /// [`super::shard::planes`] does), by their index across.
    fn plane_lines(&self, p: usize) -> Vec<Vec<usize>> {
        let mut idx = vec![0usize; self.shape.len()];
        let mut rem = p;
        for &k in self.others().iter().rev() {
            idx[k] = rem % self.shape[k];
            rem /= self.shape[k];
        }
        match self.across {
            None => vec![idx],
            Some(c) => (0..self.shape[c])
                .map(|a| {
                    let mut l = idx.clone();
                    l[c] = a;
                    l
                })
                .collect(),
        }
    }
}

/// Flat indices of the coarse grid: every point whose along index is a multiple of the stride.
pub fn coarse_points(spec: &SweepSpec) -> Vec<usize> {
    let rf = spec.refine.as_ref().expect("a refined sweep");
    let lay = Layout::of(spec);
    let stride = rf.stride();
    let mut out = vec![];
    for line in lay.lines() {
        for j in (0..lay.shape[lay.along]).step_by(stride) {
            let mut idx = line.clone();
            idx[lay.along] = j;
            out.push(lay.flat(&idx));
        }
    }
    out.sort_unstable();
    out
}

/// A line's computed points along `along`, in order: dense index and value (NaN where the
/// run has no value).
fn computed(
    lay: &Layout,
    line: &[usize],
    value: &impl Fn(usize) -> Option<f64>,
) -> Vec<(usize, f64)> {
    let mut idx = line.to_vec();
    (0..lay.shape[lay.along])
        .filter_map(|j| {
            idx[lay.along] = j;
            value(lay.flat(&idx)).map(|v| (j, v))
        })
        .collect()
}

/// Where a line stands: its open steps (neighbouring computed points at least two dense
/// indices apart to refine, and whether they straddle the level) and its crossings (neighbouring
/// computed points one index apart that straddle it; the lower index).
struct Line {
    open: Vec<(usize, usize, bool)>,
    crossings: Vec<usize>,
}

/// Whether the finite values among `v` straddle `level` (one below, one at or above it).
fn straddles(v: &[f64], level: f64) -> bool {
    let finite = || v.iter().filter(|x| x.is_finite());
    finite().any(|&x| x < level) && finite().any(|&x| x >= level)
}

impl Line {
    fn of(pts: &[(usize, f64)], rf: &Refine) -> Line {
        let mut open = vec![];
        let mut crossings = vec![];
        for w in pts.windows(2) {
            let ((a, x), (b, y)) = (w[0], w[1]);
            let straddles = straddles(&[x, y], rf.level);
            let near =
                rf.tolerance > 0.0 && [x, y].iter().any(|&v| (v - rf.level).abs() <= rf.tolerance);
            if b - a >= 2 && (straddles || near) {
                open.push((a, b, straddles));
            } else if b - a == 1 && straddles {
                crossings.push(a);
            }
        }
        Line { open, crossings }
    }
}

/// The neighbours across whose crossings guide column `a` of `n` (`guided`, module docs):
/// `None` for the columns refined by halving alone (every fourth and the last).
fn guides(a: usize, n: usize) -> Option<(usize, usize)> {
    if n < 3 || a.is_multiple_of(4) || a + 1 == n {
        None
    } else if !a.is_multiple_of(2) {
        Some((a - 1, a + 1))
    } else {
        Some((a - 2, (a + 2).min(n - 1)))
    }
}

/// The neighbours along `guide_planes` that guide plane `m` of `n` (module docs): `None` for
/// the first and the last, which refine alone; else `(m − s, min(m + s, n − 1))` with `s` the
/// largest power of two dividing `m`, so that the guides of every plane come earlier in the
/// order first and last, then the middle, then the quarters, and so on.
fn dyadic_guides(m: usize, n: usize) -> Option<(usize, usize)> {
    if m == 0 || m + 1 >= n {
        return None;
    }
    let s = 1 << m.trailing_zeros();
    Some((m - s, (m + s).min(n - 1)))
}

/// The two planes whose finished columns guide plane `p`'s (`[refine] guide_planes`, module
/// docs), or `None` (no `guide_planes`, or `p` lies at its first or last value).
pub fn plane_guides(spec: &SweepSpec, p: usize) -> Option<(usize, usize)> {
    let lay = Layout::of(spec);
    let g = lay.guide?;
    let (m, n, step) = lay.along_guide(p, g);
    let (a, b) = dyadic_guides(m, n)?;
    Some((p - (m - a) * step, p + (b - m) * step))
}

/// The points a straddling open step `(lo, hi)` is split at, given the crossing its neighbours
/// predict between `q` and `q + 1`: those two where inside the step; else, the prediction lying
/// beyond the step's end `e`, the point as far beyond `e` again (1, 2, 4, ... dense steps away
/// from the prediction: a search that doubles its stride until it brackets the crossing); else
/// the midpoint.
fn guided_split(lo: usize, hi: usize, q: usize, out: &mut Vec<usize>) {
    let inside: Vec<usize> = [q, q + 1]
        .into_iter()
        .filter(|&j| lo < j && j < hi)
        .collect();
    if !inside.is_empty() {
        out.extend(inside);
        return;
    }
    let cand = if q < lo {
        lo + (lo - q)
    } else {
        // The prediction lies at or above `hi`: its upper point `q + 1` is beyond it.
        hi.saturating_sub(q + 1 - hi)
    };
    out.push(if lo < cand && cand < hi {
        cand
    } else {
        (lo + hi) / 2
    });
}

/// Number of planes the refinement works in (every combination of the dimensions other than
/// `along` and `across`).
pub fn plane_count(spec: &SweepSpec) -> usize {
    Layout::of(spec).planes()
}

/// The points the next round of plane `p` asks for (module docs), none of them computed yet,
/// sorted and without repeats; empty when the plane is done. They depend only on the plane's
/// values computed so far, so its rounds, and its points, are the same at any thread count, in
/// whatever order the planes go, and after a resume.
pub fn next_points(spec: &SweepSpec, plan: &Plan, res: &Results, p: usize) -> Vec<usize> {
    let rf: &Refine = spec.refine.as_ref().expect("a refined sweep");
    let lay = Layout::of(spec);
    let n = lay.shape[lay.along];
    let stride = rf.stride();
    let value = |i: usize| -> Option<f64> {
        let (own, _) = res.point(plan, i);
        own?;
        Some(res.measure(plan, i, rf.measure))
    };
    let at = |line: &[usize], j: usize| {
        let mut idx = line.to_vec();
        idx[lay.along] = j;
        lay.flat(&idx)
    };
    // The plane's columns, by their index across.
    let lines = lay.plane_lines(p);
    let states: Vec<Line> = lines
        .iter()
        .map(|l| Line::of(&computed(&lay, l, &value), rf))
        .collect();
    // The crossings are interpolated in the guiding dimension's values (in their logarithm on a
    // logarithmic axis).
    let pos = |d: usize, i: usize| -> f64 {
        let vals = &spec.axes[spec.dims[d].axes[0]].values;
        if vals.iter().all(|&v| v > 0.0) {
            vals[i].ln()
        } else {
            vals[i]
        }
    };
    let weight = |d: usize, a: usize, b: usize, x: usize| {
        let (xa, xb) = (pos(d, a), pos(d, b));
        if xb != xa {
            (pos(d, x) - xa) / (xb - xa)
        } else {
            0.5
        }
    };
    // Each column's guides: two lines and the weight of the second. Between planes along
    // `guide_planes`, the same column of the two guiding planes; else its neighbours across.
    let between = plane_guides(spec, p).map(|(a, b)| {
        let g = lay.guide.expect("plane guides come from guide_planes");
        let at_g = |q: usize| lay.along_guide(q, g).0;
        let w = weight(g, at_g(a), at_g(b), at_g(p));
        (lay.plane_lines(a), lay.plane_lines(b), w)
    });
    // Per line: the guide lines on either side of it and its weight between them.
    type Guide = (Vec<usize>, Vec<usize>, f64);
    let col_guides: Vec<Option<Guide>> = (0..lines.len())
        .map(|l| {
            if !rf.guided {
                return None;
            }
            if let Some((la, lb, w)) = &between {
                return Some((la[l].clone(), lb[l].clone(), *w));
            }
            let c = lay.across?;
            let (g, h) = guides(l, lay.shape[c])?;
            Some((lines[g].clone(), lines[h].clone(), weight(c, g, h, l)))
        })
        .collect();
    let mut out = vec![];
    for (l, line) in lines.iter().enumerate() {
        let st = &states[l];
        if st.open.is_empty() {
            continue;
        }
        // A guided column waits for its guides to finish, then starts from the crossing they
        // interpolate where each has exactly one.
        let mut predicted = None;
        if let Some((lg, lh, w)) = &col_guides[l] {
            let gs = Line::of(&computed(&lay, lg, &value), rf);
            let hs = Line::of(&computed(&lay, lh, &value), rf);
            if !gs.open.is_empty() || !hs.open.is_empty() {
                continue;
            }
            if let ([bp], [bq]) = (&gs.crossings[..], &hs.crossings[..]) {
                let b = *bp as f64 + w * (*bq as f64 - *bp as f64);
                predicted = Some(b.round().clamp(0.0, (n - 2) as f64) as usize);
            }
        }
        for &(lo, hi, straddles) in &st.open {
            let mut split = vec![];
            match predicted {
                Some(q) if straddles => guided_split(lo, hi, q, &mut split),
                _ => split.push((lo + hi) / 2),
            }
            out.extend(split.into_iter().map(|j| at(line, j)));
        }
    }
    // Cells between neighbouring columns on the coarse grid: where the level passes between
    // two columns inside a coarse step, both columns are refined there, so that an island or
    // band one column misses at its coarse points is found from its neighbour.
    let steps = (0..n.saturating_sub(1))
        .step_by(stride)
        .filter(|&j| j + stride < n);
    for cols in lines.windows(2) {
        for j in steps.clone() {
            let mid = |c: &[usize]| at(c, j + stride / 2);
            if cols.iter().all(|c| value(mid(c)).is_some()) {
                continue;
            }
            let corners: Option<Vec<f64>> = cols
                .iter()
                .flat_map(|c| [at(c, j), at(c, j + stride)])
                .map(&value)
                .collect();
            let Some(corners) = corners else { continue };
            if !straddles(&corners, rf.level) {
                continue;
            }
            for c in cols {
                // A guided column whose own step straddles searches it anyway, from its guides.
                let own = |i: usize| value(at(c, i)).unwrap_or(f64::NAN);
                let straddles = straddles(&[own(j), own(j + stride)], rf.level);
                let guided = lay.across.is_some_and(|x| col_guides[c[x]].is_some());
                if value(mid(c)).is_none() && !(guided && straddles) {
                    out.push(mid(c));
                }
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// The grid points of a sweep's first round among those `owned`: the whole grid, or the coarse
/// grid of a refinement.
pub(crate) fn first_points(spec: &SweepSpec, owned: impl Fn(usize) -> bool) -> Vec<usize> {
    match &spec.refine {
        None => (0..spec.len()).filter(|&i| owned(i)).collect(),
        Some(_) => coarse_points(spec)
            .into_iter()
            .filter(|&i| owned(i))
            .collect(),
    }
}
