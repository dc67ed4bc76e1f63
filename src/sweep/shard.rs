//! Shards: a sweep split into `N` disjoint parts that run anywhere (Slurm array tasks, hosts
//! reached by `ssh`, one machine at different times) and are merged into the file a single
//! machine would have written.
//!
//! Shard `I` of `N` of the sweep whose output is `OUT.h5` lives in the folder `OUT.h5.shards/`:
//!
//! | file | while running | when complete |
//! |---|---|---|
//! | `I-of-N.h5` | checkpoint of the shard's points (others NaN, status −1) | the shard's points, `sweep_status = "complete"` |
//! | `I-of-N.h5.journal` | one line per finished run (the sweep journal) | gone |
//! | `I-of-N.runs` | absent | the journal, renamed: every run of the shard, bit-exact |
//!
//! **Partition.** The grid points are put in a scrambled order (a bijective 64-bit mix of the
//! flat index, [`scramble`]) and dealt round-robin: shard `I` owns the points at positions
//! `I, I + N, I + 2N, ...`. The cost of a run varies by orders of magnitude across a map (with
//! frequency, amplitude and the drive), usually in smooth regions; dealing a scrambled order
//! gives every shard the same number of points (±1) drawn from every region alike, so the
//! shards' expected costs are equal whatever the cost landscape, where blocks of the grid would
//! give one shard all the expensive corner. Each shard makes the runs without vibration its
//! points need (a reference shared by several shards is made by each of them: the same numbers).
//!
//! A `[refine]` sweep shards by plane (every combination of the axes other than `along` and
//! `across`), planes dealt the same way: the refinement of a plane depends only on that plane's
//! runs, so a shard refines its planes exactly as a single machine would. With
//! `[refine] guide_planes` the planes along that dimension guide each other, so they are dealt
//! together, a group to a shard.

use super::spec::SweepSpec;
use std::path::{Path, PathBuf};

/// Shard `index` of `count` (`index` from 0 to `count − 1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Shard {
    /// Which part, from 0.
    pub index: usize,
    /// How many parts, from 1 to [`MAX_SHARDS`].
    pub count: usize,
}

/// The largest number of shards (a Slurm array's size is bounded by `MaxArraySize`, 1001 by
/// default; large sites raise it).
pub const MAX_SHARDS: usize = 100_000;

impl std::str::FromStr for Shard {
    type Err = String;
    /// Parses `I/N`.
    fn from_str(s: &str) -> Result<Shard, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("`{s}` is not of the form I/N (for example 0/4)"))?;
        let parse = |x: &str, what: &str| {
            x.trim()
                .parse::<usize>()
                .map_err(|_| format!("`{s}`: {what} `{x}` is not a whole number"))
        };
        let (index, count) = (parse(i, "I")?, parse(n, "N")?);
        if count == 0 || count > MAX_SHARDS {
            return Err(format!("`{s}`: N must be from 1 to {MAX_SHARDS}"));
        }
        if index >= count {
            return Err(format!("`{s}`: I must be from 0 to N - 1 = {}", count - 1));
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl Shard {
    /// The shard's HDF5 file for the sweep output `out`: `OUT.shards/I-of-N.h5`.
    pub fn path(&self, out: &Path) -> PathBuf {
        self.path_in(&dir_for(out))
    }

    /// The shard's HDF5 file in folder `dir`: `DIR/I-of-N.h5`.
    pub fn path_in(&self, dir: &Path) -> PathBuf {
        dir.join(format!("{}-of-{}.h5", self.index, self.count))
    }
}

/// The folder of the shards of sweep output `out`: `OUT.shards` (for `OUT.h5`,
/// `OUT.h5.shards`).
pub fn dir_for(out: &Path) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".shards");
    PathBuf::from(s)
}

/// The record of a complete shard beside its HDF5 file `h5`: `I-of-N.runs`.
pub fn runs_path(h5: &Path) -> PathBuf {
    h5.with_extension("runs")
}

/// A bijective mix of a 64-bit index (splitmix64's finaliser): a fixed, well-spread order.
pub fn scramble(i: u64) -> u64 {
    let mut z = i.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The owner (0 to `count − 1`) of each of `items` things dealt in scrambled order.
fn deal(items: usize, count: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..items).collect();
    order.sort_unstable_by_key(|&i| scramble(i as u64));
    let mut owner = vec![0; items];
    for (pos, &i) in order.iter().enumerate() {
        owner[i] = pos % count;
    }
    owner
}

/// The flat index of each grid point of a `[refine]` sweep over the dimensions other than
/// `along`, `across` and `skip`, and how many such indices there are.
fn flat_over_others(spec: &SweepSpec, skip: Option<usize>) -> (Vec<usize>, usize) {
    let rf = spec.refine.as_ref().expect("a refined sweep");
    let along = spec.along_dim().expect("the refined axis has a dimension");
    let shape = spec.shape();
    let other: Vec<usize> = (0..shape.len())
        .filter(|&k| k != along && Some(k) != rf.across && Some(k) != skip)
        .collect();
    let count = other.iter().map(|&k| shape[k]).product::<usize>();
    let flat = (0..spec.len())
        .map(|i| {
            let idx = spec.unravel(i);
            other.iter().fold(0, |acc, &k| acc * shape[k] + idx[k])
        })
        .collect();
    (flat, count)
}

/// The plane of each grid point of a `[refine]` sweep: the flat index over the dimensions
/// other than `along` and `across`.
pub fn planes(spec: &SweepSpec) -> (Vec<usize>, usize) {
    flat_over_others(spec, None)
}

/// The group of planes of each grid point of a `[refine]` sweep: its plane, or, with
/// `guide_planes`, the flat index over the dimensions other than `along`, `across` and the
/// guiding one (the planes that guide each other stay in one shard).
pub fn groups(spec: &SweepSpec) -> (Vec<usize>, usize) {
    let guide = spec.refine.as_ref().and_then(|r| r.guide_planes);
    flat_over_others(spec, guide)
}

/// The units a sweep is dealt in: grid points, or planes (groups of planes with
/// `guide_planes`) for a `[refine]` sweep.
pub fn units(spec: &SweepSpec) -> usize {
    match spec.refine {
        None => spec.len(),
        Some(_) => groups(spec).1,
    }
}

/// The owner of every grid point (see the module docs).
pub fn owners(spec: &SweepSpec, count: usize) -> Vec<usize> {
    match spec.refine {
        None => deal(spec.len(), count),
        Some(_) => {
            let (group, n) = groups(spec);
            let by_group = deal(n, count);
            group.into_iter().map(|p| by_group[p]).collect()
        }
    }
}

/// Checks that a sweep can be split into `count` shards: a `[refine]` sweep has at least that
/// many planes, any sweep at least that many points.
pub fn check(spec: &SweepSpec, count: usize) -> Result<(), String> {
    let n = units(spec);
    if count > n {
        let what = if spec
            .refine
            .as_ref()
            .is_some_and(|r| r.guide_planes.is_some())
        {
            "groups of planes (a [refine] sweep with guide_planes is sharded by the planes that guide each other: every combination of the axes other than `along`, `across` and `guide_planes`)"
        } else if spec.refine.is_some() {
            "planes (a [refine] sweep is sharded by plane: every combination of the axes other than `along` and `across`)"
        } else {
            "grid points"
        };
        return Err(format!(
            "{count} shards asked for, but the sweep has {n} {what}; use at most {n}"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_refuse_with_the_rule() {
        assert_eq!("3/8".parse::<Shard>(), Ok(Shard { index: 3, count: 8 }));
        for bad in ["8/8", "0/0", "1", "a/2", "-1/2", "1/2/3"] {
            let e = bad.parse::<Shard>().unwrap_err();
            assert!(e.contains(bad), "{e}");
        }
    }

    #[test]
    fn dealing_is_balanced_disjoint_and_spread() {
        let owner = deal(1000, 7);
        let mut counts = [0usize; 7];
        for &o in &owner {
            counts[o] += 1;
        }
        assert!(counts.iter().all(|&c| c == 142 || c == 143), "{counts:?}");
        // Not blocks: the first tenth of the grid holds points of every shard, about equally.
        let mut head = [0usize; 7];
        for &o in &owner[..100] {
            head[o] += 1;
        }
        assert!(head.iter().all(|&c| (6..=24).contains(&c)), "{head:?}");
    }

    #[test]
    fn scramble_is_a_bijection_on_a_sample() {
        let mut v: Vec<u64> = (0..100_000).map(scramble).collect();
        v.sort_unstable();
        v.dedup();
        assert_eq!(v.len(), 100_000);
    }
}
