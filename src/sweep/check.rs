//! Full-model checks of a sweep's averaged points: after the grid (and its refinement), a random
//! share of the points the averaged slow model served, and every one of them whose `r` lies
//! within a band about the boundary level, are run again with the full model (journal kind
//! `chk`, so a resumed or merged sweep does not run them twice). A check integrates every
//! forcing period, whatever the sweep's `[run] envelope`: it is the judge, and envelope following
//! can tip a slide near its stability limit into stick-slip (`docs/methods.md`). Each comparison is written to
//! the HDF5 file (group `tier_check`) and summed up in the sweep's summary:
//!
//! - within `r`: `|r_averaged − r_full| ≤` [`R_TOL`] (docs/model.md's accuracy of `r`);
//! - within force: `|mean_averaged / mean_full − 1| ≤` [`FORCE_TOL`] (of the mean force);
//! - side change: the two `r` lie on opposite sides of the boundary level.
//!
//! A point that fails any of the three is **replaced** by its full run in every result of the
//! file (its `tier` then reads 0 with reason `check`). The random share is drawn by a hash of
//! the point's flat index, so it is the same on every machine, in every shard and on resuming.
//!
//! The boundary level is the `[refine]` level where `r` is refined, else r = 0.05
//! ([`ELIMINATED`](super::boundary::ELIMINATED)).

pub use super::plan::{Comparison, FORCE_TOL, R_TOL, replaced};
use super::plan::{Plan, Results, averaged_run, check_level as level, compare, measured};
use super::spec::SweepSpec;
use crate::output::{self, OutputError, h5err};
use std::path::Path;

/// Whether point `i` is in the random share `share`: a 64-bit mix (SplitMix64's finaliser) of
/// its index, as a number in [0, 1), below `share`.
pub fn sampled(i: usize, share: f64) -> bool {
    let mut z = (i as u64).wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    ((z >> 11) as f64 / (1u64 << 53) as f64) < share
}

/// Whether point `i` is drawn in the random share of a sweep whose plan has `with_vibration`
/// points with vibration.
fn random_share(spec: &SweepSpec, with_vibration: usize, i: usize) -> bool {
    with_vibration >= spec.check.min_points && sampled(i, spec.check.share)
}

/// The grid points with vibration.
fn with_vibration(plan: &Plan) -> usize {
    plan.points.iter().filter(|p| p.vibrates()).count()
}

/// The points among those `owned` to check: each averaged point with measures in the random
/// share, or with `r` within the band about the level.
pub fn points(spec: &SweepSpec, plan: &Plan, res: &Results, owned: &[bool]) -> Vec<usize> {
    let lv = plan.check_level;
    let n = with_vibration(plan);
    (0..plan.points.len())
        .filter(|&i| owned[i] && averaged_run(res, i).is_some())
        .filter(|&i| {
            let rf = measured(res.refs[plan.point_ref[i]].as_ref());
            let r = match (averaged_run(res, i), rf) {
                (Some(a), Some(b)) => crate::sim::reduction(&a.measures, &b.measures).0,
                _ => f64::NAN,
            };
            random_share(spec, n, i) || (r - lv).abs() <= spec.check.band
        })
        .collect()
}

/// Every comparison of the sweep so far, by point.
pub fn comparisons(spec: &SweepSpec, plan: &Plan, res: &Results) -> Vec<Comparison> {
    let n = with_vibration(plan);
    (0..plan.points.len())
        .filter_map(|i| compare(plan, res, i, random_share(spec, n, i)))
        .collect()
}

/// The checks of a sweep summed up.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    /// Points the averaged model served (alone or between hybrid windows).
    pub averaged: usize,
    /// Of them, served with hybrid windows.
    pub hybrid: usize,
    /// Of them, checked with the full model.
    pub checked: usize,
    /// Checked and within [`R_TOL`] in `r`.
    pub within_r: usize,
    /// Checked and within [`FORCE_TOL`] in the mean force.
    pub within_force: usize,
    /// Checked with `r` on the other side of the level.
    pub side_changes: usize,
    /// Replaced by their full runs.
    pub replaced: usize,
}

impl Summary {
    /// One line for the sweep's summary.
    pub fn line(&self) -> String {
        let averaged = if self.hybrid > 0 {
            format!(
                "{} points averaged ({} with hybrid windows)",
                self.averaged, self.hybrid
            )
        } else {
            format!("{} points averaged", self.averaged)
        };
        if self.checked == 0 {
            return format!("{averaged}, none checked with the full model");
        }
        let pc = |n: usize| 100.0 * n as f64 / self.checked as f64;
        format!(
            "{averaged}, {} checked with the full model: {:.1} % within |dr| <= {R_TOL}, \
             {:.1} % within {} % in mean force, {} boundary side changes; {} replaced by their full runs",
            self.checked,
            pc(self.within_r),
            pc(self.within_force),
            FORCE_TOL * 100.0,
            self.side_changes,
            self.replaced
        )
    }
}

/// The summary of the checks so far.
pub fn summary(spec: &SweepSpec, plan: &Plan, res: &Results) -> Summary {
    let c = comparisons(spec, plan, res);
    Summary {
        averaged: (0..plan.points.len())
            .filter(|&i| averaged_run(res, i).is_some())
            .count(),
        hybrid: (0..plan.points.len())
            .filter(|&i| averaged_run(res, i).is_some_and(|r| r.tier == crate::sim::Tier::Hybrid))
            .count(),
        checked: c.len(),
        within_r: c.iter().filter(|c| c.within_r).count(),
        within_force: c.iter().filter(|c| c.within_force).count(),
        side_changes: c.iter().filter(|c| c.side_change).count(),
        replaced: c.iter().filter(|c| c.replaced()).count(),
    }
}

/// Writes group `tier_check` of the sweep file: one entry per comparison (`point`, `random`,
/// `r_averaged`, `r_full`, `mean_force_averaged`, `mean_force_full`, `within_r`,
/// `within_force`, `side_change`, `replaced`; absent where nothing was checked) and the summary
/// and rules as attributes. Written where any point was averaged.
pub fn write_h5(
    file: &rust_hdf5::H5File,
    spec: &SweepSpec,
    plan: &Plan,
    res: &Results,
    path: &Path,
) -> Result<(), OutputError> {
    let s = summary(spec, plan, res);
    if s.averaged == 0 {
        return Ok(());
    }
    let e = h5err(path);
    let c = comparisons(spec, plan, res);
    let g = file.create_group("tier_check").map_err(&e)?;
    let col = |f: &dyn Fn(&Comparison) -> f64| c.iter().map(f).collect::<Vec<f64>>();
    let b = |x: bool| f64::from(u8::from(x));
    for (name, data, unit, doc) in [
        (
            "point",
            col(&|c| c.point as f64),
            "1",
            "flat (C-order) index of the checked grid point",
        ),
        (
            "random",
            col(&|c| b(c.random)),
            "1",
            "1 where drawn in the random share, 0 where checked for its r near the level",
        ),
        ("r_averaged", col(&|c| c.r.0), "1", "r of the averaged run"),
        ("r_full", col(&|c| c.r.1), "1", "r of the full run"),
        (
            "mean_force_averaged",
            col(&|c| c.mean_force.0),
            "N",
            "mean drive force of the averaged run",
        ),
        (
            "mean_force_full",
            col(&|c| c.mean_force.1),
            "N",
            "mean drive force of the full run",
        ),
        (
            "within_r",
            col(&|c| b(c.within_r)),
            "1",
            "1 where |r_averaged - r_full| <= r_tol",
        ),
        (
            "within_force",
            col(&|c| b(c.within_force)),
            "1",
            "1 where the mean forces differ by at most force_tol (relative)",
        ),
        (
            "side_change",
            col(&|c| b(c.side_change)),
            "1",
            "1 where the two r lie on opposite sides of the level",
        ),
        (
            "replaced",
            col(&|c| b(c.replaced())),
            "1",
            "1 where the full run replaces the averaged one in the file's results",
        ),
    ] {
        // No comparison: the group holds its attributes only (an HDF5 dataset needs data).
        if !data.is_empty() {
            output::write_vec(&g, name, &data, unit, doc, path)?;
        }
    }
    for (k, v) in [
        ("averaged_points", s.averaged as f64),
        ("checked", s.checked as f64),
        ("within_r", s.within_r as f64),
        ("within_force", s.within_force as f64),
        ("side_changes", s.side_changes as f64),
        ("replaced", s.replaced as f64),
        ("r_tol", R_TOL),
        ("force_tol", FORCE_TOL),
        ("share", spec.check.share),
        ("min_points", spec.check.min_points as f64),
        ("band", spec.check.band),
        ("level", level(spec)),
    ] {
        g.set_attr_numeric(k, &v).map_err(&e)?;
    }
    g.set_attr_string("summary", &s.line()).map_err(&e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The random share is about the share asked for; none at 0, all at 1.
    #[test]
    fn the_random_share_is_close_to_its_rate() {
        let n = 200_000;
        let hits = (0..n).filter(|&i| sampled(i, 0.01)).count();
        // Binomial: 2000 ± 44.5; five standard deviations.
        assert!((hits as f64 - 2000.0).abs() < 5.0 * 44.5, "{hits}");
        assert!(!(0..1000).any(|i| sampled(i, 0.0)));
        assert!((0..1000).all(|i| sampled(i, 1.0)));
    }
}
