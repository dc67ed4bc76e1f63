//! How a plan chooses its recordings among the design space's candidates: a [`Strategy`],
//! the greedy maximin of the discrimination criterion ([`super::criterion`]) or a uniform
//! random draw, the baseline a plan must beat. A new criterion is a variant here with its
//! choice, and its option in [`super::types::PlanOptions`].

use super::criterion::{Existing, Rows, carriers, discrimination};
use super::rivals::Rival;
use super::space::Candidate;
use super::types::{Outcome, PairGain, PlanOptions, Planned};
use crate::campaign::Campaign;
use rand::{SeedableRng, rngs::StdRng};
use rayon::prelude::*;

/// How a plan chooses its recordings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Each recording maximises, given those chosen before it, the smallest discrimination over
    /// the open pairs, ties broken by the sum over pairs (module docs of [`super`]).
    Maximin,
    /// Distinct candidates drawn uniformly, seeded ([`PlanOptions::seed`]); nothing simulated.
    Random,
}

impl Strategy {
    /// The strategy `opts` asks for ([`PlanOptions::random`]).
    pub fn of(opts: &PlanOptions) -> Strategy {
        if opts.random {
            Strategy::Random
        } else {
            Strategy::Maximin
        }
    }
}

/// `min(D_ab, D_ba)` of each open pair for the planned set `chosen` (finalist indices).
fn pair_scores(
    open: &[(usize, usize)],
    rows: &[Vec<Vec<Rows>>],
    ex: &[Existing],
    delta0: &[Vec<f64>],
    chosen: &[usize],
) -> Vec<(f64, f64)> {
    open.iter()
        .map(|&(a, b)| {
            let d = |i: usize, j: usize| {
                let planned: Vec<&Rows> = chosen.iter().map(|&x| &rows[x][i][j]).collect();
                discrimination(&ex[j], &planned, &delta0[j]).nats
            };
            (d(a, b), d(b, a))
        })
        .collect()
}

/// What the choice of recordings weighs: the rivals and their open pairs, the candidates and
/// the finalists among them (indices into `cands`), the rows of every (finalist, truth,
/// rival), the existing recordings and each rival's refit on them alone.
pub(crate) struct Choice<'a> {
    pub rivals: &'a [Rival],
    pub open: &'a [(usize, usize)],
    pub cands: &'a [Candidate],
    pub fin: &'a [usize],
    pub rows: &'a [Vec<Vec<Rows>>],
    pub ex: &'a [Existing<'a>],
    pub delta0: &'a [Vec<f64>],
}

impl Choice<'_> {
    /// Expected ln odds for every ordered pair once the `chosen` finalists are recorded.
    // `i` and `j` index the rivals, each finalist's rows and the existing recordings alike.
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn outcomes(&self, chosen: &[usize]) -> Vec<Outcome> {
        let (rivals, rows, ex, delta0) = (self.rivals, self.rows, self.ex, self.delta0);
        let r = rivals.len();
        let now = |i: usize, j: usize| rivals[i].ln_odds - rivals[j].ln_odds;
        let mut outcomes = vec![];
        for i in 0..r {
            for j in 0..r {
                if i == j {
                    continue;
                }
                let planned_rows: Vec<&Rows> = chosen.iter().map(|&y| &rows[y][i][j]).collect();
                let d = discrimination(&ex[j], &planned_rows, &delta0[j]).nats;
                outcomes.push(Outcome {
                    truth: i,
                    other: j,
                    now: now(i, j),
                    expected: now(i, j) + d,
                    simulated: None,
                    simulated_stderr: None,
                    clear: None,
                });
            }
        }
        outcomes
    }

    /// The recordings chosen one after another by the maximin ([`super::criterion`]), each
    /// with the finalist it is (an index into `fin`).
    pub(crate) fn maximin(&self, c: &Campaign, recordings: usize) -> (Vec<usize>, Vec<Planned>) {
        let (open, rows, ex, delta0) = (self.open, self.rows, self.ex, self.delta0);
        let (rivals, cands, fin) = (self.rivals, self.cands, self.fin);
        let mut chosen: Vec<usize> = vec![];
        let mut before = pair_scores(open, rows, ex, delta0, &chosen);
        let mut planned = vec![];
        for step in 0..recordings {
            let best = (0..fin.len())
                .into_par_iter()
                .filter(|x| !chosen.contains(x))
                .map(|x| {
                    let mut with = chosen.clone();
                    with.push(x);
                    let s = pair_scores(open, rows, ex, delta0, &with);
                    let worst = s.iter().map(|p| p.0.min(p.1)).fold(f64::INFINITY, f64::min);
                    let sum: f64 = s.iter().map(|p| p.0.min(p.1)).sum();
                    (x, worst, sum, s)
                })
                .reduce_with(|a, b| {
                    // Larger worst pair, then larger sum, then the lower index: deterministic.
                    let ka = (a.1, a.2);
                    let kb = (b.1, b.2);
                    match kb.0.total_cmp(&ka.0).then(kb.1.total_cmp(&ka.1)) {
                        std::cmp::Ordering::Greater => b,
                        std::cmp::Ordering::Less => a,
                        std::cmp::Ordering::Equal => {
                            if a.0 < b.0 {
                                a
                            } else {
                                b
                            }
                        }
                    }
                })
                .expect("finalists outnumber the recordings planned");
            let (x, _, _, after) = best;
            // The pair worst told apart before it.
            let wp = (0..open.len())
                .min_by(|&p, &q| {
                    before[p]
                        .0
                        .min(before[p].1)
                        .total_cmp(&before[q].0.min(before[q].1))
                })
                .expect("at least one open pair");
            let (a, b) = open[wp];
            // Its weaker direction, and the features carrying this recording's share of it.
            let (ti, tj) = if after[wp].0 <= after[wp].1 {
                (a, b)
            } else {
                (b, a)
            };
            let mut with = chosen.clone();
            with.push(x);
            let planned_rows: Vec<&Rows> = with.iter().map(|&y| &rows[y][ti][tj]).collect();
            let d = discrimination(&ex[tj], &planned_rows, &delta0[tj]);
            let (_, by) = d.per_planned.last().expect("the new recording").clone();
            let carry = carriers(&by, 3);
            let gains: Vec<PairGain> = open
                .iter()
                .enumerate()
                .map(|(p, &pair)| PairGain {
                    pair,
                    nats: after[p].0.min(after[p].1) - before[p].0.min(before[p].1),
                })
                .collect();
            let cand = cands[fin[x]];
            let name = unique_name(
                c,
                &planned,
                &format!("plan{:02}_{}", step + 1, cand.label()),
            );
            let why = sentence(
                &cand,
                &rivals[tj].name,
                &rivals[ti].name,
                &carry,
                gains[wp].nats,
            );
            planned.push(Planned {
                name,
                candidate: cand,
                gains,
                chosen_for: (a, b),
                carriers: carry,
                why,
            });
            chosen.push(x);
            before = after;
        }
        (chosen, planned)
    }
}

/// `recordings` distinct candidates of `cands` drawn uniformly (a shuffle seeded by `seed`),
/// nothing simulated.
pub(crate) fn draw(
    c: &Campaign,
    cands: &[Candidate],
    open: &[(usize, usize)],
    recordings: usize,
    seed: u64,
) -> Vec<Planned> {
    use rand::seq::SliceRandom;
    let mut idx: Vec<usize> = (0..cands.len()).collect();
    idx.shuffle(&mut StdRng::seed_from_u64(seed));
    let mut planned: Vec<Planned> = vec![];
    for (step, &k) in idx.iter().take(recordings).enumerate() {
        let x = cands[k];
        let name = unique_name(c, &planned, &format!("rand{:02}_{}", step + 1, x.label()));
        planned.push(Planned {
            name,
            candidate: x,
            gains: vec![],
            chosen_for: open.first().copied().unwrap_or((0, 0)),
            carriers: vec![],
            why: "drawn at random from the design space (the baseline a plan must beat)".into(),
        });
    }
    planned
}

fn unique_name(c: &Campaign, planned: &[Planned], want: &str) -> String {
    let taken =
        |n: &str| c.recordings.iter().any(|r| r.name == n) || planned.iter().any(|p| p.name == n);
    let mut name = want.to_string();
    let mut k = 2;
    while taken(&name) {
        name = format!("{want}_{k}");
        k += 1;
    }
    name
}

fn sentence(
    x: &Candidate,
    refitted: &str,
    truth: &str,
    carry: &[(&'static str, f64)],
    gain: f64,
) -> String {
    let p = &x.params;
    let at = if p.vibrates() {
        format!(
            "At {:.0} Hz and v_a/v_d = {:.2} (k_d {:.0} N/m, v_d {:.2} mm/s)",
            p.f,
            x.va_ratio(),
            p.k_d,
            p.v_d * 1e3
        )
    } else {
        format!(
            "Without vibration (k_d {:.0} N/m, v_d {:.2} mm/s)",
            p.k_d,
            p.v_d * 1e3
        )
    };
    let feats = if carry.is_empty() {
        "no single feature".to_string()
    } else {
        carry
            .iter()
            .map(|(f, z)| format!("{f} ({z:.1} standard errors)"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "{at}, even refitted to every recording {refitted} misses what {truth} predicts in {feats}: \
         the pair the recordings so far told apart least gains {gain:.1} nats."
    )
}
