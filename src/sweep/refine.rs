//! Adaptive refinement of a level set (`[refine]`, [`Refine`]): the elimination boundary
//! `r = 0.05` of Fig. 11 resolved finely where it lies instead of everywhere.
//!
//! The refined axis (`along`, say `u0`) holds the dense values; the sweep file's own axis is the
//! coarse grid, every `2^levels`-th dense value. The plane is spanned by `along` and `across`
//! (say `f`), whose values stay as given; it is refined separately for every combination of the
//! other dimensions (the `(f, u0)` plane of each `(v_d, k_d)`).
//!
//! Level by level, from steps of `s = 2^levels` dense indices down to `s = 2`, a step
//! `[j, j + s]` of one line along `along` whose ends are computed is refined (its midpoint
//! `j + s/2` is run) when
//! - its ends straddle the level (one below, one at or above it), or
//! - an end lies within `tolerance` of the level (`[refine] tolerance`, default 0): a dip that
//!   reaches the level between grid points, such as the intermittent band near `v_a = v_d`, is
//!   followed instead of bisected away.
//!
//! On the coarse grid the *cells* between neighbouring columns of `across` (`i`, `i + 1`) count
//! too: a cell whose four corners straddle the level is refined in both columns, so an island
//! or band that one column's coarse points miss is found from its neighbour. (Below the coarse
//! level a cell that straddles only between its columns, the boundary passing between two
//! frequencies, would be refined down to the finest step without resolving anything.)
//!
//! Corners with no value (a failed run) do not count. Each level's runs are fixed before any
//! of them is made, and the next level depends only on their values, so the points and numbers
//! do not depend on the thread count; a resumed sweep asks for the same points and finds them in
//! its journal.

use super::spec::{Refine, SweepSpec};
use super::{Plan, Results};

/// The shape of the dense grid and where the plane lies in it.
struct Layout {
    shape: Vec<usize>,
    along: usize,
    across: Option<usize>,
}

impl Layout {
    fn of(spec: &SweepSpec) -> Layout {
        let rf = spec.refine.as_ref().expect("a refined sweep");
        Layout {
            shape: spec.shape(),
            along: spec.along_dim().expect("the refined axis has a dimension"),
            across: rf.across,
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

    /// The cells' column pairs: each line with its neighbour across (or alone).
    fn columns(&self) -> Vec<Vec<Vec<usize>>> {
        self.lines()
            .into_iter()
            .filter_map(|l| match self.across {
                None => Some(vec![l]),
                Some(c) if self.shape[c] == 1 => Some(vec![l]),
                Some(c) if l[c] + 1 < self.shape[c] => {
                    let mut next = l.clone();
                    next[c] += 1;
                    Some(vec![l, next])
                }
                Some(_) => None,
            })
            .collect()
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

/// The points the cells of width `s` (dense indices, a power of two ≥ 2) ask for: the
/// midpoints of every cell to refine (module docs), sorted and without repeats, including
/// points already computed (the caller skips those).
pub fn midpoints(spec: &SweepSpec, plan: &Plan, res: &Results, s: usize) -> Vec<usize> {
    let rf: &Refine = spec.refine.as_ref().expect("a refined sweep");
    let lay = Layout::of(spec);
    let n = lay.shape[lay.along];
    let half = s / 2;
    let value = |i: usize| -> Option<f64> {
        let (own, _) = res.point(plan, i);
        own?;
        Some(res.measure(plan, i, &rf.measure))
    };
    let at = |col: &Vec<usize>, j: usize| {
        let mut idx = col.clone();
        idx[lay.along] = j;
        lay.flat(&idx)
    };
    // The finite values at the ends of step [j, j + s] of each column (None: not both computed).
    let ends = |col: &Vec<usize>, j: usize| -> Option<Vec<f64>> {
        let (a, b) = (value(at(col, j))?, value(at(col, j + s))?);
        Some([a, b].into_iter().filter(|v| v.is_finite()).collect())
    };
    let straddles = |v: &[f64]| v.iter().any(|&x| x < rf.level) && v.iter().any(|&x| x >= rf.level);
    let near =
        |v: &[f64]| rf.tolerance > 0.0 && v.iter().any(|&x| (x - rf.level).abs() <= rf.tolerance);
    let mut out = vec![];
    let steps = (0..n.saturating_sub(1)).step_by(s).filter(|&j| j + s < n);
    for line in lay.lines() {
        for j in steps.clone() {
            if let Some(v) = ends(&line, j)
                && (straddles(&v) || near(&v))
            {
                out.push(at(&line, j + half));
            }
        }
    }
    // On the coarse grid, cells between neighbouring columns too: where the level passes
    // between two columns inside a step, both columns are refined there, so that an island or
    // band one column misses at its coarse points is found from its neighbour.
    if s == rf.stride() {
        for cols in lay.columns().into_iter().filter(|c| c.len() == 2) {
            for j in steps.clone() {
                let (Some(a), Some(b)) = (ends(&cols[0], j), ends(&cols[1], j)) else {
                    continue;
                };
                let corners: Vec<f64> = a.into_iter().chain(b).collect();
                if straddles(&corners) {
                    out.extend(cols.iter().map(|c| at(c, j + half)));
                }
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// The cell widths of the refinement, coarsest first: `2^levels, ..., 4, 2`.
pub fn widths(rf: &Refine) -> Vec<usize> {
    (1..=rf.levels).rev().map(|l| 1usize << l).collect()
}
